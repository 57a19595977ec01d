// A decomposition of the grid in two directions (issue 17; doc/parallel.md, "Decomposition in
// two directions"): which ranks write each node of a scatter, in which order, and the partial
// sums they hand each other between the colours so that every node still receives its
// contributions in the order of one process.
//
// The Scheduler's tiles (strips along the last axis, cut into columns along the first:
// Scheduler::setColumns) are dealt out in blocks: the ranks form a grid of `rows` along the last
// axis and `cols` along the first, rank row * cols + col holding a contiguous range of strips and
// one of columns. One process scatters the tiles in colours (Scheduler::numPhases), and the tiles
// that write one node have different colours; so a node's sum is the contributions of its tiles
// in colour order, each tile's in slot order. Split between ranks, the rank whose tile writes a
// node in phase k continues from the partial sum of the rank that wrote it last before, which
// hands it on after its phase; after the last phase the rank that wrote last hands the total to
// every other rank that writes the node (they read it in the passes after the scatter). With one
// column of ranks this is the exchange of the strips' ranks in Distribution.hpp.
#pragma once
#include <algorithm>
#include <array>
#include <map>
#include <vector>

#include "Errors.hpp"

namespace emp {

/// The ranks' blocks of tiles: rank r = row * cols() + col owns the strips [strips[row],
/// strips[row + 1]) and the columns [columns[col], columns[col + 1]) (the last entries are the
/// numbers of strips and columns).
struct Blocks {
    std::vector<int> strips{0, 1}, columns{0, 1};
    int rows() const { return static_cast<int>(strips.size()) - 1; }
    int cols() const { return static_cast<int>(columns.size()) - 1; }
    int size() const { return rows() * cols(); }
    static int rangeOf(const std::vector<int>& first, int i)
    {
        return static_cast<int>(std::upper_bound(first.begin(), first.end() - 1, i) - first.begin()) - 1;
    }
    /// The rank of the tile (strip s, column c).
    int rankOf(int s, int c) const { return rangeOf(strips, s) * cols() + rangeOf(columns, c); }
};

/// The tiles along one axis (strips or columns of `width` cells, `count` of them; width 0: one)
/// whose points can write node i of `nodes`, for a kernel of support S: their bases lie in
/// [i - (S - 1), i] on the grid. Returns the first and the last.
inline std::array<int, 2> tilesWriting(int i, int width, int nodes, int count, int S)
{
    const int lo = std::max(0, i - (S - 1)), hi = std::min(i, nodes - S);
    return width > 0 ? std::array<int, 2>{lo / width, std::min(hi / width, count - 1)} : std::array<int, 2>{0, 0};
}

template <int D> class ScatterChain {
public:
    /// Nodes handed to or taken from one rank, in increasing index.
    struct Pass {
        int rank;
        std::vector<int> nodes;
    };

    /// For a grid of n nodes per direction and a kernel of support S, tiles of the Scheduler's
    /// stripWidth and columnCells (0: no columns), dealt out in the blocks b; this rank's
    /// passes. Throws ParameterError for blocks that do not cover the tiles.
    ScatterChain(const std::array<int, D>& n, int S, int stripWidth, int columnCells, const Blocks& b, int rank)
    {
        constexpr int last = D - 1;
        const int numStrips = (n[last] - S) / stripWidth + 1;
        const int numColumns = columnCells > 0 ? (n[0] - S) / columnCells + 1 : 1;
        require(b.strips.front() == 0 && b.strips.back() == numStrips && std::is_sorted(b.strips.begin(), b.strips.end()),
                "strip ranges", b.strips.size(), "ranges that cover the " + std::to_string(numStrips) + " strips");
        require(b.columns.front() == 0 && b.columns.back() == numColumns &&
                    std::is_sorted(b.columns.begin(), b.columns.end()),
                "column ranges", b.columns.size(), "ranges that cover the " + std::to_string(numColumns) + " columns");
        require(rank >= 0 && rank < b.size(), "rank", rank, "0 to " + std::to_string(b.size() - 1));
        phases_ = numColumns > 1 ? 4 : 2;
        send_.assign(phases_, {});
        recv_.assign(phases_, {});
        const int row = rank / b.cols(), col = rank % b.cols();
        const auto tilesOf = [&](int i, int width, int nodes, int count) { return tilesWriting(i, width, nodes, count, S); };
        // This rank's nodes along the two split axes: those its tiles can write.
        const int w0 = columnCells > 0 ? columnCells : n[0];
        const int lo0 = b.columns[col] * w0, hi0 = std::min(n[0] - 1, b.columns[col + 1] * w0 - 1 + S - 1);
        const int loL = b.strips[row] * stripWidth, hiL = std::min(n[last] - 1, b.strips[row + 1] * stripWidth - 1 + S - 1);
        // Along the first axis, the nodes whose columns belong to other ranks' columns too.
        std::vector<int> edge0;
        for (int i = lo0; i <= hi0; ++i) {
            const auto c = tilesOf(i, columnCells, n[0], numColumns);
            if (Blocks::rangeOf(b.columns, c[0]) != col || Blocks::rangeOf(b.columns, c[1]) != col) edge0.push_back(i);
        }
        std::vector<int> all0(hi0 - lo0 + 1);
        for (int i = lo0; i <= hi0; ++i) all0[i - lo0] = i;
        const int middle = D == 3 ? n[1] : 1, stride1 = n[0], strideL = D == 3 ? n[0] * n[1] : n[0];
        std::vector<std::map<int, std::vector<int>>> send(phases_), recv(phases_);
        struct Writer {
            int colour, rank;
        };
        std::vector<Writer> writers;
        for (int iL = loL; iL <= hiL; ++iL) {
            const auto s = tilesOf(iL, stripWidth, n[last], numStrips);
            const bool edgeL = Blocks::rangeOf(b.strips, s[0]) != row || Blocks::rangeOf(b.strips, s[1]) != row;
            for (int i0 : edgeL ? all0 : edge0) {
                const auto c = tilesOf(i0, columnCells, n[0], numColumns);
                writers.clear();
                for (int si = s[0]; si <= s[1]; ++si)
                    for (int ci = c[0]; ci <= c[1]; ++ci)
                        writers.push_back({numColumns > 1 ? 2 * (si & 1) + (ci & 1) : si & 1, b.rankOf(si, ci)});
                std::sort(writers.begin(), writers.end(), [](const Writer& a, const Writer& z) { return a.colour < z.colour; });
                const auto add = [&](std::vector<std::map<int, std::vector<int>>>& to, int k, int other) {
                    for (int j = 0; j < middle; ++j) to[k][other].push_back(iL * strideL + j * stride1 + i0);
                };
                // Between the phases: the last writer so far hands on to the next one.
                for (std::size_t w = 0; w + 1 < writers.size(); ++w) {
                    const int from = writers[w].rank, to = writers[w + 1].rank, k = writers[w].colour;
                    if (from == to) continue;
                    if (from == rank) add(send, k, to);
                    if (to == rank) add(recv, k, from);
                }
                // After the last phase: the totals from the last writer to every other one.
                const int lastWriter = writers.back().rank;
                for (std::size_t w = 0; w < writers.size(); ++w) {
                    const int other = writers[w].rank;
                    bool seen = other == lastWriter;
                    for (std::size_t v = 0; v < w; ++v) seen = seen || writers[v].rank == other;
                    if (seen) continue;
                    if (lastWriter == rank) add(send, phases_ - 1, other);
                    if (other == rank) add(recv, phases_ - 1, lastWriter);
                }
            }
        }
        for (int k = 0; k < phases_; ++k) {
            for (auto& [r, nodes] : send[k]) {
                std::sort(nodes.begin(), nodes.end());
                send_[k].push_back({r, std::move(nodes)});
            }
            for (auto& [r, nodes] : recv[k]) {
                std::sort(nodes.begin(), nodes.end());
                recv_[k].push_back({r, std::move(nodes)});
            }
        }
    }

    /// The phases of the scatter: 2 without columns, 4 with (Scheduler::numPhases).
    int numPhases() const { return phases_; }
    /// What this rank hands on after phase k, by rank in increasing order: partial sums to the
    /// rank that writes the nodes next (k < numPhases() - 1), the totals to every other rank
    /// that writes them (k = numPhases() - 1).
    const std::vector<Pass>& sends(int k) const { return send_[k]; }
    /// What this rank takes after phase k: its values of these nodes are replaced by the sender's.
    const std::vector<Pass>& receives(int k) const { return recv_[k]; }

private:
    int phases_ = 2;
    std::vector<std::vector<Pass>> send_, recv_;
};

}  // namespace emp
