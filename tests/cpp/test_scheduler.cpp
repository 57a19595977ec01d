// The scheduler's split of the work between threads: which worker runs which strip and which
// node rows may change the speed only. Every strip runs once, in slot order, all strips of
// colour 0 before any of colour 1; every node of a nodal loop is visited once; the workers'
// ranges are contiguous and balanced by points to a strip.
#include <omp.h>

#include <atomic>
#include <mutex>
#include <numeric>

#include "test_helpers.hpp"

namespace {

using emp::GimpKernel;
using emp::Grid;
using emp::Scheduler;
using emptest::Vec;

constexpr int D = 2;
using K = GimpKernel;

/// A 2D grid 10 cells wide and 60 tall, with points in strips of very different counts.
struct Scene {
    Grid<D> g;
    std::vector<Vec<D>> x;
    std::vector<int> perStrip;  // points per strip, from Scheduler::stripOf
    Scene()
    {
        g.resize(Vec<D>::Zero(), 1.0, std::array<int, D>{12, 62});
        const int numStrips = Scheduler<D>::numStrips<K>(g);
        perStrip.assign(numStrips, 0);
        const int counts[] = {0, 40, 3, 3, 90, 0, 0, 25, 1, 60, 7, 0, 0, 0, 30};
        std::mt19937 rng(5);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        for (int s = 0; s < numStrips && s < 15; ++s)
            for (int i = 0; i < counts[s]; ++i) {
                // A place inside strip s (cells 4s + 1 .. 4s + 4 hold the bases 4s .. 4s + 3).
                const Vec<D> p(1.5 + 8.0 * u(rng), 4.0 * s + 1.0 + 3.4 * u(rng));
                x.push_back(p);
            }
        std::shuffle(x.begin(), x.end(), rng);
        for (const auto& p : x) ++perStrip[Scheduler<D>::stripOf<K>(p, g)];
    }
};

TEST(Scheduler, SplitGivesEachWorkerContiguousStripsOfAboutAnEqualShareOfPoints)
{
    Scene sc;
    const int numStrips = static_cast<int>(sc.perStrip.size());
    std::vector<int> before(numStrips + 1, 0);  // points in the strips before each boundary
    for (int s = 0; s < numStrips; ++s) before[s + 1] = before[s] + sc.perStrip[s];
    const int np = before.back();
    ASSERT_EQ(np, static_cast<int>(sc.x.size()));
    for (int T = 1; T <= 6; ++T) {
        Scheduler<D> sch;
        ASSERT_EQ(sch.bin<K>(sc.x, sc.g, T), -1);
        const auto& split = sch.split();
        ASSERT_EQ(static_cast<int>(split.size()), T + 1);
        EXPECT_EQ(split.front(), 0);
        EXPECT_EQ(split.back(), numStrips);
        for (int t = 1; t <= T; ++t) {
            EXPECT_LE(split[t - 1], split[t]) << "T = " << T;
            if (t == T) break;
            // Boundary t is the strip boundary nearest to t/T of the points (or the one before
            // it, when that is nearer to no worse).
            const double share = static_cast<double>(np) * t / T;
            double best = 1e300;
            for (int b = split[t - 1]; b <= numStrips; ++b) best = std::min(best, std::abs(before[b] - share));
            EXPECT_LE(std::abs(before[split[t]] - share), best + 1.0) << "T = " << T << ", t = " << t;
        }
    }
}

TEST(Scheduler, BinningInChunksIsTheStableSortByStrip)
{
    // Enough points for several chunks of the counting sort: the order is that of a stable
    // sort of the ids by strip, for any number of workers.
    Grid<D> g;
    g.resize(Vec<D>::Zero(), 1.0, std::array<int, D>{40, 90});
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> ux(1.0, 38.4), u(0.0, 1.0);
    std::vector<Vec<D>> x(30011);
    for (auto& p : x) {
        const double v = u(rng);
        p = Vec<D>(ux(rng), 1.0 + 86.0 * v * v);  // denser at the bottom
    }
    std::vector<int> expected(x.size());
    std::iota(expected.begin(), expected.end(), 0);
    std::stable_sort(expected.begin(), expected.end(), [&](int a, int b) {
        return Scheduler<D>::stripOf<K>(x[a], g) < Scheduler<D>::stripOf<K>(x[b], g);
    });
    for (int T : {1, 2, 3, 7}) {
        Scheduler<D> sch;
        ASSERT_EQ(sch.bin<K>(x, g, T), -1);
        EXPECT_EQ(sch.order(), expected) << T << " workers";
    }
    // A point off the grid is reported, the first one whatever the chunks.
    x[20000] = Vec<D>(-5.0, 3.0);
    x[29000] = Vec<D>(3.0, 1e3);
    for (int T : {1, 2, 3, 7}) EXPECT_EQ(Scheduler<D>().bin<K>(x, g, T), 20000) << T << " workers";
}

TEST(Scheduler, ScatterRunsEveryStripOnceInSlotOrderColourZeroFirst)
{
    Scene sc;
    for (int binThreads : {1, 2, 3, 5})
        for (int threads : {1, 2, 3}) {
            Scheduler<D> sch;
            ASSERT_EQ(sch.bin<K>(sc.x, sc.g, binThreads), -1);
            const auto& order = sch.order();
            std::vector<int> visits(order.size(), 0), next(sc.perStrip.size(), -1);
            std::atomic<bool> between{false}, wrong{false};
            std::mutex m;
            sch.scatter(threads, [&](int k) {
                const int s = Scheduler<D>::stripOf<K>(sc.x[order[k]], sc.g);
                std::lock_guard<std::mutex> lock(m);
                ++visits[k];
                if ((s % 2 == 1) != between.load()) wrong = true;  // colour 1 before the hook, or 0 after
                if (next[s] >= 0 && k != next[s]) wrong = true;  // a strip's slots in order
                next[s] = k + 1;
            }, [&](int phase) {
                EXPECT_EQ(phase, 0);
                between = true;
            });
            EXPECT_FALSE(wrong.load()) << binThreads << " workers binned, " << threads << " threads";
            for (std::size_t k = 0; k < visits.size(); ++k) ASSERT_EQ(visits[k], 1) << "slot " << k;
        }
}

/// n points spread uniformly over [1, xHi) x [1, yHi) (cells of a unit grid from the origin).
std::vector<Vec<D>> uniformPoints(int n, double xHi, double yHi, unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(1.0, xHi), uy(1.0, yHi);
    std::vector<Vec<D>> x(n);
    for (auto& p : x) p = Vec<D>(ux(rng), uy(rng));
    return x;
}

TEST(Scheduler, BinningWithColumnsIsTheStableSortByStripThenColumn)
{
    Grid<D> g;
    g.resize(Vec<D>::Zero(), 1.0, std::array<int, D>{40, 90});
    const std::vector<Vec<D>> x = uniformPoints(30011, 38.4, 87.0, 23);
    for (int cells : {2, 5, 37}) {
        Scheduler<D> sch;
        sch.setColumns(cells);
        const auto key = [&](int p) { return std::pair{Scheduler<D>::stripOf<K>(x[p], g), sch.columnOf<K>(x[p], g)}; };
        std::vector<int> expected(x.size());
        std::iota(expected.begin(), expected.end(), 0);
        std::stable_sort(expected.begin(), expected.end(), [&](int a, int b) { return key(a) < key(b); });
        for (int T : {1, 2, 3, 7}) {
            ASSERT_EQ(sch.bin<K>(x, g, T), -1);
            ASSERT_EQ(sch.numColumns(), (g.n[0] - K::S) / cells + 1);
            EXPECT_EQ(sch.order(), expected) << T << " workers, columns of " << cells;
            // Every tile's slots hold the points of its strip and column; the strips' starts are
            // their first tiles'.
            const int nc = sch.numColumns();
            const auto& tile = sch.tileStart();
            ASSERT_EQ(static_cast<int>(tile.size()), Scheduler<D>::numStrips<K>(g) * nc + 1);
            for (int t = 0; t + 1 < static_cast<int>(tile.size()); ++t)
                for (int k = tile[t]; k < tile[t + 1]; ++k) ASSERT_EQ(key(sch.order()[k]), std::pair(t / nc, t % nc));
            for (std::size_t s = 0; s < sch.stripStart().size(); ++s) ASSERT_EQ(sch.stripStart()[s], tile[s * nc]);
        }
    }
    Scheduler<D> narrow;
    narrow.setColumns(1);  // uGIMP's support spans two cells: tiles one cell wide would share nodes
    EXPECT_THROW(narrow.bin<K>(x, g, 1), emp::ParameterError);
}

// bin keeps the last order when no point's key changed (it then computes the keys alone): after
// every change of the points, the workers or the columns, one scheduler binned again and again
// gives what a fresh one gives for the same input (order, slot ranges, split), and it reused its
// order exactly when every key, the number of points, keys and workers were those of the bin
// before.
TEST(Scheduler, BinningAgainKeepsTheOrderOnlyWhereAFreshBinningGivesIt)
{
    Grid<D> g;
    g.resize(Vec<D>::Zero(), 1.0, std::array<int, D>{40, 90});
    std::vector<Vec<D>> x = uniformPoints(12011, 38.4, 87.0, 41);
    Scheduler<D> sch;
    int columns = 0, rebins = 0, reuses = 0;
    const auto binAndCompare = [&](int T, bool expectReuse, const char* what) {
        Scheduler<D> fresh;
        fresh.setColumns(columns);
        sch.setColumns(columns);
        const int off = fresh.bin<K>(x, g, T);
        ASSERT_EQ(sch.bin<K>(x, g, T), off) << what;
        EXPECT_EQ(sch.reusedLastBin(), expectReuse) << what;
        EXPECT_FALSE(fresh.reusedLastBin()) << what;
        (sch.reusedLastBin() ? reuses : rebins) += 1;
        if (off >= 0) return;
        EXPECT_EQ(sch.order(), fresh.order()) << what;
        EXPECT_EQ(sch.stripStart(), fresh.stripStart()) << what;
        EXPECT_EQ(sch.tileStart(), fresh.tileStart()) << what;
        EXPECT_EQ(sch.split(), fresh.split()) << what;
        EXPECT_EQ(sch.numColumns(), fresh.numColumns()) << what;
        for (int p = 0; p < static_cast<int>(x.size()); p += 97) EXPECT_EQ(sch.slotOf(p), fresh.slotOf(p)) << what;
    };
    // Moves that keep every point's base node along y in its strip (bases 2s and 2s + 1: uGIMP's
    // base is floor(y + 1/2) - 1, so y in [2s + 1/2, 2s + 5/2) stays in strip s).
    const auto jiggle = [&](double amount) {
        for (auto& p : x) {
            const int s = Scheduler<D>::stripOf<K>(p, g);
            p[0] = std::clamp(p[0] + amount, 1.0, 38.4);
            p[1] = std::clamp(p[1] + amount, 2.0 * s + 0.5, 2.0 * s + 2.5 - 1e-9);
        }
    };
    binAndCompare(2, false, "first bin");
    binAndCompare(2, true, "the same positions");
    jiggle(0.3);
    binAndCompare(2, true, "moves within the strips");
    // Two points trade places: in one strip the keys stay, in two strips they change.
    const auto strip = [&](int p) { return Scheduler<D>::stripOf<K>(x[p], g); };
    int same = 11, other = 11;
    while (strip(same) != strip(10)) ++same;
    while (strip(other) == strip(10)) ++other;
    std::swap(x[10], x[same]);
    binAndCompare(2, true, "two points of one strip swapped");
    std::swap(x[10], x[other]);
    binAndCompare(2, false, "two points of two strips swapped");
    x[500][1] += 6.0;  // one point three strips up
    binAndCompare(2, false, "one point to another strip");
    binAndCompare(2, true, "unchanged after it");
    binAndCompare(3, false, "three workers");
    binAndCompare(3, true, "three workers again");
    binAndCompare(1, false, "one worker");
    x.push_back(x[7]);  // a point more, in a strip that has points
    binAndCompare(1, false, "a point added");
    binAndCompare(1, true, "unchanged after it");
    const Vec<D> keep = x[300];
    x[300] = Vec<D>(-5.0, 3.0);
    binAndCompare(1, false, "a point off the grid");
    x[300] = keep;
    binAndCompare(1, false, "back on the grid");
    binAndCompare(1, true, "unchanged after it");
    columns = 5;
    binAndCompare(2, false, "columns");
    binAndCompare(2, true, "columns, unchanged");
    x[900][0] = x[900][0] < 20.0 ? x[900][0] + 10.0 : x[900][0] - 10.0;  // to another column of its strip
    binAndCompare(2, false, "a point to another column");
    binAndCompare(2, true, "columns, unchanged after it");
    columns = 0;
    binAndCompare(2, false, "no columns again");
    g.resize(Vec<D>::Zero(), 1.0, std::array<int, D>{40, 94});  // another grid: more strips
    binAndCompare(2, false, "a taller grid");
    EXPECT_EQ(reuses, 9);
    EXPECT_GE(rebins, 12);
}

// The strips a box of nodes can be reached from (P2G tests only their points for the marked box
// of a crack): against every point's support, and against each strip's bases by brute force.
template <class Kern> void checkSlotsReaching(int columns)
{
    constexpr int S = Kern::S, w = Scheduler<D>::stripWidth;
    Grid<D> g;
    g.resize(Vec<D>::Zero(), 1.0, std::array<int, D>{17, 41});
    const std::vector<Vec<D>> x = uniformPoints(4000, 14.0, 38.0, 31);
    Scheduler<D> sch;
    sch.setColumns(columns);
    ASSERT_EQ(sch.bin<Kern>(x, g, 2), -1);
    const int numStrips = static_cast<int>(sch.stripStart().size()) - 1;
    int reached = 0, outside = 0;
    for (int lo = -4; lo <= 43; ++lo)
        for (int hi = lo - 1; hi <= lo + 6; ++hi) {
            const auto [first, second] = sch.slotsReaching<Kern>(lo, hi);
            // A strip can reach [lo, hi] when one of its bases b has [b, b + S - 1] meet it.
            int sLo = numStrips, sHi = -1;
            for (int s = 0; s < numStrips; ++s)
                for (int b = s * w; b < (s + 1) * w; ++b)
                    if (lo <= hi && b <= hi && b + S - 1 >= lo) sLo = std::min(sLo, s), sHi = std::max(sHi, s);
            const auto expected = sLo <= sHi ? std::pair{sch.stripStart()[sLo], sch.stripStart()[sHi + 1]} : std::pair{0, 0};
            ASSERT_EQ(std::pair(first, second), expected) << "nodes " << lo << " .. " << hi;
            for (int k = 0; k < sch.size(); ++k) {
                const int b = Kern::base(x[sch.order()[k]][D - 1]);
                const bool reaches = lo <= hi && b <= hi && b + S - 1 >= lo;
                if (reaches) ASSERT_TRUE(k >= first && k < second) << "slot " << k << ", base " << b << ", nodes " << lo << " .. " << hi;
                reached += reaches;
                outside += !(k >= first && k < second);
            }
        }
    EXPECT_GT(reached, 10000);
    EXPECT_GT(outside, 10000);  // most boxes leave most strips out
}

TEST(Scheduler, SlotsReachingHoldEveryPointWhoseSupportReachesTheNodes)
{
    checkSlotsReaching<GimpKernel>(0);
    checkSlotsReaching<GimpKernel>(3);
    checkSlotsReaching<emp::LinearKernel>(0);
}

TEST(Scheduler, SlotOfIsTheInverseOfTheOrder)
{
    // Scheduler::slotOf (the traction and erosion stages read P2G's stencils by it) finds every
    // point's slot of the last binning, with and without columns, and -1 for an unknown id.
    Grid<D> g;
    g.resize(Vec<D>::Zero(), 1.0, std::array<int, D>{40, 90});
    std::mt19937 rng(31);
    std::uniform_real_distribution<double> ux(1.0, 38.4), uy(1.0, 87.0);
    std::vector<Vec<D>> x(20011);
    for (auto& p : x) p = Vec<D>(ux(rng), uy(rng));
    for (int cells : {0, 2, 7}) {
        Scheduler<D> sch;
        sch.setColumns(cells);
        EXPECT_EQ(sch.slotOf(0), -1);  // not binned yet
        for (int T : {1, 3}) {
            ASSERT_EQ(sch.bin<K>(x, g, T), -1);
            for (int k = 0; k < sch.size(); ++k) ASSERT_EQ(sch.slotOf(sch.order()[k]), k) << "columns of " << cells;
            EXPECT_EQ(sch.slotOf(-1), -1);
            EXPECT_EQ(sch.slotOf(static_cast<int>(x.size())), -1);
        }
    }
}

TEST(Scheduler, ScatterWithColumnsGivesEveryNodeItsContributionsInOneOrderWhateverTheThreads)
{
    // Every node records which slots wrote it, in the order they did: that order is the same for
    // any number of binning and scattering workers, no two tiles of one colour write one node,
    // a node's tiles come in colour order (strip parity, then column parity), and the hook runs
    // between the strips' two colours.
    Scene sc;
    std::vector<std::vector<int>> first;
    for (bool separate : {true, false})  // (the columns' colours as phases of their own, or strip by strip)
    for (int binThreads : {1, 2, 3})
        for (int threads : {1, 2, 3}) {
            Scheduler<D> sch;
            sch.setColumns(2);
            sch.setSeparatePhases(separate);
            ASSERT_EQ(sch.bin<K>(sc.x, sc.g, binThreads), -1);
            ASSERT_EQ(sch.numPhases(), separate ? 4 : 2);
            ASSERT_GT(sch.numColumns(), 2);
            const auto& order = sch.order();
            std::vector<std::vector<int>> writers(sc.g.numNodes());
            std::vector<int> visits(order.size(), 0);
            std::atomic<bool> between{false}, wrong{false};
            std::mutex m;
            sch.scatter(threads, [&](int k) {
                const Vec<D>& p = sc.x[order[k]];
                const int s = Scheduler<D>::stripOf<K>(p, sc.g);
                const int b0 = K::base(p[0]), b1 = K::base(p[1]);
                std::lock_guard<std::mutex> lock(m);
                ++visits[k];
                if ((s % 2 == 1) != between.load()) wrong = true;
                for (int i = b0; i < b0 + K::S; ++i)
                    for (int j = b1; j < b1 + K::S; ++j) writers[j * sc.g.stride[1] + i].push_back(k);
            }, [&](int phase) {
                if (phase == sch.numPhases() / 2 - 1) between = true;  // (after the even strips)
            });
            EXPECT_FALSE(wrong.load()) << binThreads << " workers binned, " << threads << " threads";
            for (std::size_t k = 0; k < visits.size(); ++k) ASSERT_EQ(visits[k], 1) << "slot " << k;
            for (const auto& w : writers) {
                int lastColour = -1, lastTile = -1;
                for (int k : w) {
                    const Vec<D>& p = sc.x[order[k]];
                    const int s = Scheduler<D>::stripOf<K>(p, sc.g), c = sch.columnOf<K>(p, sc.g);
                    const int colour = 2 * (s % 2) + c % 2, tile = s * sch.numColumns() + c;
                    if (tile != lastTile) {
                        ASSERT_GT(colour, lastColour) << "a node's tiles out of colour order, or two of one colour";
                        lastColour = colour;
                        lastTile = tile;
                    }
                }
            }
            // (Points ids in place of slots: the slots depend on the binning only, the same here.)
            if (first.empty())
                first = writers;
            else
                EXPECT_EQ(writers, first) << binThreads << " workers binned, " << threads << " threads, "
                                          << (separate ? "separate" : "strip by strip");
        }
}

TEST(Scheduler, NodalLoopsVisitEveryNodeOfTheirRowsOnce)
{
    Scene sc;
    const int rows = sc.g.n[D - 1], rowSize = sc.g.stride[D - 1];
    for (int binThreads : {0, 1, 2, 4})  // 0: not binned yet
        for (int threads : {1, 2, 3})
            for (auto [lo, hi] : {std::pair{0, rows}, std::pair{9, 30}, std::pair{33, 34}, std::pair{5, 5}}) {
                Scheduler<D> sch;
                if (binThreads) ASSERT_EQ(sch.bin<K>(sc.x, sc.g, binThreads), -1);
                std::vector<std::atomic<int>> visits(sc.g.numNodes());
                for (auto& v : visits) v = 0;
                std::vector<int> worker(sc.g.numNodes(), -1);
                sch.forEachNodeOfRows(lo, hi, rowSize, threads, [&](int I) {
                    ++visits[I];
                    worker[I] = omp_get_thread_num();
                });
                for (int I = 0; I < sc.g.numNodes(); ++I) {
                    const int row = I / rowSize;
                    ASSERT_EQ(visits[I].load(), row >= lo && row < hi ? 1 : 0)
                        << "node " << I << ", rows " << lo << ".." << hi << ", " << binThreads << "/" << threads;
                }
                // With as many threads as workers, worker t takes the rows of its strips.
                if (binThreads == threads && threads > 1 && lo == 0 && hi == rows)
                    for (int I = 0; I < sc.g.numNodes(); ++I) {
                        const int row = I / rowSize, strip = std::min(row / Scheduler<D>::stripWidth,
                                                                      static_cast<int>(sc.perStrip.size()) - 1);
                        int t = 0;
                        while (t + 1 < threads && sch.split()[t + 1] <= strip) ++t;
                        ASSERT_EQ(worker[I], t) << "node " << I;
                    }
            }
}

}  // namespace
