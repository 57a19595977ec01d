// One scene over several processes (ranks), by domain decomposition of the Scheduler's strips
// (issue 17; doc/parallel.md). Every rank runs the same step on its part:
//
//   - a rank owns a contiguous range of strips along the last axis, chosen once so that the
//     ranks hold equal numbers of points, and the points binned there; a point that moves into a
//     neighbour's range migrates at the start of the next step;
//   - it works on the node planes its points reach; two neighbouring ranks share the S - 1
//     planes where their boundary strips overlap (the ghost layer);
//   - a scatter to the grid runs in the Scheduler's two colours. At a shared plane, the rank
//     whose boundary strip has colour 0 writes first, hands its partial sums to the other rank
//     between the colours, and the other adds its own and hands the totals back: every node
//     receives its contributions in the order of the single-process step;
//   - the serial contributions (eroded points' corrections, tractions) to shared planes are
//     exchanged and applied on both ranks in the single-process order (by a key);
//   - eigenerosion sees the points of the neighbours within its reach (ghost points), in the
//     single-process order, and the erosion events are gathered on every rank.
//
// The points of a rank stay sorted by their id in the single-process scene (globalId), so that
// every sum over points runs in the single-process order: the results are bitwise those of one
// process for any number of ranks (tests/mpi). Sums over all points for diagnostics (energies,
// momenta, reactions) are reduced over the ranks and may differ at round-off.
//
// The core does no message passing itself: a Transport (mpi/MpiTransport.hpp, or a test
// double) carries the bytes.
#pragma once
#include <algorithm>
#include <array>
#include <climits>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "Errors.hpp"
#include "Grid.hpp"
#include "MaterialPoints.hpp"
#include "PhantomNodes.hpp"
#include "ScatterChain.hpp"

