// Scheduling, apart from the physics: which points and nodes a worker owns and in which order
// the contributions reach a node. Points are binned (stable counting sort) into strips of
// `stripWidth` cells along the last axis; a scatter to the grid runs the strips in two colours,
// so strips of one colour never write the same node and need neither atomics nor per-thread
// copies. The order of the contributions to every node is then fixed whatever the thread
// count: results are bitwise independent of it. This is also the seam where a distributed run
// decides which points and nodes a process owns.
//
// Which worker runs which strip does not change the results, only the speed: each worker takes a
// contiguous range of strips (balanced by points at every binning) in both colours, and the
// nodal loops give each worker the node rows of its strips, so that a worker keeps finding the
// nodes and the stencils it touched in the pass before in its own core's cache. (With the strips
// dealt out one at a time, two threads ran the 2D step at 1e5 points about 1.6 times as fast as
// one instead of 1.8: the grid's cache lines moved between the cores at every pass.)
//
// Columns (setColumns, off by default): the strips may also be cut along the first axis into
// columns of `columnCells` cells, the points of a strip then sorted by column, then id, and a
// scatter runs in four colours (strip parity, then column parity), tiles of one colour sharing no
// node. The order of the contributions to every node is then fixed by the tiles alone, so that a
// run can also be split between processes along the first axis and stay bitwise that of one
// process with the same columns (doc/parallel.md, "Decomposition in two directions"). Without
// columns the order is the strips' alone, as before.
#pragma once
#include <algorithm>
#include <climits>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "Errors.hpp"
#include "Lanes.hpp"
#include "Grid.hpp"

