#include "CrackFront.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

namespace emp::crackfront {

namespace {

using Cell = std::array<long, 3>;

struct CellHash {
    std::size_t operator()(const Cell& c) const
    {
        std::uint64_t h = 1469598103934665603ull;
        for (long v : c) h = (h ^ static_cast<std::uint64_t>(v)) * 1099511628211ull;
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};

/// The occupied cells of a set of points, numbered in order of first occupation, and the points
/// of each (a counting sort: the points of cell c are ids[start[c] .. start[c + 1]), in row order).
class SparseCells {
public:
    SparseCells(const double* x, long n, double size) : size_(size), cellOf_(n)
    {
        index_.reserve(static_cast<std::size_t>(n));
        for (long i = 0; i < n; ++i) {
            const auto [it, added] = index_.emplace(cellAt(x + 3 * i), static_cast<int>(cells_.size()));
            if (added) cells_.push_back(it->first);
            cellOf_[i] = it->second;
        }
        start_.assign(cells_.size() + 1, 0);
        for (long i = 0; i < n; ++i) ++start_[cellOf_[i] + 1];
        for (std::size_t c = 0; c < cells_.size(); ++c) start_[c + 1] += start_[c];
        ids_.resize(n);
        std::vector<long> fill(start_.begin(), start_.end() - 1);
        for (long i = 0; i < n; ++i) ids_[fill[cellOf_[i]]++] = i;
    }
    Cell cellAt(const double* p) const
    {
        return {static_cast<long>(std::floor(p[0] / size_)), static_cast<long>(std::floor(p[1] / size_)),
                static_cast<long>(std::floor(p[2] / size_))};
    }
    /// The number of cell c (an offset from a cell), or -1 if no point occupies it.
    int find(const Cell& c) const
    {
        const auto it = index_.find(c);
        return it == index_.end() ? -1 : it->second;
    }
    /// f(other cell's number) for each occupied cell around `c` (3^3 of them, `c` included).
    template <class F> void forEachAround(const Cell& c, F&& f) const
    {
        for (long k = -1; k <= 1; ++k)
            for (long j = -1; j <= 1; ++j)
                for (long i = -1; i <= 1; ++i) {
                    const int o = find({c[0] + i, c[1] + j, c[2] + k});
                    if (o >= 0) f(o);
                }
    }
    int cells() const { return static_cast<int>(cells_.size()); }
    const Cell& cell(int c) const { return cells_[c]; }
    int cellOf(long i) const { return cellOf_[i]; }
    long begin(int c) const { return start_[c]; }
    long end(int c) const { return start_[c + 1]; }
    long id(long k) const { return ids_[k]; }

private:
    double size_;
    std::unordered_map<Cell, int, CellHash> index_;
    std::vector<Cell> cells_;
    std::vector<int> cellOf_;
    std::vector<long> start_, ids_;
};

/// |a - b|^2 summed over the axes in order, as numpy's np.sum((a - b) ** 2, axis=1).
double squaredDistance(const double* a, const double* b)
{
    const double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return (d0 * d0 + d1 * d1) + d2 * d2;
}

}  // namespace

std::vector<char> mainCrack(const double* x, long n, const double* origin, double R)
{
    std::vector<char> main(n, 0);
    if (n == 0) return main;
    long start = 0;
    double nearest = std::numeric_limits<double>::infinity();
    for (long i = 0; i < n; ++i) {
        const double d = squaredDistance(x + 3 * i, origin);
        if (d < nearest) {
            nearest = d;
            start = i;
        }
    }
    const SparseCells cells(x, n, R);
    std::vector<char> reached(cells.cells(), 0);
    std::vector<int> stack{cells.cellOf(start)};
    reached[stack.back()] = 1;
    while (!stack.empty()) {
        const int c = stack.back();
        stack.pop_back();
        cells.forEachAround(cells.cell(c), [&](int o) {
            if (!reached[o]) {
                reached[o] = 1;
                stack.push_back(o);
            }
        });
    }
    for (long i = 0; i < n; ++i) main[i] = reached[cells.cellOf(i)];
    return main;
}

std::vector<char> fartherWithin(const double* xm, const double* r, long nm, const double* xr, const double* rr,
                                long nr, double R, double R2)
{
    std::vector<char> farther(nr, 0);
    if (nm == 0 || nr == 0) return farther;
    // Cells a hair wider than R: two points within R of each other then lie in neighbouring cells
    // whatever the rounding of x / size.
    const SparseCells cells(xm, nm, R * (1.0 + 1e-6));
    for (long i = 0; i < nr; ++i) {
        const double* p = xr + 3 * i;
        bool found = false;
        cells.forEachAround(cells.cellAt(p), [&](int c) {
            for (long k = cells.begin(c); !found && k < cells.end(c); ++k) {
                const long j = cells.id(k);
                found = r[j] > rr[i] && squaredDistance(xm + 3 * j, p) <= R2;
            }
        });
        farther[i] = found;
    }
    return farther;
}

}  // namespace emp::crackfront
