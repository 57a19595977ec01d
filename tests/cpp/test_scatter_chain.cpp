// A decomposition in two directions on one process (ScatterChain.hpp): ranks emulated in memory,
// each scattering only the points of its blocks of tiles, phase by phase, and handing on the
// partial sums the chain names after each phase, end with the node sums of the one-process
// scatter, bitwise, on every node their points write; for blocks in one and two directions, 2D
// and 3D, both shapes, one and two threads per rank.
#include <map>

#include "test_helpers.hpp"
#include "ScatterChain.hpp"

namespace {

using emp::Blocks;
using emp::GimpKernel;
using emp::Grid;
using emp::LinearKernel;
using emp::ScatterChain;
using emp::Scheduler;
using emptest::Vec;

/// A value per point and node whose sums round differently in every order.
double contribution(int id, int node) { return std::sin(0.7 * id + 0.013 * node) * (1.0 + 1e-3 * (id % 97)); }

template <int D, class K> std::vector<int> supportOf(const Vec<D>& x, const Grid<D>& g)
{
    int base[D];
    for (int d = 0; d < D; ++d) base[d] = K::base((x[d] - g.origin[d]) * g.invh);
    std::vector<int> nodes;
    int i[3] = {0, 0, 0};
    for (i[2] = 0; i[2] < (D == 3 ? K::S : 1); ++i[2])
        for (i[1] = 0; i[1] < K::S; ++i[1])
            for (i[0] = 0; i[0] < K::S; ++i[0]) {
                int I = 0;
                for (int d = 0; d < D; ++d) I += (base[d] + i[d]) * g.stride[d];
                nodes.push_back(I);
            }
    return nodes;
}

/// Scatters the points x (ids: their one-process ids) with the scheduler, one phase at a time.
template <int D, class K> struct Rank {
    std::vector<Vec<D>> x;
    std::vector<int> id;
    Scheduler<D> sch;
    std::vector<double> sum;
    /// deferred: the columns this rank's phases defer (Distribution::deferredColumns).
    void bin(const Grid<D>& g, int columnCells, int threads, std::array<int, 2> deferred = {-1, -1})
    {
        sch.setColumns(columnCells);
        sch.setSeparatePhases(true, deferred[0], deferred[1]);
        ASSERT_EQ(sch.template bin<K>(x, g, threads), -1);
        sum.assign(g.numNodes(), 0.0);
    }
    void phase(int k, const Grid<D>& g, int threads)
    {
        const auto& order = sch.order();
        sch.scatterPhase(k, threads, [&](int begin, int end) {
            for (int slot = begin; slot < end; ++slot) {
                const int p = order[slot];
                for (int I : supportOf<D, K>(x[p], g)) sum[I] += contribution(id[p], I);
            }
        });
    }
};

template <int D, class K> void checkChain(int columnCells, const Blocks& blocks, int threads, unsigned seed)
{
    SCOPED_TRACE(::testing::Message() << D << "D " << K::name << ", columns of " << columnCells << ", "
                                      << blocks.rows() << " x " << blocks.cols() << " ranks, " << threads << " threads");
    Grid<D> g;
    std::array<int, D> n;
    n.fill(D == 2 ? 47 : 19);
    n[D - 1] = D == 2 ? 61 : 23;
    g.resize(Vec<D>::Zero(), 1.0, n);
    std::mt19937 rng(seed);
    Rank<D, K> one;
    for (int p = 0; p < (D == 2 ? 6000 : 9000); ++p) {
        Vec<D> x;
        for (int d = 0; d < D; ++d) x[d] = std::uniform_real_distribution<double>(0.6, n[d] - 1.6)(rng);
        one.x.push_back(x);
        one.id.push_back(p);
    }
    one.bin(g, columnCells, threads);
    for (int k = 0; k < one.sch.numPhases(); ++k) one.phase(k, g, threads);

    // The ranks: each the points of its tiles, in id order.
    const int R = blocks.size();
    std::vector<Rank<D, K>> ranks(R);
    for (std::size_t p = 0; p < one.x.size(); ++p) {
        const int s = Scheduler<D>::template stripOf<K>(one.x[p], g), c = one.sch.template columnOf<K>(one.x[p], g);
        Rank<D, K>& r = ranks[blocks.rankOf(s, c)];
        r.x.push_back(one.x[p]);
        r.id.push_back(static_cast<int>(p));
    }
    std::vector<ScatterChain<D>> chain;
    for (int r = 0; r < R; ++r) {
        // A rank defers its odd columns at its boundaries with other ranks' columns.
        const int c = r % blocks.cols(), lo = blocks.columns[c], hi = blocks.columns[c + 1] - 1;
        ranks[r].bin(g, columnCells, threads,
                     {c > 0 && lo % 2 == 1 ? lo : -1, c < blocks.cols() - 1 && hi % 2 == 1 ? hi : -1});
        chain.emplace_back(n, K::S, Scheduler<D>::stripWidth, columnCells, blocks, r);
        ASSERT_EQ(chain[r].numPhases(), one.sch.numPhases());
    }
    int handed = 0;
    for (int k = 0; k < one.sch.numPhases(); ++k) {
        for (auto& r : ranks) r.phase(k, g, threads);
        // Every rank's messages first (as they are sent at once), then every rank takes its own.
        std::map<std::pair<int, int>, std::vector<double>> sent;  // (from, to) -> values
        for (int r = 0; r < R; ++r)
            for (const auto& pass : chain[r].sends(k)) {
                auto& v = sent[{r, pass.rank}];
                for (int I : pass.nodes) v.push_back(ranks[r].sum[I]);
                handed += static_cast<int>(pass.nodes.size());
            }
        for (int r = 0; r < R; ++r)
            for (const auto& pass : chain[r].receives(k)) {
                const auto it = sent.find({pass.rank, r});
                ASSERT_TRUE(it != sent.end()) << "rank " << r << " waits for rank " << pass.rank << " after phase " << k;
                ASSERT_EQ(it->second.size(), pass.nodes.size()) << "ranks " << pass.rank << " -> " << r << ", phase " << k;
                for (std::size_t i = 0; i < pass.nodes.size(); ++i) ranks[r].sum[pass.nodes[i]] = it->second[i];
                sent.erase(it);
            }
        ASSERT_TRUE(sent.empty()) << "a pass sent after phase " << k << " that no rank takes";
    }
    if (R > 1) EXPECT_GT(handed, 0);
    // Every node a rank's points write holds the one-process sum, bitwise.
    int checked = 0;
    for (int r = 0; r < R; ++r)
        for (const auto& x : ranks[r].x)
            for (int I : supportOf<D, K>(x, g)) {
                ASSERT_EQ(ranks[r].sum[I], one.sum[I]) << "rank " << r << ", node " << I;
                ++checked;
            }
    EXPECT_GT(checked, 0);
}

/// Blocks of rows x cols ranks, the ranges cut at uneven places.
template <int D, class K> Blocks blocksOf(int rows, int cols, int columnCells)
{
    const int nL = D == 2 ? 61 : 23, n0 = D == 2 ? 47 : 19;
    const int strips = (nL - K::S) / Scheduler<D>::stripWidth + 1, columns = columnCells > 0 ? (n0 - K::S) / columnCells + 1 : 1;
    Blocks b;
    const auto cut = [](int count, int parts) {
        std::vector<int> first{0};
        for (int i = 1; i < parts; ++i) first.push_back(count * i / parts + (i % 2 ? 1 : -1) * (i > 0 && count / parts > 2));
        first.push_back(count);
        return first;
    };
    b.strips = cut(strips, rows);
    b.columns = cut(columns, cols);
    return b;
}

template <int D, class K> void checkAll(int columnCells)
{
    for (auto [rows, cols] : {std::pair{1, 1}, std::pair{2, 1}, std::pair{3, 1}, std::pair{1, 2}, std::pair{2, 2},
                              std::pair{3, 2}, std::pair{2, 3}})
        for (int threads : {1, 2}) {
            if (cols > 1 && columnCells == 0) continue;
            checkChain<D, K>(columnCells, blocksOf<D, K>(rows, cols, columnCells), threads, 11 * rows + cols);
        }
}

TEST(ScatterChain, RanksInBlocksSumEveryNodeAsOneProcess2DGimp) { checkAll<2, GimpKernel>(2); }
TEST(ScatterChain, RanksInBlocksSumEveryNodeAsOneProcess2DGimpWideColumns) { checkAll<2, GimpKernel>(5); }
TEST(ScatterChain, RanksInBlocksSumEveryNodeAsOneProcess2DLinear) { checkAll<2, LinearKernel>(1); }
TEST(ScatterChain, RanksInStripsSumEveryNodeAsOneProcessWithoutColumns) { checkAll<2, GimpKernel>(0); }
TEST(ScatterChain, RanksInBlocksSumEveryNodeAsOneProcess3DGimp) { checkAll<3, GimpKernel>(2); }
TEST(ScatterChain, RanksInBlocksSumEveryNodeAsOneProcess3DLinear) { checkAll<3, LinearKernel>(3); }

TEST(ScatterChain, BlocksThatDoNotCoverTheTilesAreRefused)
{
    Blocks b;
    b.strips = {0, 5, 12};  // the 2D grid below has 30 strips, and 23 columns of 2 cells
    b.columns = {0, 23};
    const std::array<int, 2> n{47, 61};
    EXPECT_THROW((ScatterChain<2>(n, 3, 2, 2, b, 0)), emp::ParameterError);
    b.strips = {0, 5, 30};
    EXPECT_NO_THROW((ScatterChain<2>(n, 3, 2, 2, b, 1)));
    EXPECT_THROW((ScatterChain<2>(n, 3, 2, 2, b, 2)), emp::ParameterError);  // rank 2 of 2
}

}  // namespace
