#include "CrackFront.hpp"

#include <algorithm>
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
/// A cell is found through a dense table over the points' box of cells when that table is small
/// (the usual crack: a few cells of size R across), else through a hash map (a point far from
/// the others); the numbering is the same either way.
class SparseCells {
public:
    SparseCells(const double* x, long n, double size) : size_(size), cellOf_(n)
    {
        std::vector<Cell> at(n);
        for (long i = 0; i < n; ++i) at[i] = cellAt(x + 3 * i);
        lo_ = hi_ = n ? at[0] : Cell{0, 0, 0};
        for (const Cell& c : at)
            for (int d = 0; d < 3; ++d) lo_[d] = std::min(lo_[d], c[d]), hi_[d] = std::max(hi_[d], c[d]);
        // (extents in double: a far point must not overflow the product)
        const double cells = double(hi_[0] - lo_[0] + 1) * double(hi_[1] - lo_[1] + 1) * double(hi_[2] - lo_[2] + 1);
        dense_ = cells <= 8.0 * double(n) + 4096.0;
        if (dense_)
            table_.assign(static_cast<std::size_t>(cells), -1);
        else
            index_.reserve(static_cast<std::size_t>(n));
        for (long i = 0; i < n; ++i) {
            int& slot = dense_ ? table_[slotOf(at[i])] : index_.emplace(at[i], -1).first->second;
            if (slot < 0) {
                slot = static_cast<int>(cells_.size());
                cells_.push_back(at[i]);
            }
            cellOf_[i] = slot;
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
        if (dense_) {
            for (int d = 0; d < 3; ++d)
                if (c[d] < lo_[d] || c[d] > hi_[d]) return -1;
            return table_[slotOf(c)];
        }
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
    /// The dense table's entry of a cell inside the box lo_ .. hi_.
    std::size_t slotOf(const Cell& c) const
    {
        const std::size_t nx = hi_[0] - lo_[0] + 1, ny = hi_[1] - lo_[1] + 1;
        return (static_cast<std::size_t>(c[2] - lo_[2]) * ny + static_cast<std::size_t>(c[1] - lo_[1])) * nx
               + static_cast<std::size_t>(c[0] - lo_[0]);
    }
    double size_;
    bool dense_ = false;
    Cell lo_{}, hi_{};
    std::vector<int> table_;
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

std::vector<char> mainCrack(const double* x, long n, const double* origin, double R, std::vector<double>* squared)
{
    std::vector<char> main(n, 0);
    if (squared) squared->resize(n);
    if (n == 0) return main;
    long start = 0;
    double nearest = std::numeric_limits<double>::infinity();
    for (long i = 0; i < n; ++i) {
        const double d = squaredDistance(x + 3 * i, origin);
        if (squared) (*squared)[i] = d;
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
    // Only a point farther from the origin than the nearest of the xr can answer for any of
    // them: the others (most of a crack, behind its front) are left out of the cells.
    double nearest = std::numeric_limits<double>::infinity();
    for (long i = 0; i < nr; ++i) nearest = rr[i] < nearest ? rr[i] : nearest;
    std::vector<double> xs, rs;
    for (long j = 0; j < nm; ++j)
        if (r[j] > nearest) {
            xs.insert(xs.end(), xm + 3 * j, xm + 3 * j + 3);
            rs.push_back(r[j]);
        }
    const long ns = static_cast<long>(rs.size());
    if (ns == 0) return farther;
    // Cells a hair wider than R: two points within R of each other then lie in neighbouring cells
    // whatever the rounding of x / size.
    const SparseCells cells(xs.data(), ns, R * (1.0 + 1e-6));
    for (long i = 0; i < nr; ++i) {
        const double* p = xr + 3 * i;
        bool found = false;
        cells.forEachAround(cells.cellAt(p), [&](int c) {
            for (long k = cells.begin(c); !found && k < cells.end(c); ++k) {
                const long j = cells.id(k);
                found = rs[j] > rr[i] && squaredDistance(xs.data() + 3 * j, p) <= R2;
            }
        });
        farther[i] = found;
    }
    return farther;
}

bool mergedTips(const double* xr, const double* rr, const std::vector<char>& farther, long nr, double R2,
                std::vector<long>& tips)
{
    std::vector<long> order;
    for (long i = 0; i < nr; ++i)
        if (!farther[i]) {
            if (std::isnan(rr[i])) return false;
            order.push_back(i);
        }
    std::stable_sort(order.begin(), order.end(), [&](long a, long b) { return rr[a] > rr[b]; });
    const std::size_t first = tips.size();
    for (const long i : order) {
        bool far = true;
        for (std::size_t k = first; far && k < tips.size(); ++k)
            far = squaredDistance(xr + 3 * i, xr + 3 * tips[k]) > R2;
        if (far) tips.push_back(i);
    }
    return true;
}

}  // namespace emp::crackfront
