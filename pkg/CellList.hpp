// Cell-linked list for fixed-radius neighbour search (paper Section 4.2, after Allen and
// Tildesley). Cells of size >= the search radius cover a box; a query visits the 3^D cells
// around a point. The list is stored as a counting sort of the ids by cell (cell start offsets
// and ids in cell order), the array form of the paper's head-of-chain and linked-list arrays;
// ids within a cell keep their input order, so every query visits neighbours in a fixed order.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "ElasticMaterial.hpp"

namespace emp {

template <int D> class CellList {
public:
    /// Bins the points `ids` (positions x[id]; x any array of Vec<D>) in cells of size `cell`
    /// covering [lo, hi].
    template <class X> void build(const X& x, const std::vector<int>& ids, double cell, const Vec<D>& lo, const Vec<D>& hi)
    {
        cell_ = cell;
        lo_ = lo;
        long total = 1;
        for (int d = 0; d < D; ++d) {
            n_[d] = std::max(1, static_cast<int>(std::floor((hi[d] - lo[d]) / cell)) + 1);
            total *= n_[d];
        }
        start_.assign(total + 1, 0);
        cellOf_.resize(ids.size());
        for (std::size_t k = 0; k < ids.size(); ++k) {
            cellOf_[k] = cellIndex(x[ids[k]]);
            ++start_[cellOf_[k] + 1];
        }
        for (long c = 0; c < total; ++c) start_[c + 1] += start_[c];
        sorted_.resize(ids.size());
        std::vector<int> fill(start_.begin(), start_.end() - 1);
        for (std::size_t k = 0; k < ids.size(); ++k) sorted_[fill[cellOf_[k]]++] = ids[k];
    }

    /// Calls f(q) for every binned q with |x_q - p| <= r (r <= cell size), cells in index order.
    template <class X, class F> void forEachWithin(const X& x, const Vec<D>& p, double r, F&& f) const
    {
        std::array<int, D> c;
        for (int d = 0; d < D; ++d) c[d] = coord(p[d], d);
        const double r2 = r * r;
        if constexpr (D == 2) {
            for (int j = std::max(c[1] - 1, 0); j <= std::min(c[1] + 1, n_[1] - 1); ++j)
                for (int i = std::max(c[0] - 1, 0); i <= std::min(c[0] + 1, n_[0] - 1); ++i)
                    visit(x, p, r2, i + n_[0] * j, f);
        } else {
            for (int k = std::max(c[2] - 1, 0); k <= std::min(c[2] + 1, n_[2] - 1); ++k)
                for (int j = std::max(c[1] - 1, 0); j <= std::min(c[1] + 1, n_[1] - 1); ++j)
                    for (int i = std::max(c[0] - 1, 0); i <= std::min(c[0] + 1, n_[0] - 1); ++i)
                        visit(x, p, r2, i + n_[0] * (j + n_[1] * k), f);
        }
    }

private:
    int coord(double v, int d) const
    {
        return std::clamp(static_cast<int>(std::floor((v - lo_[d]) / cell_)), 0, n_[d] - 1);
    }
    long cellIndex(const Vec<D>& p) const
    {
        long c = 0, stride = 1;
        for (int d = 0; d < D; ++d) {
            c += coord(p[d], d) * stride;
            stride *= n_[d];
        }
        return c;
    }
    template <class X, class F> void visit(const X& x, const Vec<D>& p, double r2, long c, F& f) const
    {
        for (int k = start_[c]; k < start_[c + 1]; ++k) {
            const int q = sorted_[k];
            if ((x[q] - p).squaredNorm() <= r2) f(q);
        }
    }

    double cell_ = 1;
    Vec<D> lo_;
    std::array<int, D> n_{};
    std::vector<int> start_, sorted_;
    std::vector<long> cellOf_;
};

}  // namespace emp
