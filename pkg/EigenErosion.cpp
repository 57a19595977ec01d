#include "EigenErosion.hpp"

#include <algorithm>
#include <cmath>

#include "Errors.hpp"
#include "Laws.hpp"

namespace emp {

template <int D> EigenErosion<D>::EigenErosion(const ErosionSettings& s) : settings_(s)
{
    require(std::isfinite(s.Gc) && s.Gc > 0, "Gc (critical energy release rate, J/m2)", s.Gc, "Gc > 0");
    require(std::isfinite(s.alpha) && s.alpha > 0, "alpha (normalising constant)", s.alpha, "alpha > 0");
    require(std::isfinite(s.kappa) && s.kappa > 0, "kappa (neighbourhood radius, m)", s.kappa, "kappa > 0");
}

template <int D>
void EigenErosion<D>::buildList(const MaterialPoints<D>& P, const std::vector<int>& around, double margin)
{
    // Bin only the intact points in the box around `around`, widened by `margin`.
    Vec<D> lo = P.x[around[0]], hi = P.x[around[0]];
    for (int p : around) {
        lo = lo.cwiseMin(P.x[p]);
        hi = hi.cwiseMax(P.x[p]);
    }
    lo.array() -= margin;
    hi.array() += margin;
    binned_.clear();
    const int n = static_cast<int>(P.size());
    for (int q = 0; q < n; ++q)
        if (P.damage[q] > 0 && (P.x[q].array() >= lo.array()).all() && (P.x[q].array() <= hi.array()).all())
            binned_.push_back(q);
    cells_.build(P.x, binned_, settings_.kappa, lo, hi);
}

template <int D> double EigenErosion<D>::rate(const MaterialPoints<D>& P, int p) const
{
    double mh = 0, m = 0;
    cells_.forEachWithin(P.x, P.x[p], settings_.kappa, [&](int q) {
        mh += P.mass[q] * P.history[q];
        m += P.mass[q];
    });
    return m > 0 ? settings_.alpha * settings_.kappa * mh / m : 0.0;  // Eq 23
}

template <int D>
int EigenErosion<D>::apply(MaterialPoints<D>& P, const std::vector<ElasticMaterial>& materials,
                           std::int64_t step, double time, int nThreads)
{
    const ErosionSettings& s = settings_;
    const double hSource = s.Gc / (s.alpha * s.kappa);  // alpha kappa H >= Gc  <=>  H >= hSource
    const int n = static_cast<int>(P.size());
    sources_.clear();
    eroding_.clear();
    before_.clear();
    for (int p = 0; p < n; ++p)
        if (P.history[p] >= hSource && P.damage[p] > 0) sources_.push_back(p);
    searched_ = !sources_.empty();
    candidates_.clear();
    if (!searched_) return 0;

    // Candidates: intact points within kappa of a source (the only ones that can reach Gc).
    buildList(P, sources_, 2.0 * s.kappa);
    if (static_cast<int>(mark_.size()) != n) mark_.assign(n, 0);
    for (int src : sources_)
        cells_.forEachWithin(P.x, P.x[src], s.kappa, [&](int q) {
            if (!mark_[q]) {
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
    for (int k = 0; k < nc; ++k) erode[k] = rate(P, candidates_[k]) >= s.Gc;
    for (int k = 0; k < nc; ++k)
        if (erode[k]) eroding_.push_back(candidates_[k]);
    for (int p : eroding_) {
        const ElasticMaterial& m = materials[P.material[p]];
        before_.push_back(P.stress[p]);
        P.damage[p] = 0.0;
        P.stress[p] = lawResponse<D>(P.strain[p], m).sigmaMinus;  // g(0) sigma+ + sigma-
        dissipated_ += s.Gc / (2.0 * s.kappa) * P.volume[p];                    // Eq 33
        events_.push_back({p, step, time});
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
                mh += P.mass[q] * P.history[q];
                m += P.mass[q];
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
    buildList(P, ids, 2.0 * settings_.kappa);
    for (int p : ids) out.push_back(rate(P, p));
    return out;
}

template class EigenErosion<2>;
template class EigenErosion<3>;

}  // namespace emp
