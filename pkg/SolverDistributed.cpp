// A distributed run's stages of the solver (Distribution.hpp, doc/parallel.md), and the crack
// transport that reads the nodes of other ranks there: in their own translation unit, so that the
// step's hot passes in Solver.cpp are compiled as before (with them in Solver.cpp GCC generated a
// stress pass of 3 % more instructions for the default 2D step).
#include <algorithm>
#include <cmath>
#include <string>

#include "CrackTransport.hpp"
#include "Errors.hpp"
#include "Solver.hpp"

namespace emp {

template <int D, class K> void Solver<D, K>::distributePoints()
{
    if (!dist_) {
        if (points_.distributed)
            throw ParameterError("EigenMPM: this solver holds rank " + std::to_string(resumeRank_) + "'s part of a run on " +
                                 std::to_string(resumeRanks_) + " ranks (loaded from its archive); resume it under mpiexec -n " +
                                 std::to_string(resumeRanks_) + " (doc/parallel.md)");
        return;
    }
    checkDistributable();  // (something may have been attached since distribute())
    const auto stripOf = [&](const Vec<D>& x) { return Scheduler<D>::template stripOf<K>(x, grid_); };
    // A rank's range of strips must hold erosion's reach (its ghosts come from its neighbours only).
    const int minStrips =
        erosion_ ? std::max(1, static_cast<int>(std::ceil((erosion_->settings().kappa + 2 * grid_.h) /
                                                          (Scheduler<D>::stripWidth * grid_.h))))
                 : 1;
    if (!dist_->partitioned()) {
        std::vector<int> strips(points_.size());
        for (std::size_t p = 0; p < points_.size(); ++p) strips[p] = stripOf(points_.x[p]);
        const int numStrips = Scheduler<D>::template numStrips<K>(grid_);
        dist_->partition(points_, strips, numStrips, S, grid_.n[D - 1]);
        int thinnest = numStrips;
        for (int r = 0; r < dist_->size(); ++r)
            thinnest = std::min(thinnest, dist_->firstStrips()[r + 1] - dist_->firstStrips()[r]);
        require(thinnest >= minStrips, "number of ranks", dist_->size(),
                "one whose thinnest range of strips (" + std::to_string(thinnest) + " x " +
                    std::to_string(Scheduler<D>::stripWidth) + " cells) holds kappa + 2 h (fewer ranks)");
    } else {
        dist_->migrate(points_, stripOf);
        if (rebalancePeriod_ > 0 && steps_ % rebalancePeriod_ == 0 &&
            dist_->rebalance(points_, stripOf, rebalanceTolerance_, minStrips))
            ++rebalances_;
    }
    // The traction points on this rank, by their position in each condition's list.
    tractionLocal_.assign(tractions_.size(), {});
    for (std::size_t t = 0; t < tractions_.size(); ++t)
        for (std::size_t k = 0; k < tractions_[t].points.size(); ++k) {
            const int p = dist_->localIndex(points_, tractions_[t].points[k]);
            if (p >= 0) tractionLocal_[t].emplace_back(p, static_cast<int>(k));
        }
    recordsLeft_.clear();
    recordsRight_.clear();
}

template <int D, class K> void Solver<D, K>::ownedNodes(int& lo, int& hi) const
{
    lo = 0;
    hi = grid_.totalNodes();
    if (!dist_) return;
    lo = dist_->ownedLo() * grid_.stride[D - 1];
    hi = dist_->ownedHi() * grid_.stride[D - 1];
}

template <int D, class K>
void Solver<D, K>::addNodeForce(int I, const Vec<D>& f, std::int64_t key0, std::int64_t key1)
{
    const int side = !dist_ ? 0 : dist_->sharedSide((I < grid_.numNodes() ? I : twinRegular_[I - grid_.numNodes()]) / grid_.stride[D - 1]);
    if (side == 0) {
        grid_.force[I] += f;
        return;
    }
    NodeRecord<D> r{{key0, key1}, I, {}};
    for (int d = 0; d < D; ++d) r.value[d] = f[d];
    (side < 0 ? recordsLeft_ : recordsRight_).push_back(r);
}

template <int D, class K> void Solver<D, K>::transportCracks(double dt)
{
    if (phantom_.empty()) return;
    if (!dist_) {
        emp::transportCracks<D, K>(phantom_, grid_, lp_, dt);
        return;
    }
    // Every rank moves the vertices alike: the nodes the transport reads (the marked ones, and
    // the supports of the vertices) get their owners' values first.
    int lo[D], hi[D];
    for (int d = 0; d < D; ++d) {
        lo[d] = std::min(markedLo_[d], grid_.n[d] - 1);
        hi[d] = std::max(markedHi_[d], 0);
    }
    for (std::size_t c = 0; c < phantom_.numCracks(); ++c)
        for (const Vec<D>& x : phantom_.vertices(static_cast<int>(c)))
            for (int d = 0; d < D; ++d) {
                const int b = K::base((x[d] - grid_.origin[d]) * grid_.invh);
                lo[d] = std::max(0, std::min(lo[d], b));
                hi[d] = std::min(grid_.n[d] - 1, std::max(hi[d], b + S - 1));
            }
    dist_->shareBox(grid_, lo, hi);
    emp::transportCracks<D, K>(phantom_, grid_, lp_, dt);
    dist_->restoreBox(grid_, lo, hi);
}

template <int D, class K> void Solver<D, K>::distribute(std::shared_ptr<Transport> transport)
{
    require(!dist_ && (steps_ == 0 || points_.distributed), "distribute", "called after the first step or twice",
            "once, before the first step (or to resume a rank's part loaded from its archive)");
    checkDistributable();
    initialize();
    auto d = std::make_shared<Distribution<D>>(std::move(transport));
    if (points_.distributed) {
        if (d->size() != resumeRanks_ || d->rank() != resumeRank_)
            require(false, "number of ranks", d->size(),
                    std::to_string(resumeRanks_) + ": this is the archive of rank " + std::to_string(resumeRank_) +
                        " of a run on " + std::to_string(resumeRanks_) + " ranks; resume it with as many");
        d->setRanges(resumeStrips_, S, grid_.n[D - 1]);
    }
    dist_ = d;
    dist_->setPhantomNodes(&phantom_);
}

template <int D, class K> void Solver<D, K>::setRebalance(double tolerance, int period)
{
    require(tolerance >= 1 && std::isfinite(tolerance), "rebalance", tolerance, "1 <= rebalance < inf");
    require(period >= 0, "rebalancePeriod", period, "0 (never) or more steps");
    rebalanceTolerance_ = tolerance;
    rebalancePeriod_ = period;
}

template <int D, class K> void Solver<D, K>::checkDistributable() const
{
    const std::string not_ = "; a distributed run (doc/parallel.md) does not have it yet: run on one process";
    require(!points_.bodies, "bodies", "several", "one" + not_);
    require(!contact_, "contact with YADE bodies", "attached", "none" + not_);
    require(!crackContact_, "crack-face contact", "on", "off" + not_);
    for (const auto& c : conditions_) {
        const bool velocity = std::find_if(velocityConditions_.begin(), velocityConditions_.end(),
                                           [&](const auto& v) { return v == c; }) != velocityConditions_.end();
        require(velocity, "grid condition", "other than a velocity condition", "velocity conditions" + not_);
    }
}

#define EMP_INSTANTIATE(D, K)                                                                     \
    template void Solver<D, K>::distributePoints();                                               \
    template void Solver<D, K>::ownedNodes(int&, int&) const;                                     \
    template void Solver<D, K>::addNodeForce(int, const Vec<D>&, std::int64_t, std::int64_t);     \
    template void Solver<D, K>::transportCracks(double);                                          \
    template void Solver<D, K>::distribute(std::shared_ptr<Transport>);                           \
    template void Solver<D, K>::checkDistributable() const;                                       \
    template void Solver<D, K>::setRebalance(double, int);
EMP_SOLVER_CONFIGURATIONS(EMP_INSTANTIATE)
#undef EMP_INSTANTIATE

}  // namespace emp