namespace emp {

template <int D> class Scheduler {
public:
    /// Cells per strip: strips two apart never share a node (needs stripWidth >= S - 1). The
    /// narrowest that uGIMP allows: the finer the strips, the closer a contiguous split comes to
    /// equal shares of the points (3D block of 97 336 points on two threads: 1.65x one thread
    /// with strips of 4 cells, 1.87x with 2).
    static constexpr int stripWidth = 2;

    /// Cuts the strips into columns of `cells` cells along the first axis (0: one column, the
    /// default). Applies from the next bin(); a kernel of support S needs cells >= S - 1.
    void setColumns(int cells) { columnCells_ = std::max(0, cells); }
    int columnCells() const { return columnCells_; }
    /// Columns of the last bin (1 without columns).
    int numColumns() const { return numColumns_; }
    /// The column of a point at x, for the kernel K (0 without columns; x on the grid).
    template <class K> int columnOf(const Vec<D>& x, const Grid<D>& g) const
    {
        return columnCells_ > 0 ? K::base((x[0] - g.origin[0]) * g.invh) / columnCells_ : 0;
    }

    /// The number of strips of a grid, for the kernel K.
    template <class K> static int numStrips(const Grid<D>& g) { return (g.n[D - 1] - K::S) / stripWidth + 1; }
    /// The strip of a point at x, for the kernel K, or -1 when its support leaves the grid.
    template <class K> static int stripOf(const Vec<D>& x, const Grid<D>& g)
    {
        int b = 0;
        for (int d = 0; d < D; ++d) {
            b = K::base((x[d] - g.origin[d]) * g.invh);
            if (!(b >= 0 && b <= g.n[d] - K::S)) return -1;
        }
        return b / stripWidth;
    }

    /// Bins the points at x by strip, for the kernel K, and splits the strips between nThreads
    /// workers. Returns the id of the first point whose support leaves the grid (binned
    /// nowhere), or -1 when all are on it.
    template <class K> int bin(const std::vector<Vec<D>>& x, const Grid<D>& g, int nThreads)
    {
        static_assert(stripWidth >= K::S - 1,
                      "strips of one colour would share nodes: a kernel of support S needs stripWidth >= S - 1");
        // (Tiles of one colour two columns apart share no node when columnCells >= S - 1.)
        require(columnCells_ == 0 || columnCells_ >= K::S - 1, "columnCells", columnCells_,
                "0 (no columns) or at least " + std::to_string(K::S - 1) + " for this shape function");
        constexpr int last = D - 1;
        const int numStrips = (g.n[last] - K::S) / stripWidth + 1;
        numColumns_ = columnCells_ > 0 ? (g.n[0] - K::S) / columnCells_ + 1 : 1;
        return numColumns_ > 1 ? binTiles<K, true>(x, g, nThreads, numStrips) : binTiles<K, false>(x, g, nThreads, numStrips);
    }

    /// Whether the last bin kept the order of the one before (every point's key unchanged,
    /// for as many points, keys and workers), having computed only the keys.
    bool reusedLastBin() const { return reused_; }

    /// Worker t's strips are [split()[t], split()[t + 1]): contiguous, each range holding about
    /// an equal share of the points (to a strip), set by the last bin.
    const std::vector<int>& split() const { return split_; }

    /// Point ids in binned order: slot k holds point order()[k].
    const std::vector<int>& order() const { return order_; }
    /// Strip s holds the slots [stripStart()[s], stripStart()[s + 1]): the points whose base node
    /// along the last axis lies in [s stripWidth, (s + 1) stripWidth), in increasing id order
    /// (with columns: by column, then id).
    const std::vector<int>& stripStart() const { return stripStart_; }
    /// The slots [first, second) of the strips whose points' supports (S nodes from the base along
    /// the last axis) can reach the nodes lo .. hi along the last axis (the strips are in slot
    /// order, with columns too): a point of strip s has its base in [s stripWidth, (s + 1)
    /// stripWidth - 1], and reaches [lo, hi] only from a base in [lo - (S - 1), hi]. Empty (0, 0)
    /// when lo > hi or no strip can.
    template <class K> std::pair<int, int> slotsReaching(int lo, int hi) const
    {
        if (lo > hi || hi < 0 || stripStart_.size() < 2) return {0, 0};  // (bases are >= 0)
        const int numStrips = static_cast<int>(stripStart_.size()) - 1;
        const int first = static_cast<int>(std::max(0LL, static_cast<long long>(lo) - (K::S - 1)) / stripWidth);
        const int last = std::min(numStrips - 1, hi / stripWidth);
        if (first > last) return {0, 0};
        return {stripStart_[first], stripStart_[last + 1]};
    }
    /// Tile (s, c) (strip s, column c) holds the slots [tileStart()[t], tileStart()[t + 1]), t =
    /// s numColumns() + c, in increasing id order; without columns the tiles are the strips.
    const std::vector<int>& tileStart() const { return numColumns_ > 1 ? tileStart_ : stripStart_; }
    int size() const { return static_cast<int>(order_.size()); }
    /// The slot of point p in the last binning (its tile's slots are in increasing id order: a
    /// binary search there), or -1 when p was not binned then.
    int slotOf(int p) const
    {
        if (p < 0 || p >= static_cast<int>(keyOf_.size()) || order_.size() != keyOf_.size()) return -1;
        const std::vector<int>& start = tileStart();
        const int key = keyOf_[p];
        const auto first = order_.begin() + start[key], last = order_.begin() + start[key + 1];
        const auto it = std::lower_bound(first, last, p);
        return it != last && *it == p ? static_cast<int>(it - order_.begin()) : -1;
    }

    /// Calls f(slot) for every slot, where f may scatter to the nodes of its point's support:
    /// two colours of strips (each in two colours of columns, with columns), each strip in slot
    /// order. `between(k)`, when given, runs after every phase k but the last (a distributed
    /// run's exchange, Distribution.hpp).
    template <class F> void scatter(int nThreads, F&& f, const std::function<void(int)>& between = {}) const
    {
        scatterStrips(nThreads, [&](int begin, int end) {
            for (int k = begin; k < end; ++k) f(k);
        }, between);
    }

    /// scatter in runs: calls f(begin, end) for consecutive ranges of at most `run` slots of one
    /// tile (strip), in slot order. A pass can then do its per-point work for the whole run before it
    /// scatters: points are independent until they write, so their long chains of dependent
    /// arithmetic (the law's square roots and divisions) overlap in the processor instead of
    /// following each other; the order of the contributions to each node is that of scatter.
    template <class F> void scatterRuns(int nThreads, int run, F&& f, const std::function<void(int)>& between = {}) const
    {
        scatterStrips(nThreads, [&](int begin, int end) {
            for (int k = begin; k < end; k += run) f(k, std::min(k + run, end));
        }, between);
    }

    /// The tiles of scatter: calls f(begin, end) with the slot range of every tile (strip, without
    /// columns), the phases (numPhases()) one after the other, each worker the strips of its
    /// range (split()).
    template <class F> void scatterStrips(int nThreads, F&& f, const std::function<void(int)>& between = {}) const
    {
        const int phases = numPhases();
        for (int phase = 0; phase < phases; ++phase) {
            scatterPhase(phase, nThreads, f);
            if (phase < phases - 1 && between) between(phase);
        }
    }

    /// The colours of a scatter, run one after the other: 2 (the strips' parity; with columns,
    /// each strip's even columns, then its odd ones), or 4 with columns and separate phases (the
    /// strips' parity, then the columns').
    int numPhases() const { return numColumns_ > 1 && separatePhases_ ? 4 : 2; }
    /// With columns: whether the columns' two colours are phases of their own, for a
    /// decomposition in two directions, which hands partial sums on between them (ScatterChain).
    /// Phase 2a then runs the strips of parity a strip by strip, each strip's even columns, then
    /// its odd ones but the `deferred` columns (-1: none), and phase 2a + 1 the deferred
    /// columns of those strips: a rank defers its odd columns at its boundaries with other
    /// ranks, the only tiles that write nodes another rank's tiles write. Every node receives
    /// its contributions in the same order as without separate phases (by tile colour; strips
    /// of one colour share no node, and a deferred tile's neighbours in its strip are even),
    /// and a strip's nodes are read from the caches once but at those columns.
    void setSeparatePhases(bool on, int deferredLo = -1, int deferredHi = -1)
    {
        require((deferredLo < 0 || deferredLo % 2 == 1) && (deferredHi < 0 || deferredHi % 2 == 1), "deferred columns",
                std::to_string(deferredLo) + ", " + std::to_string(deferredHi), "odd columns, or -1 for none");
        separatePhases_ = on;
        deferred_[0] = deferredLo;
        deferred_[1] = deferredHi;
    }
    /// The colour of tile (strip s, column c): the phase that writes it.
    int colourOf(int s, int c) const { return numColumns_ > 1 ? 2 * (s & 1) + (c & 1) : s & 1; }

    /// One phase of scatterStrips: calls f(begin, end) with the slot range of every tile of
    /// colour `phase`, each worker the tiles of its range of strips (split()). Tiles of one
    /// colour share no node.
    template <class F> void scatterPhase(int phase, int nThreads, F&& f) const
    {
        // Worker t runs the strips of split_'s range t (iteration t of a static schedule of
        // chunk 1 goes to thread t); with fewer threads than ranges a thread runs several.
        const int nRanges = static_cast<int>(split_.size()) - 1, nc = numColumns_;
        if (nc == 1) {
#pragma omp parallel for schedule(static, 1) num_threads(nThreads)
            for (int t = 0; t < nRanges; ++t)
                for (int s = split_[t] + ((split_[t] & 1) != phase); s < split_[t + 1]; s += 2)
                    f(stripStart_[s], stripStart_[s + 1]);
            return;
        }
        if (!separatePhases_) {
#pragma omp parallel for schedule(static, 1) num_threads(nThreads)
            for (int t = 0; t < nRanges; ++t)
                for (int s = split_[t] + ((split_[t] & 1) != phase); s < split_[t + 1]; s += 2)
                    for (int parity = 0; parity < 2; ++parity)
                        for (int c = parity; c < nc; c += 2) f(tileStart_[s * nc + c], tileStart_[s * nc + c + 1]);
            return;
        }
        const int colour = phase >> 1, a = deferred_[0], b = deferred_[1];
        const auto tile = [&](int s, int c) { f(tileStart_[s * nc + c], tileStart_[s * nc + c + 1]); };
#pragma omp parallel for schedule(static, 1) num_threads(nThreads)
        for (int t = 0; t < nRanges; ++t)
            for (int s = split_[t] + ((split_[t] & 1) != colour); s < split_[t + 1]; s += 2) {
                if (phase & 1) {  // the deferred columns
                    if (a >= 0 && a < nc) tile(s, a);
                    if (b >= 0 && b < nc && b != a) tile(s, b);
                    continue;
                }
                for (int c = 0; c < nc; c += 2) tile(s, c);
                for (int c = 1; c < nc; c += 2)
                    if (c != a && c != b) tile(s, c);
            }
    }

    /// Calls f(begin, end, acc) for every strip's slots [begin, end) (stripStart), where f writes
    /// only the points of those slots, with an accumulator acc (initialised to init) per strip;
    /// the strips' accumulators are then folded by combine(total, stripAcc) in strip order. The
    /// strips do not depend on the thread count, so neither does the result, whatever combine
    /// does (sums too); and a step as a wavefront (Solver::pipelineLoop), which gathers strip by
    /// strip, gets the same result.
    template <class Acc, class F, class C> Acc gather(int nThreads, Acc init, F&& f, C&& combine) const
    {
        const int np = size();
        if (stripStart_.size() < 2 || stripStart_.back() != np) {  // (not binned: one block)
            Acc acc = init;
            if (np > 0) f(0, np, acc);
            Acc total = init;
            combine(total, acc);
            return total;
        }
        // Worker t the strips of split_'s range t, as in the other passes (their points are then
        // in its caches; strips dealt out one by one cost 2D two threads 20 %).
        const int nb = static_cast<int>(stripStart_.size()) - 1, nRanges = static_cast<int>(split_.size()) - 1;
        std::vector<Acc> part(nb, init);
        const auto strips = [&](int lo, int hi) {
            for (int b = lo; b < hi; ++b) {
                Acc acc = init;
                f(stripStart_[b], stripStart_[b + 1], acc);
                part[b] = acc;
            }
        };
        if (nRanges < 1 || split_.back() != nb) {
            strips(0, nb);
        } else {
#pragma omp parallel for schedule(static, 1) num_threads(nThreads)
            for (int t = 0; t < nRanges; ++t) strips(split_[t], split_[t + 1]);
        }
        Acc total = init;
        for (const Acc& a : part) combine(total, a);
        return total;
    }

    /// Calls f(I) for every node of the rows [rowLo, rowHi) along the last axis (rowSize nodes
    /// each; nodal loops, each node writes itself), worker t the rows of its strips.
    template <class F> void forEachNodeOfRows(int rowLo, int rowHi, int rowSize, int nThreads, F&& f) const
    {
        const int nRanges = static_cast<int>(split_.size()) - 1;
        if (nRanges < 1) return forEachNodeIn(rowLo * rowSize, rowHi * rowSize, nThreads, f);
#pragma omp parallel for schedule(static, 1) num_threads(nThreads)
        for (int t = 0; t < nRanges; ++t) {
            const int lo = t == 0 ? rowLo : std::clamp(split_[t] * stripWidth, rowLo, rowHi);
            const int hi = t == nRanges - 1 ? rowHi : std::clamp(split_[t + 1] * stripWidth, rowLo, rowHi);
            for (int I = lo * rowSize; I < hi * rowSize; ++I) f(I);
        }
    }
    /// Calls f(I) for every node index I in [lo, hi), statically split between the workers.
    template <class F> static void forEachNodeIn(int lo, int hi, int nThreads, F&& f)
    {
#pragma omp parallel for schedule(static) num_threads(nThreads)
        for (int I = lo; I < hi; ++I) f(I);
    }

private:
    /// bin's counting sort, by strip (columns: by tile, strip-major).
    template <class K, bool columns> int binTiles(const std::vector<Vec<D>>& x, const Grid<D>& g, int nThreads, int numStrips)
    {
        const int nc = columns ? numColumns_ : 1, numKeys = numStrips * nc;
        const int np = static_cast<int>(x.size());
        const int nChunks = std::max(1, std::min(nThreads, np / minChunk));
        const auto chunkBegin = [&](int c) { return static_cast<int>(static_cast<long long>(np) * c / nChunks); };
        // The last bin's order, slot ranges and split still hold when every key is the one it
        // had then, for as many points, keys and workers: the order is a function of the keys
        // alone. Then only the keys are computed (their comparison rides in the same loop).
        const bool sameShape = binned_ && np == static_cast<int>(keyOf_.size()) && numKeys == binnedKeys_ &&
                               nc == binnedColumns_ && nThreads == binnedThreads_;
        keyOf_.resize(np);
        int firstOffGrid = INT_MAX, changed = 0;
#pragma omp parallel for schedule(static, 1) num_threads(nThreads) reduction(min : firstOffGrid) reduction(| : changed)
        for (int c = 0; c < nChunks; ++c) {
            // (The bounds are taken first: in the condition, chunkBegin's 64-bit division ran at
            // every point, the stores through the keys possibly changing what it reads.)
            const int begin = chunkBegin(c), end = chunkBegin(c + 1);
            // The keys first, in one loop without a branch per point that GCC vectorises (in the
            // lanes' width, pkg/Lanes.hpp); a point off the grid gets key -1, and only then does a
            // second loop find the chunk's first such point. (Point by point with a break at the
            // first axis off the grid, this took about 4 % of the 2D step.)
            static_assert(sizeof(Vec<D>) == D * sizeof(double), "positions as rows of D numbers");
            int* const keys = keyOf_.data();
            int anyOff = 0, anyChanged = 0;
            withLaneIsa([&]() EMP_LAMBDA_INLINE {
                // (All of it local to the loop's copy: read through the closure, GCC would not
                // vectorise the loop for fear that the keys' stores change it.)
                const double* const xs = np ? x[0].data() : nullptr;
                int* const out = keys;
                double origin[D];
                int last[D];
                for (int d = 0; d < D; ++d) origin[d] = g.origin[d], last[d] = g.n[d] - K::S;
                const double invh = g.invh;
                const int cells = columnCells_, from = begin, to = end;
                int any = 0, moved = 0;
                for (int p = from; p < to; ++p) {
                    int off = 0, b = 0, column = 0;
                    for (int d = 0; d < D; ++d) {
                        b = K::base((xs[D * p + d] - origin[d]) * invh);
                        off |= (b < 0) | (b > last[d]);
                        if (columns && d == 0) column = b / cells;
                    }
                    // b is now the base node along the last axis (the key's strip).
                    const int key = off ? -1 : columns ? b / stripWidth * nc + column : b / stripWidth;
                    moved |= key != out[p];
                    out[p] = key;
                    any |= off;
                }
                anyOff = any;
                anyChanged = moved;
            });
            changed |= anyChanged;
            if (anyOff) firstOffGrid = std::min(firstOffGrid, static_cast<int>(std::find(keys + begin, keys + end, -1) - keys));
        }
        binned_ = reused_ = false;
        if (firstOffGrid != INT_MAX) return firstOffGrid;
        if (sameShape && !changed) {
            binned_ = reused_ = true;
            return -1;
        }
        // A stable counting sort in chunks of points: each chunk counts its points per key (strip
        // or tile), and fills its slots after those of the chunks before it in each key. The
        // order is that of a serial stable sort (by key, then id) whatever the chunks.
        chunkFill_.assign(static_cast<std::size_t>(nChunks) * numKeys, 0);
#pragma omp parallel for schedule(static, 1) num_threads(nThreads)
        for (int c = 0; c < nChunks; ++c) {
            int* count = &chunkFill_[static_cast<std::size_t>(c) * numKeys];
            const int begin = chunkBegin(c), end = chunkBegin(c + 1);
            // Points in id order mostly come in runs of one key (a row of points lies in one
            // strip): each run is counted in a register and added at its end. (++count[key]
            // point by point waited on the store of the same counter by the point before.)
            int runKey = -1, run = 0;
            for (int p = begin; p < end; ++p) {
                const int key = keyOf_[p];
                if (key != runKey) {
                    if (run) count[runKey] += run;
                    runKey = key;
                    run = 0;
                }
                ++run;
            }
            if (run) count[runKey] += run;
        }
        // Key starts, and each chunk's first slot in each key.
        std::vector<int>& start = columns ? tileStart_ : stripStart_;
        start.assign(numKeys + 1, 0);
        for (int s = 0; s < numKeys; ++s) {
            int next = start[s];
            for (int c = 0; c < nChunks; ++c) {
                int& fill = chunkFill_[static_cast<std::size_t>(c) * numKeys + s];
                const int count = fill;
                fill = next;
                next += count;
            }
            start[s + 1] = next;
        }
        if (columns) {
            stripStart_.resize(numStrips + 1);
            for (int s = 0; s <= numStrips; ++s) stripStart_[s] = tileStart_[static_cast<std::size_t>(s) * nc];
        }
        order_.resize(np);
#pragma omp parallel for schedule(static, 1) num_threads(nThreads)
        for (int c = 0; c < nChunks; ++c) {
            int* fill = &chunkFill_[static_cast<std::size_t>(c) * numKeys];
            const int begin = chunkBegin(c), end = chunkBegin(c + 1);
            // (A run of one key fills from a register, as the counts above.)
            int runKey = -1, next = 0;
            for (int p = begin; p < end; ++p) {
                const int key = keyOf_[p];
                if (key != runKey) {
                    if (runKey >= 0) fill[runKey] = next;
                    runKey = key;
                    next = fill[key];
                }
                order_[next++] = p;
            }
            if (runKey >= 0) fill[runKey] = next;
        }
        splitStrips(nThreads);
        binned_ = true;
        binnedKeys_ = numKeys;
        binnedColumns_ = nc;
        binnedThreads_ = nThreads;
        return -1;
    }

    void splitStrips(int nThreads)
    {
        const int numStrips = static_cast<int>(stripStart_.size()) - 1;
        const long long np = stripStart_.back();
        split_.assign(nThreads + 1, numStrips);
        split_[0] = 0;
        for (int t = 1; t < nThreads; ++t) {
            // The strip boundary nearest to an equal share of t / nThreads of the points.
            const long long share = np * t / nThreads;
            int b = static_cast<int>(std::lower_bound(stripStart_.begin(), stripStart_.end(), share) - stripStart_.begin());
            if (b > 0 && share - stripStart_[b - 1] < stripStart_[b] - share) --b;
            split_[t] = std::clamp(b, split_[t - 1], numStrips);
        }
    }

    /// Points per chunk of bin's counting sort at least (fewer points: one chunk, serial).
    static constexpr int minChunk = 4096;
    std::vector<int> order_, stripStart_, tileStart_, keyOf_, chunkFill_, split_;
    int columnCells_ = 0, numColumns_ = 1;
    /// Whether order_ and the slot ranges are those of keyOf_, binned for binnedKeys_ keys,
    /// binnedColumns_ columns and binnedThreads_ workers (bin's reuse of an unchanged order).
    bool binned_ = false, reused_ = false;
    int binnedKeys_ = 0, binnedColumns_ = 0, binnedThreads_ = 0;
    bool separatePhases_ = false;
    int deferred_[2] = {-1, -1};
};

}  // namespace emp