namespace emp {

/// The message passing a distributed run needs; the ranks form a line (rank - 1, rank + 1).
class Transport {
public:
    virtual ~Transport() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    /// Sends toLeft to rank - 1 and toRight to rank + 1 (nothing past the ends) and receives
    /// what those ranks sent to this one (empty past the ends). Every rank calls it.
    virtual void exchange(const std::vector<char>& toLeft, const std::vector<char>& toRight,
                          std::vector<char>& fromLeft, std::vector<char>& fromRight) = 0;
    /// Element-wise sum or maximum over the ranks, in place; every rank gets the same values.
    virtual void sum(double* v, int n) = 0;
    virtual void max(double* v, int n) = 0;
    /// Every rank's bytes, in rank order, on every rank.
    virtual std::vector<std::vector<char>> allGather(const std::vector<char>& mine) = 0;
    /// Sends toEach[r] to rank r (one buffer per rank, this one's included) and returns what
    /// each rank sent to this one, in rank order. Every rank calls it.
    virtual std::vector<std::vector<char>> allToAll(const std::vector<std::vector<char>>& toEach) = 0;
    /// Sends out[i] to rank ranks[i] and returns what each of them sent to this one, in the same
    /// order. The relation is symmetric: every rank named here names this one in its own call.
    virtual std::vector<std::vector<char>> neighbourExchange(const std::vector<int>& ranks,
                                                             const std::vector<std::vector<char>>& out) = 0;
};

/// A byte buffer written and read in the same order: plain values (numbers, fixed-size Eigen
/// vectors and matrices of doubles, structs of them), copied as their bytes.
class Bytes {
public:
    std::vector<char> data;
    template <class T> void put(const T& v)
    {
        static_assert(std::is_standard_layout<T>::value, "plain values only");
        const std::size_t at = data.size();
        data.resize(at + sizeof(T));
        std::memcpy(data.data() + at, static_cast<const void*>(&v), sizeof(T));
    }
    template <class T> T get()
    {
        T v;
        std::memcpy(static_cast<void*>(&v), data.data() + read_, sizeof(T));
        read_ += sizeof(T);
        return v;
    }
    bool done() const { return read_ >= data.size(); }

private:
    std::size_t read_ = 0;
};

/// A nodal array as doubles: node I's `width` values start at data + I * width.
struct NodeField {
    double* data;
    int width;
};

/// A contribution of a serial stage to one node, applied everywhere in the order of `key`
/// (the single-process order: stage, then the point's or condition's order in it).
template <int D> struct NodeRecord {
    std::int64_t key[2];
    int node;     ///< a regular node or a phantom twin
    int regular;  ///< the regular node (the twin's), whose ranks receive the record
    double value[D];
};

/// What eigenerosion needs of the neighbours' points near this rank (ghost points), sorted by
/// globalId.
template <int D> struct GhostPoints {
    std::vector<Vec<D>> x;
    std::vector<double> mass, history, damage;
    std::vector<std::int32_t> id;
    std::size_t size() const { return x.size(); }
};

template <int D> class Distribution {
public:
    /// Throws ParameterError for a transport of fewer than one rank.
    explicit Distribution(std::shared_ptr<Transport> t);
    int rank() const { return rank_; }
    int size() const { return size_; }
    Transport& transport() { return *t_; }
    bool partitioned() const { return !first_.empty(); }

    /// A decomposition in two directions (doc/parallel.md): the ranks form `columns` columns
    /// along the first axis and size() / columns rows along the last; rank r is in row
    /// r / columns and column r % columns, and holds a range of strips and one of the
    /// Scheduler's columns (columnCells cells each, numColumns of them on a grid of n0 nodes
    /// along the first axis); the scatters hand their partial sums on as ScatterChain says.
    /// Before the partition; columns = 1 (the default): strips only, as before. Throws
    /// ParameterError for a number of columns that does not divide the ranks or exceeds the
    /// Scheduler's columns.
    void setColumns(int columns, int columnCells, int numColumns, const std::array<int, D>& n);
    int rankColumns() const { return cols_; }
    int row() const { return rank_ / cols_; }
    int rows() const { return size_ / cols_; }
    int column() const { return rank_ % cols_; }
    /// The first Scheduler column of every rank column, and their number at the end.
    const std::vector<int>& firstColumns() const { return firstCol_; }
    /// Node indices along the first axis this rank works on, [lo, hi), and those it owns.
    int columnLo() const { return colLo_; }
    int columnHi() const { return colHi_; }
    int ownedColumnLo() const { return ownedColLo_; }
    int ownedColumnHi() const { return ownedColHi_; }
    /// The columns this rank's scatters defer to the second phase of each strip colour
    /// (Scheduler::setSeparatePhases): its first and last columns where they are odd and meet
    /// another rank's (-1: none).
    std::array<int, 2> deferredColumns() const
    {
        if (cols_ == 1) return {-1, -1};
        const int c = column(), lo = firstCol_[c], hi = firstCol_[c + 1] - 1;
        return {c > 0 && lo % 2 == 1 ? lo : -1, c < cols_ - 1 && hi % 2 == 1 ? hi : -1};
    }
    /// The rank of the tile (strip s, Scheduler column c).
    int rankOf(int s, int c) const
    {
        return Blocks::rangeOf(first_, s) * cols_ + (cols_ > 1 ? Blocks::rangeOf(firstCol_, c) : 0);
    }

    /// Chooses the strip ranges (every rank holds every point now, and the same ones) so that
    /// the ranks hold nearly equal numbers of points, and keeps this rank's points, numbering
    /// them by their index now (globalId). stripOf[p] is point p's strip, numStrips their
    /// number, S the kernel's support, nLast the nodes along the last axis. Throws
    /// ParameterError when there are fewer strips than ranks.
    /// With columns (setColumns), columnOf[p] is point p's Scheduler column, and the rows and
    /// the columns of ranks are balanced apart.
    void partition(MaterialPoints<D>& P, const std::vector<int>& stripOf, int numStrips, int S, int nLast,
                   const std::vector<int>& columnOf = {});
    /// The same choice when the points were distributed at set-up (Solver::distributeSetup):
    /// every rank holds a share of the points, sorted by globalId, and stripOf[p] is its point
    /// p's strip. The counts per strip are summed over the ranks, the ranges chosen as in
    /// partition(), and every point sent to the rank whose range holds its strip. Every rank
    /// calls it; the ranges and each rank's points are those partition() gives.
    void partitionHeld(MaterialPoints<D>& P, const std::vector<int>& stripOf, int numStrips, int S, int nLast,
                       const std::vector<int>& columnOf = {});
    /// The same ranges as another run's (a restart): first[r] is rank r's first strip (with
    /// columns, rank row r's; firstColumns() as firstColumns()).
    void setRanges(const std::vector<int>& first, int S, int nLast, const std::vector<int>& firstColumns = {});
    const std::vector<int>& firstStrips() const { return first_; }
    /// The first strip of each of `ranks` ranges (and numStrips at the end) that split the points
    /// counted per strip in `count` nearly equally, at least one strip each.
    static std::vector<int> balancedRanges(const std::vector<double>& count, int ranks);
    /// The same, each boundary the one nearest to its share (columns are wide: the first that
    /// reaches the share may overshoot it by most of a column).
    static std::vector<int> nearestRanges(const std::vector<double>& count, int ranks);

    /// Load balance when fragments fly apart: counts the points of every strip over all ranks,
    /// and when the rank holding most holds more than `tolerance` times the mean, chooses
    /// balanced ranges again (balancedRanges; each at least `minStrips` strips wide, else
    /// nothing changes) and sends every point to the rank whose new range holds its strip, from
    /// any rank to any rank, keeping the points sorted by globalId. Results do not depend on the
    /// ranges (doc/parallel.md), so nothing but the ranks' shares changes. Returns whether the
    /// ranges changed; the same on every rank. Every rank calls it.
    template <class StripOf>
    bool rebalance(MaterialPoints<D>& P, StripOf&& stripOf, double tolerance, int minStrips);
    /// The same with columns of ranks (tileOf(x): strip and column): the rows and the columns
    /// are balanced apart on the points counted per strip and per column, each range at least
    /// minStrips strips and minColumns columns; the ranks' loads under the new ranges are
    /// counted exactly (one sum of a number per rank) and the ranges change only when the
    /// largest is lower.
    template <class TileOf>
    bool rebalanceBlocks(MaterialPoints<D>& P, TileOf&& tileOf, double tolerance, int minStrips, int minColumns);
    /// The largest number of points on one rank over the mean, from the last count of rebalance
    /// (after it moved points, the new ranges'); 0 before any.
    double imbalance() const { return imbalance_; }

    /// Sends the points whose strip (stripOf(x)) left this rank's range to the neighbour that
    /// owns it and takes theirs, keeping the points sorted by globalId. Throws SimulationError
    /// (on every rank) when a point skipped a whole neighbour's range.
    template <class StripOf> void migrate(MaterialPoints<D>& P, StripOf&& stripOf);

    /// Node planes (along the last axis) this rank works on, [lo, hi), and those it owns (each
    /// plane owned by one rank: reactions and sums over nodes count it once).
    int planeLo() const { return planeLo_; }
    int planeHi() const { return planeHi_; }
    int ownedLo() const { return ownedLo_; }
    int ownedHi() const { return ownedHi_; }
    /// Whether node plane i is shared with the left (-1) or right (+1) neighbour, else 0.
    int sharedSide(int plane) const
    {
        if (row() > 0 && plane < leftShared_) return -1;
        if (row() < rows() - 1 && plane >= rightShared_) return 1;
        return 0;
    }

    /// Between the two colours of a scatter: the rank that wrote a shared plane first hands it on.
    void afterFirstColour(const Grid<D>& g, const std::vector<NodeField>& fields);
    /// After phase k of the `phases` of a scatter (Scheduler::numPhases), but the last: with
    /// columns, the partial sums ScatterChain names go on; without, afterFirstColour between the
    /// strips' colours.
    void afterPhase(int k, int phases, const Grid<D>& g, const std::vector<NodeField>& fields);
    /// Migration with columns: every point whose tile (tileOf(x): strip, column) is another
    /// rank's goes there (a neighbour in the grid of ranks; else SimulationError on every rank),
    /// the points sorted by globalId.
    template <class TileOf> void migrateBlocks(MaterialPoints<D>& P, TileOf&& tileOf);
    /// After a scatter: the rank that wrote a shared plane last hands the totals back.
    void finishScatter(const Grid<D>& g, const std::vector<NodeField>& fields);
    /// Applies the serial contributions to shared planes (left, right) of this rank and of its
    /// neighbours, in key order, to the field f (width D). With columns of ranks, `left` holds
    /// every contribution to a node that other ranks write too (sharedNode), and `right` none.
    void applyRecords(std::vector<NodeRecord<D>>& left, std::vector<NodeRecord<D>>& right, NodeField f);
    /// With columns of ranks: the ranks whose tiles write the regular node I (this one's too),
    /// increasing; whether there are several.
    void writersOf(int I, std::vector<int>& ranks) const;
    bool sharedNode(int I) const;

    /// The neighbours' points within `reach` of this rank's range along the last axis.
    void ghosts(const MaterialPoints<D>& P, const Grid<D>& g, double reach, GhostPoints<D>& out);

    /// Adds to `nodes` (regular node indices) those in the planes this rank shares with its
    /// neighbours that the neighbours list in theirs.
    void shareNodes(const Grid<D>& g, std::vector<int>& nodes);

    /// Index of the point of globalId `id` among this rank's points, or -1.
    int localIndex(const MaterialPoints<D>& P, int id) const;

    /// The phantom twins of the pre-existing cracks (the same on every rank: they follow from the
    /// crack geometry): a shared plane carries its nodes' twins too.
    void setPhantomNodes(const PhantomNodes<D>* ph) { phantom_ = ph; }
    /// Makes the nodal mass and momentum of the regular nodes in the box [lo, hi] (node indices
    /// per direction) and of their twins those of the ranks that own them, on every rank (crack
    /// transport reads them there). Nodes outside this rank's planes are written; restore()
    /// sets them back to zero.
    void shareBox(Grid<D>& g, const int* lo, const int* hi);
    void restoreBox(Grid<D>& g, const int* lo, const int* hi);

private:
    /// Sends every point to the rank whose range in `first` holds its strip (strip[p]; a point
    /// off the grid, strip < 0, stays), from any rank to any rank, and keeps the points sorted
    /// by globalId. Every rank calls it.
    void sendToOwners(MaterialPoints<D>& P, const std::vector<int>& strip, const std::vector<int>& first);
    /// Sends every point p with to[p] != rank() to rank to[p], to the neighbours in the grid of
    /// ranks only (neighbours_) or to any rank, and keeps the points sorted by globalId.
    void sendPoints(MaterialPoints<D>& P, const std::vector<int>& to, bool neighboursOnly);
    /// The passes of ScatterChain after phase k: node values to and from the neighbours.
    void passChain(int k, const Grid<D>& g, const std::vector<NodeField>& fields);
    /// Sends each item to the other ranks that write its regular node (nodeOf(item)) and appends
    /// what the neighbours sent this rank.
    template <class T, class NodeOf> void shareWithWriters(std::vector<T>& items, NodeOf&& nodeOf);
    /// applyRecords and ghosts with columns of ranks: with the neighbours in the grid of ranks.
    void applyRecordsBlocks(std::vector<NodeRecord<D>>& mine, NodeField f);
    void ghostsBlocks(const MaterialPoints<D>& P, const Grid<D>& g, double reach, GhostPoints<D>& out);
    /// The ghost points the neighbours sent (globalId, position, mass, history, damage each),
    /// sorted by globalId into out.
    void collectGhosts(std::vector<Bytes>& from, GhostPoints<D>& out);
    /// The index of neighbour r in neighbours_.
    int slotOf(int r) const
    {
        return static_cast<int>(std::lower_bound(neighbours_.begin(), neighbours_.end(), r) - neighbours_.begin());
    }
    /// Throws ParameterError when there are fewer strips than ranks.
    void checkStrips(int numStrips) const;
    std::vector<char> planes(const Grid<D>& g, int lo, int hi, const std::vector<NodeField>& fields) const;
    void setPlanes(const Grid<D>& g, int lo, const std::vector<char>& bytes, const std::vector<NodeField>& fields) const;
    void setRangesOf(int S, int nLast);
    /// Whether this rank writes first at its boundary with the right (+1) or left (-1) neighbour.
    bool writesFirst(int side) const;

    template <class F> void forEachInBox(const Grid<D>& g, const int* lo, const int* hi, F&& f) const;
    std::shared_ptr<Transport> t_;
    const PhantomNodes<D>* phantom_ = nullptr;
    int rank_ = 0, size_ = 1;
    std::vector<int> first_;  ///< first strip of every rank, and the number of strips at the end
    int planeLo_ = 0, planeHi_ = 0, ownedLo_ = 0, ownedHi_ = 0, leftShared_ = 0, rightShared_ = 0;
    int S_ = 0, nLast_ = 0;
    // Columns of ranks (setColumns): their Scheduler columns and node columns, the neighbours
    // in the grid of ranks, the scatters' passes.
    int cols_ = 1, columnCells_ = 0, numColumns_ = 1;
    std::array<int, D> n_{};
    std::vector<int> firstCol_, neighbours_;
    int colLo_ = 0, colHi_ = INT_MAX, ownedColLo_ = 0, ownedColHi_ = INT_MAX;
    std::unique_ptr<ScatterChain<D>> chain_;
    double imbalance_ = 0;
};

template <int D>
template <class StripOf>
void Distribution<D>::migrate(MaterialPoints<D>& P, StripOf&& stripOf)
{
    const int n = static_cast<int>(P.size());
    const int lo = first_[rank_], hi = first_[rank_ + 1];
    std::vector<int> keep, left, right;
    keep.reserve(n);
    for (int p = 0; p < n; ++p) {
        const int s = stripOf(P.x[p]);
        (s < 0 || (s >= lo && s < hi) ? keep : s < lo ? left : right).push_back(p);
    }
    // Both neighbours are told how many arrive (0 too): every rank takes part in every exchange.
    Bytes toLeft, toRight;
    const auto pack = [&](const std::vector<int>& ids, Bytes& b) {
        b.put(static_cast<int>(ids.size()));
        P.forEachArray([&](const char* name, auto& a) {
            if (!P.carries(name)) return;
            for (int p : ids) b.put(a[p]);
        });
    };
    pack(left, toLeft);
    pack(right, toRight);
    Bytes fromLeft, fromRight;
    t_->exchange(toLeft.data, toRight.data, fromLeft.data, fromRight.data);
    int arriving[2] = {fromLeft.data.empty() ? 0 : fromLeft.get<int>(), fromRight.data.empty() ? 0 : fromRight.get<int>()};
    double moved = static_cast<double>(left.size() + right.size() + arriving[0] + arriving[1]);
    t_->sum(&moved, 1);
    if (moved == 0) return;
    // The kept points (in globalId order), then the arrivals; then all sorted by globalId.
    std::vector<int> order(keep.size() + arriving[0] + arriving[1]);
    P.forEachArray([&](const char* name, auto& a) {
        if (!P.carries(name)) return;
        using T = typename std::decay_t<decltype(a)>::value_type;
        std::vector<T> next;
        next.reserve(order.size());
        for (int p : keep) next.push_back(a[p]);
        for (int k = 0; k < arriving[0]; ++k) next.push_back(fromLeft.get<T>());
        for (int k = 0; k < arriving[1]; ++k) next.push_back(fromRight.get<T>());
        a.swap(next);
    });
    // Three runs sorted by globalId (kept, from the left, from the right): two merges.
    const std::vector<std::int32_t>& id = P.globalId;
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
    const auto byId = [&](int a, int b) { return id[a] < id[b]; };
    const auto fromL = order.begin() + keep.size(), fromR = fromL + arriving[0];
    std::inplace_merge(order.begin(), fromL, fromR, byId);
    std::inplace_merge(order.begin(), fromR, order.end(), byId);
    P.forEachArray([&](const char* name, auto& a) {
        if (!P.carries(name)) return;
        std::decay_t<decltype(a)> next(a.size());
        for (std::size_t k = 0; k < order.size(); ++k) next[k] = a[order[k]];
        a.swap(next);
    });
    // A point must land in the range of the rank it was sent to (it moves less than a cell in a
    // step, a range is at least one strip wide): checked on every rank, reported by all.
    double skipped = 0;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const int s = stripOf(P.x[p]);
        if (s >= 0 && (s < lo || s >= hi)) skipped = 1;
    }
    t_->max(&skipped, 1);
    if (skipped > 0)
        throw SimulationError("EigenMPM: a point moved past a whole neighbouring rank's strips in one step; "
                              "use fewer ranks or a smaller dt");
}

