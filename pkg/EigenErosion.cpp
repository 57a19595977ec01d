#include "EigenErosion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "Errors.hpp"
#include "Laws.hpp"

namespace emp {

template <int D> EigenErosion<D>::EigenErosion(const ErosionSettings& s) : settings_(s)
{
    require(std::isfinite(s.Gc) && s.Gc > 0, "Gc (critical energy release rate, J/m2)", s.Gc, "Gc > 0");
    require(std::isfinite(s.alpha) && s.alpha > 0, "alpha (normalising constant)", s.alpha, "alpha > 0");
    require(std::isfinite(s.kappa) && s.kappa > 0, "kappa (neighbourhood radius, m)", s.kappa, "kappa > 0");
}

namespace {

/// The points eigenerosion sees: this rank's (q < n) and, in a distributed run, the
/// neighbours' ghost points (q >= n). Also the positions array of the cell list.
template <int D> struct Neighbourhood {
    const MaterialPoints<D>& P;
    const GhostPoints<D>* G;
    int n;
    int total() const { return n + (G ? static_cast<int>(G->size()) : 0); }
    const Vec<D>& operator[](int q) const { return q < n ? P.x[q] : G->x[q - n]; }
    double mass(int q) const { return q < n ? P.mass(q) : G->mass[q - n]; }
    double history(int q) const { return q < n ? P.history[q] : G->history[q - n]; }
    double damage(int q) const { return q < n ? P.damage[q] : G->damage[q - n]; }
    /// q in the single-process order: by globalId in a distributed run, else by index.
    std::int64_t order(int q) const { return !G ? q : q < n ? P.globalId[q] : G->id[q - n]; }
};

template <int D> Neighbourhood<D> local(const MaterialPoints<D>& P)
{
    return {P, nullptr, static_cast<int>(P.size())};
}

template <int D> void box(const MaterialPoints<D>& P, const std::vector<int>& ids, Vec<D>& lo, Vec<D>& hi)
{
    lo = hi = P.x[ids[0]];
    for (int p : ids) {
        lo = lo.cwiseMin(P.x[p]);
        hi = hi.cwiseMax(P.x[p]);
    }
}

}  // namespace

template <int D>
template <class V>
void EigenErosion<D>::buildList(const V& view, Vec<D> lo, Vec<D> hi, const PointSupport<D>* rows, const Grid<D>* g)
{
    // Bin only the intact points in the box [lo, hi] widened by 2 kappa, in the single-process
    // order (a cell visits its points in that order, so every sum runs in it).
    const double margin = 2.0 * settings_.kappa;
    lo.array() -= margin;
    hi.array() += margin;
    binned_.clear();
    const auto inBox = [&](int q) {
        return view.damage(q) > 0 && (view[q].array() >= lo.array()).all() && (view[q].array() <= hi.array()).all();
    };
    if (rows && g) {
        // This process's points from the cell rows of the box along the last axis (a row more
        // on each side: the rows hold floor((x - origin) / h)), in increasing id order: the
        // points the scan of all would find, in its order.
        constexpr int last = D - 1;
        const auto row = [&](double x) {
            const double c = std::floor((x - g->origin[last]) * g->invh);
            return static_cast<int>(std::clamp(c, -2.0, static_cast<double>(g->n[last]) + 1.0));
        };
        rows->pointsInRows(row(lo[last]) - 1, row(hi[last]) + 1, rowPoints_);
        for (const int q : rowPoints_)
            if (q < view.n && inBox(q)) binned_.push_back(q);
        for (int q = view.n; q < view.total(); ++q)
            if (inBox(q)) binned_.push_back(q);
    } else {
        const int n = view.total();
        for (int q = 0; q < n; ++q)
            if (inBox(q)) binned_.push_back(q);
    }
    if (view.G) std::inplace_merge(binned_.begin(), std::lower_bound(binned_.begin(), binned_.end(), view.n), binned_.end(),
                                   [&](int a, int b) { return view.order(a) < view.order(b); });
    cells_.build(view, binned_, settings_.kappa, lo, hi);
}

template <int D> template <class V> double EigenErosion<D>::rate(const V& view, int p) const
{
    double mh = 0, m = 0;
    cells_.forEachWithin(view, view[p], settings_.kappa, [&](int q) {
        mh += view.mass(q) * view.history(q);
        m += view.mass(q);
    });
    return m > 0 ? settings_.alpha * settings_.kappa * mh / m : 0.0;  // Eq 23
}

template <int D>
int EigenErosion<D>::apply(MaterialPoints<D>& P, const std::vector<ElasticMaterial>& materials,
                           std::int64_t step, double time, int nThreads, const GhostPoints<D>* ghosts,
                           Transport* transport, const PointSupport<D>* rows, const Grid<D>* g)
{
    const ErosionSettings& s = settings_;
    const int n = static_cast<int>(P.size());
    const Neighbourhood<D> view{P, ghosts, n};
    sources_.clear();
    eroding_.clear();
    before_.clear();
    for (int p = 0; p < n; ++p)  // (alpha kappa H >= Gc  <=>  H >= sourceHistory())
        if (isSource(P.history[p], P.damage[p])) sources_.push_back(p);
    for (int q = n; q < view.total(); ++q)
        if (isSource(view.history(q), view.damage(q))) sources_.push_back(q);
    // The box of the sources (of all ranks in a distributed run: the cells are then the same).
    Vec<D> lo = Vec<D>::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (int q : sources_) {
        lo = lo.cwiseMin(view[q]);
        hi = hi.cwiseMax(view[q]);
    }
    if (transport) {
        double b[2 * D];
        for (int d = 0; d < D; ++d) {
            b[d] = -lo[d];
            b[D + d] = hi[d];
        }
        transport->max(b, 2 * D);
        for (int d = 0; d < D; ++d) {
            lo[d] = -b[d];
            hi[d] = b[D + d];
        }
    }
    searched_ = lo[0] <= hi[0];
    candidates_.clear();
    if (!searched_) return 0;
    // Candidates: this rank's intact points within kappa of a source (the only ones that can
    // reach Gc).
    buildList(view, lo, hi, rows, g);
    if (static_cast<int>(mark_.size()) != n) mark_.assign(n, 0);
    for (int src : sources_)
        cells_.forEachWithin(view, view[src], s.kappa, [&](int q) {
            if (q < n && !mark_[q]) {
                mark_[q] = 1;
                candidates_.push_back(q);
            }
        });
    std::sort(candidates_.begin(), candidates_.end());
    for (int q : candidates_) mark_[q] = 0;
    // G_p (Eq 23) of every candidate, then erosion (Eq 24) of all qualifying points together.
    const int nc = static_cast<int>(candidates_.size());
    std::vector<char> erode(nc, 0);
#pragma omp parallel for schedule(static) num_threads(nThreads)
    for (int k = 0; k < nc; ++k) erode[k] = rate(view, candidates_[k]) >= s.Gc;
    for (int k = 0; k < nc; ++k)
        if (erode[k]) eroding_.push_back(candidates_[k]);
    for (int p : eroding_) {
        const ElasticMaterial& m = materials[P.material[p]];
        Mat<D> eps;
        before_.push_back(P.stressOf(p, materials, &eps));  // (the stress the force used)
        P.damage[p] = 0.0;                                    // g(0) sigma+ + sigma-: stressOf is sigma- now
        const LawResponse<D> r = lawResponse<D>(eps, m);
        P.energy[p] = P.damage[p] * r.psiPlus + r.psiMinus;       // (as the stress pass writes it)
    }
    // The events and the dissipated energy (Eq 33), in the single-process order.
    const double perVolume = s.Gc / (2.0 * s.kappa);
    if (!transport) {
        for (int p : eroding_) {
            dissipated_ += perVolume * P.volume[p];
            events_.push_back({p, step, time});
        }
        return static_cast<int>(eroding_.size());
    }
    Bytes mine;
    for (int p : eroding_) {
        mine.put(P.globalId[p]);
        mine.put(P.volume[p]);
    }
    std::vector<std::pair<std::int32_t, double>> all;
    for (auto& bytes : transport->allGather(mine.data)) {
        Bytes b;
        b.data = std::move(bytes);
        while (!b.done()) {
            const auto id = b.get<std::int32_t>();
            all.emplace_back(id, b.get<double>());
        }
    }
    std::sort(all.begin(), all.end());
    for (const auto& [id, volume] : all) {
        dissipated_ += perVolume * volume;
        events_.push_back({id, step, time});
    }
    return static_cast<int>(eroding_.size());
}

template <int D>
std::vector<double> EigenErosion<D>::energyReleaseRateBruteForce(const MaterialPoints<D>& P,
                                                                 const std::vector<int>& ids) const
{
    std::vector<double> out;
    const double r2 = settings_.kappa * settings_.kappa;
    for (int p : ids) {
        double mh = 0, m = 0;
        for (std::size_t q = 0; q < P.size(); ++q)
            if (P.damage[q] > 0 && (P.x[q] - P.x[p]).squaredNorm() <= r2) {
                mh += P.mass(q) * P.history[q];
                m += P.mass(q);
            }
        out.push_back(m > 0 ? settings_.alpha * settings_.kappa * mh / m : 0.0);
    }
    return out;
}

template <int D>
std::vector<double> EigenErosion<D>::energyReleaseRate(const MaterialPoints<D>& P, const std::vector<int>& ids)
{
    std::vector<double> out;
    if (ids.empty()) return out;
    Vec<D> lo, hi;
    box(P, ids, lo, hi);
    const auto view = local(P);
    buildList(view, lo, hi);
    for (int p : ids) out.push_back(rate(view, p));
    return out;
}

template class EigenErosion<2>;
template class EigenErosion<3>;

}  // namespace emp
