// Scheduling, apart from the physics: which points and nodes a worker owns and in which order
// the contributions reach a node. Points are binned (stable counting sort) into strips of
// `stripWidth` cells along the last axis; a scatter to the grid runs the strips in two colours,
// so strips of one colour never write the same node and need neither atomics nor per-thread
// copies. The order of the contributions to every node is then fixed whatever the thread
// count: results are bitwise independent of it. This is also the seam where a distributed run
// decides which points and nodes a process owns.
#pragma once
#include <algorithm>
#include <climits>
#include <functional>
#include <string>
#include <vector>

#include "Grid.hpp"

namespace emp {

template <int D> class Scheduler {
public:
    /// Cells per strip: strips two apart never share a node (needs stripWidth >= S - 1).
    static constexpr int stripWidth = 4;

    /// Bins the points at x by strip, for the kernel K. Returns the id of the first point whose
    /// support leaves the grid (binned nowhere), or -1 when all are on it.
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

    template <class K> int bin(const std::vector<Vec<D>>& x, const Grid<D>& g, int nThreads)
    {
        static_assert(stripWidth >= K::S - 1, "strips of one colour would share nodes");
        constexpr int last = D - 1;
        const int numStrips = (g.n[last] - K::S) / stripWidth + 1;
        const int np = static_cast<int>(x.size());
        stripOf_.resize(np);
        int firstOffGrid = INT_MAX;
#pragma omp parallel for schedule(static) num_threads(nThreads) reduction(min : firstOffGrid)
        for (int p = 0; p < np; ++p) {
            int b = 0;
            for (int d = 0; d < D; ++d) {
                b = K::base((x[p][d] - g.origin[d]) * g.invh);
                if (!(b >= 0 && b <= g.n[d] - K::S)) {
                    firstOffGrid = std::min(firstOffGrid, p);
                    b = 0;
                    break;
                }
            }
            stripOf_[p] = b / stripWidth;  // b is now the base node along the last axis
        }
        if (firstOffGrid != INT_MAX) return firstOffGrid;
        stripStart_.assign(numStrips + 1, 0);
        for (int p = 0; p < np; ++p) ++stripStart_[stripOf_[p] + 1];
        for (int s = 0; s < numStrips; ++s) stripStart_[s + 1] += stripStart_[s];
        order_.resize(np);
        stripFill_.assign(stripStart_.begin(), stripStart_.end() - 1);
        for (int p = 0; p < np; ++p) order_[stripFill_[stripOf_[p]]++] = p;
        return -1;
    }

    /// Point ids in binned order: slot k holds point order()[k].
    const std::vector<int>& order() const { return order_; }
    int size() const { return static_cast<int>(order_.size()); }

    /// Calls f(slot) for every slot, where f may scatter to the nodes of its point's support:
    /// two colours of strips, each strip in slot order.
    /// `between`, when given, runs between the two colours (a distributed run's exchange,
    /// Distribution.hpp).
    template <class F> void scatter(int nThreads, F&& f, const std::function<void()>& between = {}) const
    {
        scatterStrips(nThreads, [&](int begin, int end) {
            for (int k = begin; k < end; ++k) f(k);
        }, between);
    }

    /// scatter in runs: calls f(begin, end) for consecutive ranges of at most `run` slots of one
    /// strip, in slot order. A pass can then do its per-point work for the whole run before it
    /// scatters: points are independent until they write, so their long chains of dependent
    /// arithmetic (the law's square roots and divisions) overlap in the processor instead of
    /// following each other; the order of the contributions to each node is that of scatter.
    template <class F> void scatterRuns(int nThreads, int run, F&& f, const std::function<void()>& between = {}) const
    {
        scatterStrips(nThreads, [&](int begin, int end) {
            for (int k = begin; k < end; k += run) f(k, std::min(k + run, end));
        }, between);
    }

    /// The strips of scatter: calls f(begin, end) with the slot range of every strip, two colours
    /// of strips one after the other, the strips of a colour on the workers.
    template <class F> void scatterStrips(int nThreads, F&& f, const std::function<void()>& between = {}) const
    {
        const int numStrips = static_cast<int>(stripStart_.size()) - 1;
        for (int colour = 0; colour < 2; ++colour) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(nThreads)
            for (int s = colour; s < numStrips; s += 2) f(stripStart_[s], stripStart_[s + 1]);
            if (colour == 0 && between) between();
        }
    }

    /// Calls f(slot, acc) for every slot where f writes only its own point, with an accumulator
    /// acc (initialised to init) per block of `gatherBlock` consecutive slots; the blocks'
    /// accumulators are then folded by combine(total, blockAcc) in block order. The blocks do not
    /// depend on the thread count, so neither does the result, whatever combine does (sums too).
    template <class Acc, class F, class C> Acc gather(int nThreads, Acc init, F&& f, C&& combine) const
    {
        constexpr int gatherBlock = 2048;
        const int np = size(), nb = (np + gatherBlock - 1) / gatherBlock;
        std::vector<Acc> part(nb, init);
#pragma omp parallel for schedule(static) num_threads(nThreads)
        for (int b = 0; b < nb; ++b) {
            Acc acc = init;
            const int end = std::min(np, (b + 1) * gatherBlock);
            for (int k = b * gatherBlock; k < end; ++k) f(k, acc);
            part[b] = acc;
        }
        Acc total = init;
        for (const Acc& a : part) combine(total, a);
        return total;
    }

    /// Calls f(I) for every node index I in [0, n) (nodal loops: each node writes itself).
    template <class F> static void forEachNode(int n, int nThreads, F&& f)
    {
#pragma omp parallel for schedule(static) num_threads(nThreads)
        for (int I = 0; I < n; ++I) f(I);
    }
    /// forEachNode over the nodes [lo, hi) only (a distributed run's planes).
    template <class F> static void forEachNodeIn(int lo, int hi, int nThreads, F&& f)
    {
#pragma omp parallel for schedule(static) num_threads(nThreads)
        for (int I = lo; I < hi; ++I) f(I);
    }

private:
    std::vector<int> order_, stripStart_, stripOf_, stripFill_;
};

}  // namespace emp