template <int D>
template <class TileOf>
void Distribution<D>::migrateBlocks(MaterialPoints<D>& P, TileOf&& tileOf)
{
    const int n = static_cast<int>(P.size());
    std::vector<int> to(n);
    double far = 0;
    for (int p = 0; p < n; ++p) {
        const std::array<int, 2> t = tileOf(P.x[p]);
        to[p] = t[0] < 0 ? rank_ : rankOf(t[0], t[1]);
        if (to[p] != rank_ && !std::binary_search(neighbours_.begin(), neighbours_.end(), to[p])) far = 1;
    }
    t_->max(&far, 1);
    if (far > 0)
        throw SimulationError("EigenMPM: a point moved past a whole neighbouring rank's tiles in one step; "
                              "use fewer ranks or a smaller dt");
    sendPoints(P, to, true);
}

template <int D>
template <class TileOf>
bool Distribution<D>::rebalanceBlocks(MaterialPoints<D>& P, TileOf&& tileOf, double tolerance, int minStrips, int minColumns)
{
    const int numStrips = first_.back(), n = static_cast<int>(P.size());
    std::vector<std::array<int, 2>> tile(n);
    // Points per strip and per column: one sum over the ranks; this rank's: a maximum and a sum.
    std::vector<double> count(numStrips + numColumns_, 0.0);
    for (int p = 0; p < n; ++p) {
        tile[p] = tileOf(P.x[p]);
        if (tile[p][0] < 0) continue;
        ++count[tile[p][0]];
        ++count[numStrips + tile[p][1]];
    }
    t_->sum(count.data(), numStrips + numColumns_);
    double most = n, total = n;
    t_->max(&most, 1);
    t_->sum(&total, 1);
    imbalance_ = total > 0 ? most * size_ / total : 1.0;
    if (imbalance_ <= tolerance) return false;
    const std::vector<int> rowsNext = balancedRanges(std::vector<double>(count.begin(), count.begin() + numStrips), rows());
    const std::vector<int> colsNext =
        nearestRanges(std::vector<double>(count.begin() + numStrips, count.begin() + numStrips + numColumns_), cols_);
    for (int r = 0; r < rows(); ++r)
        if (rowsNext[r + 1] - rowsNext[r] < minStrips) return false;
    for (int c = 0; c < cols_; ++c)
        if (colsNext[c + 1] - colsNext[c] < minColumns) return false;
    if (rowsNext == first_ && colsNext == firstCol_) return false;
    // Every rank's load under the new ranges, exactly.
    const auto rankIn = [&](const std::array<int, 2>& t) {
        return t[0] < 0 ? rank_ : Blocks::rangeOf(rowsNext, t[0]) * cols_ + Blocks::rangeOf(colsNext, t[1]);
    };
    std::vector<double> load(size_, 0.0);
    std::vector<int> to(n);
    for (int p = 0; p < n; ++p) ++load[to[p] = rankIn(tile[p])];
    t_->sum(load.data(), size_);
    const double better = total > 0 ? *std::max_element(load.begin(), load.end()) * size_ / total : 1.0;
    if (better >= imbalance_) return false;
    sendPoints(P, to, false);
    first_ = rowsNext;
    firstCol_ = colsNext;
    setRangesOf(S_, nLast_);
    imbalance_ = better;
    return true;
}

