// A distributed run's stages of the solver (Distribution.hpp, doc/parallel.md), and the crack
// transport that reads the nodes of other ranks there: in their own translation unit, so that the
// step's hot passes in Solver.cpp are compiled as before (with them in Solver.cpp GCC generated a
// stress pass of 3 % more instructions for the default 2D step).
#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
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
    const auto columnOf = [&](const Vec<D>& x) { return schedule_.template columnOf<K>(x, grid_); };
    if (!dist_->partitioned()) {
        const int cells = settings_.columnCells, numColumns = cells > 0 ? (grid_.n[0] - S) / cells + 1 : 1;
        dist_->setColumns(rankColumns_, cells, numColumns, grid_.n);
        std::vector<int> strips(points_.size()), columns;
        for (std::size_t p = 0; p < points_.size(); ++p) strips[p] = stripOf(points_.x[p]);
        if (rankColumns_ > 1) {
            columns.resize(points_.size());
            for (std::size_t p = 0; p < points_.size(); ++p) columns[p] = strips[p] >= 0 ? columnOf(points_.x[p]) : 0;
        }
        const int numStrips = Scheduler<D>::template numStrips<K>(grid_);
        if (heldSetup_) {
            dist_->partitionHeld(points_, strips, numStrips, S, grid_.n[D - 1], columns);
        } else {
            globalPoints_ = static_cast<int>(points_.size());
            dist_->partition(points_, strips, numStrips, S, grid_.n[D - 1], columns);
        }
        int thinnest = numStrips;
        for (int r = 0; r < dist_->rows(); ++r)
            thinnest = std::min(thinnest, dist_->firstStrips()[r + 1] - dist_->firstStrips()[r]);
        require(thinnest >= minStrips, "number of ranks", dist_->size(),
                "one whose thinnest range of strips (" + std::to_string(thinnest) + " x " +
                    std::to_string(Scheduler<D>::stripWidth) + " cells) holds kappa + 2 h (fewer ranks)");
        if (rankColumns_ > 1 && erosion_) {  // (and whose thinnest range of columns holds it too)
            const auto& fc = dist_->firstColumns();
            int narrowest = INT_MAX;
            for (int c = 0; c < rankColumns_; ++c) narrowest = std::min(narrowest, fc[c + 1] - fc[c]);
            require(narrowest * cells * grid_.h >= erosion_->settings().kappa + 2 * grid_.h, "rankColumns", rankColumns_,
                    "one whose narrowest range of columns (" + std::to_string(narrowest) + " x " + std::to_string(cells) +
                        " cells) holds kappa + 2 h (fewer rank columns, or wider columnCells)");
        }
    } else if (rankColumns_ > 1) {
        const auto tileOf = [&](const Vec<D>& x) {
            const int s = stripOf(x);
            return std::array<int, 2>{s, s >= 0 ? columnOf(x) : 0};
        };
        dist_->migrateBlocks(points_, tileOf);
        const int cells = settings_.columnCells;
        const int minColumns = erosion_ ? std::max(1, static_cast<int>(std::ceil((erosion_->settings().kappa + 2 * grid_.h) /
                                                                                  (cells * grid_.h))))
                                        : 1;
        if (rebalancePeriod_ > 0 && steps_ % rebalancePeriod_ == 0 &&
            dist_->rebalanceBlocks(points_, tileOf, rebalanceTolerance_, minStrips, minColumns))
            ++rebalances_;
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
void Solver<D, K>::addDistributedNodeForce(int I, const Vec<D>& f, std::int64_t key0, std::int64_t key1)
{
    const int regular = I < grid_.numNodes() ? I : twinRegular_[I - grid_.numNodes()];
    // (With columns of ranks, every contribution to a node other ranks write too is a record.)
    const int side = dist_->rankColumns() > 1 ? (dist_->sharedNode(regular) ? -1 : 0)
                                              : dist_->sharedSide(regular / grid_.stride[D - 1]);
    if (side == 0) {
        grid_.force[I] += f;
        return;
    }
    NodeRecord<D> r{{key0, key1}, I, regular, {}};
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

template <int D, class K> void Solver<D, K>::distribute(std::shared_ptr<Transport> transport, int rankColumns)
{
    require(!dist_ && (steps_ == 0 || points_.distributed), "distribute", "called after the first step or twice",
            "once, before the first step (or to resume a rank's part loaded from its archive)");
    rankColumns_ = points_.distributed && !resumeColumns_.empty() ? static_cast<int>(resumeColumns_.size()) - 1 : rankColumns;
    require(rankColumns == 1 || rankColumns == rankColumns_, "rankColumns", rankColumns,
            std::to_string(rankColumns_) + ", the columns of ranks of the run this rank's part was saved from");
    checkDistributable();
    initialize();
    auto d = std::make_shared<Distribution<D>>(std::move(transport));
    checkRankColumns(d->size());
    if (points_.distributed) {
        if (d->size() != resumeRanks_ || d->rank() != resumeRank_)
            require(false, "number of ranks", d->size(),
                    std::to_string(resumeRanks_) + ": this is the archive of rank " + std::to_string(resumeRank_) +
                        " of a run on " + std::to_string(resumeRanks_) + " ranks; resume it with as many");
        const int cells = settings_.columnCells, numColumns = cells > 0 ? (grid_.n[0] - S) / cells + 1 : 1;
        d->setColumns(rankColumns_, cells, numColumns, grid_.n);
        d->setRanges(resumeStrips_, S, grid_.n[D - 1], resumeColumns_);
    }
    dist_ = d;
    dist_->setPhantomNodes(&phantom_);
    if (points_.distributed) {  // (a rank's part: the scene's points are the largest id's + 1)
        std::int32_t last = -1;
        for (std::int32_t id : points_.globalId) last = std::max(last, id);
        double count = last + 1.0;
        dist_->transport().max(&count, 1);
        globalPoints_ = static_cast<int>(count);
    }
}

template <int D, class K> void Solver<D, K>::distributeSetup(std::shared_ptr<Transport> transport, int rankColumns)
{
    require(!dist_ && steps_ == 0 && points_.size() == 0 && !initialized_, "distributeSetup",
            "called after points were added, the grid was built or the run was distributed",
            "once, on a new solver, before any point is added");
    rankColumns_ = rankColumns;
    checkDistributable();
    dist_ = std::make_shared<Distribution<D>>(std::move(transport));
    checkRankColumns(dist_->size());
    dist_->setPhantomNodes(&phantom_);
    heldSetup_ = true;
    points_.distributed = true;
    points_.referenced = true;
}

template <int D, class K> void Solver<D, K>::holdPoints(int offset, int count, int total)
{
    require(dist_ && heldSetup_ && !dist_->partitioned(), "holdPoints", "called without distributeSetup() or after the first step",
            "set-up of a run distributed at set-up only");
    require(offset >= 0 && count >= 0 && static_cast<long>(offset) + count <= total, "share of this rank's points",
            "[" + std::to_string(offset) + ", " + std::to_string(static_cast<long>(offset) + count) + ")",
            "0 <= offset <= offset + count <= total = " + std::to_string(total));
    require(static_cast<long>(globalPoints_) + total < INT_MAX, "number of points", static_cast<long>(globalPoints_) + total,
            "< 2^31 - 1");
    nextId_ = globalPoints_ + offset;
    heldEnd_ = nextId_ + count;
    globalPoints_ += total;
}

template <int D, class K> void Solver<D, K>::initializeHeld(Vec<D>& lo, Vec<D>& hi, double& meanMass)
{
    Transport& t = dist_->transport();
    // The bounding box: minima and maxima, exact in any order.
    std::vector<double> box(2 * D, -std::numeric_limits<double>::infinity());
    for (const auto& x : points_.x)
        for (int d = 0; d < D; ++d) {
            box[d] = std::max(box[d], -x[d]);
            box[D + d] = std::max(box[D + d], x[d]);
        }
    t.max(box.data(), 2 * D);
    for (int d = 0; d < D; ++d) {
        lo[d] = -box[d];
        hi[d] = box[D + d];
    }
    // The mean mass as one process sums it, point after point in id order: the ranks' runs of
    // consecutive ids are visited in id order, each summed by its rank from the sum so far.
    std::vector<std::int32_t> runs;  // (first id, length, first local index) of this rank's runs
    for (std::size_t p = 0; p < points_.size(); ++p) {
        const std::int32_t id = points_.globalId[p];
        if (p > 0 && points_.globalId[p - 1] + 1 == id) {
            ++runs[runs.size() - 2];
            continue;
        }
        runs.insert(runs.end(), {id, 1, static_cast<std::int32_t>(p)});
    }
    Bytes mine;
    for (std::size_t k = 0; k < runs.size(); k += 3) {
        mine.put(runs[k]);
        mine.put(runs[k + 1]);
    }
    std::vector<std::pair<std::int32_t, int>> all;  // (first id, rank)
    const auto gathered = t.allGather(mine.data);
    for (int r = 0; r < static_cast<int>(gathered.size()); ++r) {
        Bytes b;
        b.data = gathered[r];
        while (!b.done()) {
            all.emplace_back(b.get<std::int32_t>(), r);
            b.get<std::int32_t>();
        }
    }
    std::sort(all.begin(), all.end());
    double sum = 0;
    std::size_t next = 0;  // this rank's next run
    for (const auto& run : all) {
        double part = 0;
        if (run.second == dist_->rank()) {
            part = sum;
            const int first = runs[next + 2], len = runs[next + 1];
            for (int p = first; p < first + len; ++p) part += points_.mass(p);
            next += 3;
        }
        t.sum(&part, 1);  // (the others add 0: exact)
        sum = part;
    }
    meanMass = globalPoints_ > 0 ? sum / globalPoints_ : 0.0;
}

template <int D, class K> void Solver<D, K>::setRebalance(double tolerance, int period)
{
    require(tolerance >= 1 && std::isfinite(tolerance), "rebalance", tolerance, "1 <= rebalance < inf");
    require(period >= 0, "rebalancePeriod", period, "0 (never) or more steps");
    rebalanceTolerance_ = tolerance;
    rebalancePeriod_ = period;
}

template <int D, class K> void Solver<D, K>::checkRankColumns(int ranks) const
{
    require(rankColumns_ >= 1 && ranks % rankColumns_ == 0, "rankColumns", rankColumns_,
            "a divisor of the number of ranks, " + std::to_string(ranks));
    require(rankColumns_ == 1 || settings_.columnCells > 0, "columnCells", settings_.columnCells,
            "a number of cells > 0 with rankColumns = " + std::to_string(rankColumns_) +
                " (the ranks of a row split the scheduler's columns)");
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
    template void Solver<D, K>::addDistributedNodeForce(int, const Vec<D>&, std::int64_t, std::int64_t); \
    template void Solver<D, K>::transportCracks(double);                                          \
    template void Solver<D, K>::distribute(std::shared_ptr<Transport>, int);                      \
    template void Solver<D, K>::distributeSetup(std::shared_ptr<Transport>, int);                 \
    template void Solver<D, K>::holdPoints(int, int, int);                                        \
    template void Solver<D, K>::initializeHeld(Vec<D>&, Vec<D>&, double&);                         \
    template void Solver<D, K>::checkDistributable() const;                                       \
    template void Solver<D, K>::checkRankColumns(int) const;                                      \
    template void Solver<D, K>::setRebalance(double, int);
EMP_SOLVER_CONFIGURATIONS(EMP_INSTANTIATE)
#undef EMP_INSTANTIATE

}  // namespace emp