template <int D>
template <class StripOf>
bool Distribution<D>::rebalance(MaterialPoints<D>& P, StripOf&& stripOf, double tolerance, int minStrips)
{
    const int numStrips = first_.back(), n = static_cast<int>(P.size());
    std::vector<int> strip(n);
    std::vector<double> count(numStrips, 0.0);
    for (int p = 0; p < n; ++p) {
        strip[p] = stripOf(P.x[p]);
        if (strip[p] >= 0) ++count[strip[p]];
    }
    t_->sum(count.data(), numStrips);
    const auto worst = [&](const std::vector<int>& first) {
        double total = 0, most = 0;
        for (int r = 0; r < size_; ++r) {
            double load = 0;
            for (int s = first[r]; s < first[r + 1]; ++s) load += count[s];
            total += load;
            most = std::max(most, load);
        }
        return total > 0 ? most * size_ / total : 1.0;
    };
    imbalance_ = worst(first_);
    if (imbalance_ <= tolerance) return false;
    const std::vector<int> next = balancedRanges(count, size_);
    for (int r = 0; r < size_; ++r)
        if (next[r + 1] - next[r] < minStrips) return false;
    const double better = worst(next);
    if (next == first_ || better >= imbalance_) return false;
    sendToOwners(P, strip, next);
    first_ = next;
    setRangesOf(S_, nLast_);
    imbalance_ = better;
    return true;
}

}  // namespace emp
