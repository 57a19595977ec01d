#include "PhantomNodes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "Errors.hpp"

namespace emp {

namespace {

/// Newell normal (not normalised) and the polygon's size.
Vec<3> newellNormal(const std::vector<Vec<3>>& v)
{
    Vec<3> n = Vec<3>::Zero();
    for (std::size_t i = 0; i < v.size(); ++i) {
        const Vec<3>& a = v[i];
        const Vec<3>& b = v[(i + 1) % v.size()];
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    return n;
}

int dominantAxis(const Vec<3>& n)
{
    int a = 0;
    for (int d = 1; d < 3; ++d)
        if (std::fabs(n[d]) > std::fabs(n[a])) a = d;
    return a;
}

/// The plane of a 3D crack polygon as crossesPolygon uses it.
template <class Plane> Plane planeOf(const std::vector<Vec<3>>& v)
{
    const Vec<3> n = newellNormal(v);
    return Plane{n, n.dot(v[0]), dominantAxis(n)};
}

/// Crossing-number point-in-polygon test in the plane of axes (b, c), half-open edges.
bool insidePolygon(const std::vector<Vec<3>>& v, int b, int c, double pb, double pc)
{
    bool in = false;
    for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
        const double yi = v[i][c], yj = v[j][c];
        if ((yi > pc) != (yj > pc)) {
            const double x = v[i][b] + (pc - yi) * (v[j][b] - v[i][b]) / (yj - yi);
            if (pb < x) in = !in;
        }
    }
    return in;
}

double distanceToEdges(const std::vector<Vec<3>>& v, int b, int c, double pb, double pc)
{
    double best = 1e300;
    for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
        const double ab = v[i][b] - v[j][b], ac = v[i][c] - v[j][c];
        const double len2 = ab * ab + ac * ac;
        double t = len2 > 0 ? ((pb - v[j][b]) * ab + (pc - v[j][c]) * ac) / len2 : 0.0;
        t = std::clamp(t, 0.0, 1.0);
        const double db = v[j][b] + t * ab - pb, dc = v[j][c] + t * ac - pc;
        best = std::min(best, std::sqrt(db * db + dc * dc));
    }
    return best;
}

}  // namespace

template <int D> int PhantomNodes<D>::addCrack(const std::vector<Vec<D>>& v)
{
    const std::string what = "crack " + std::to_string(cracks_.size());
    for (const auto& p : v) require(p.allFinite(), what + " vertex", "non-finite", "finite coordinates");
    if constexpr (D == 2) {
        require(v.size() >= 2, what + " vertex count", v.size(), ">= 2 (a segment or a polyline)");
        for (std::size_t i = 1; i < v.size(); ++i)
            require((v[i] - v[i - 1]).norm() > 0, what + " segment " + std::to_string(i - 1) + " length", 0,
                    "> 0 (consecutive vertices must differ)");
    } else {
        require(v.size() >= 3, what + " vertex count", v.size(), ">= 3 (a planar polygon)");
        const Vec<3> n = newellNormal(v);
        double size = 0;
        for (const auto& p : v) size = std::max(size, (p - v[0]).norm());
        require(n.norm() > 1e-12 * size * size, what + " area", n.norm() / 2, "> 0 (a non-degenerate polygon)");
        const Vec<3> u = n.normalized();
        double off = 0;
        for (const auto& p : v) off = std::max(off, std::fabs(u.dot(p - v[0])));
        require(off <= 1e-6 * size, what + " distance of a vertex from the polygon's plane (m)", off,
                "<= 1e-6 of the polygon size (the polygon must be planar)");
    }
    cracks_.push_back(v);
    planesStale_ = true;
    return static_cast<int>(cracks_.size()) - 1;
}

template <int D> bool PhantomNodes<D>::crossesPolygon(int c, const Vec<D>& p, const Vec<D>& q) const
{
    if constexpr (D == 3) {
        const auto& v = cracks_[c];
        // (P2G calls this for every marked node of every point near the crack: the plane kept
        // since update(), the same numbers as formed here.)
        const Plane plane = planesStale_ ? planeOf<Plane>(v) : planes_[c];
        const Vec<3>& n = plane.normal;
        const double off = plane.offset;
        const double sp = n.dot(p) - off, sq = n.dot(q) - off;
        if ((sp >= 0) == (sq >= 0)) return false;
        const Vec<3> x = p + (sp / (sp - sq)) * (q - p);
        const int a = plane.axis;
        return insidePolygon(v, (a + 1) % 3, (a + 2) % 3, x[(a + 1) % 3], x[(a + 2) % 3]);
    } else {
        return crosses(c, p, q);
    }
}

template <int D> void PhantomNodes<D>::markCells(int c, const Grid<D>& g, std::vector<long>& cells) const
{
    // Cells (as the index of their lowest node) that the crack passes through, in cell units.
    std::vector<Vec<D>> v;
    for (const auto& p : cracks_[c]) v.push_back((p - g.origin) * g.invh);
    // First and last cell index along axis d for cell coordinates u, clipped to the grid's cells.
    auto lowCell = [&](double u, int d) { return static_cast<long>(std::clamp(std::floor(u), 0.0, double(g.n[d] - 1))); };
    auto highCell = [&](double u, int d) { return static_cast<long>(std::clamp(std::floor(u), -1.0, double(g.n[d] - 2))); };
    auto add = [&](const std::array<long, D>& cell) {
        long idx = 0;
        for (int d = 0; d < D; ++d) {
            if (cell[d] < 0 || cell[d] > g.n[d] - 2) return;
            idx += cell[d] * g.stride[d];
        }
        cells.push_back(idx);
    };
    if constexpr (D == 2) {
        for (std::size_t s = 0; s + 1 < v.size(); ++s) {
            const Vec<2>& a = v[s];
            const Vec<2>& b = v[s + 1];
            const double u0 = std::min(a[0], b[0]), u1 = std::max(a[0], b[0]);
            // Loops clipped to the grid's cells: a vertex may lie far outside it.
            for (long i = lowCell(u0, 0), iEnd = highCell(u1, 0); i <= iEnd; ++i) {
                double y0, y1;
                if (b[0] == a[0]) {
                    y0 = std::min(a[1], b[1]);
                    y1 = std::max(a[1], b[1]);
                } else {
                    const double xl = std::max(u0, double(i)), xr = std::min(u1, double(i + 1));
                    const double ya = a[1] + (xl - a[0]) * (b[1] - a[1]) / (b[0] - a[0]);
                    const double yb = a[1] + (xr - a[0]) * (b[1] - a[1]) / (b[0] - a[0]);
                    y0 = std::min(ya, yb);
                    y1 = std::max(ya, yb);
                }
                for (long j = lowCell(y0, 1), jEnd = highCell(y1, 1); j <= jEnd; ++j) add({i, j});
            }
        }
    } else {
        const Vec<3> n = newellNormal(v);
        const double off = n.dot(v[0]);
        const int a = dominantAxis(n), b = (a + 1) % 3, cc = (a + 2) % 3;
        double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
        for (const auto& p : v)
            for (int d = 0; d < 3; ++d) {
                lo[d] = std::min(lo[d], p[d]);
                hi[d] = std::max(hi[d], p[d]);
            }
        const double half = std::sqrt(0.5);
        for (long ib = lowCell(lo[b], b), ibEnd = highCell(hi[b], b); ib <= ibEnd; ++ib)
            for (long ic = lowCell(lo[cc], cc), icEnd = highCell(hi[cc], cc); ic <= icEnd; ++ic) {
                const double mb = ib + 0.5, mc = ic + 0.5;
                if (!insidePolygon(v, b, cc, mb, mc) && distanceToEdges(v, b, cc, mb, mc) > half) continue;
                double amin = 1e300, amax = -1e300;
                for (int corner = 0; corner < 4; ++corner) {
                    const double pb = ib + (corner & 1), pc = ic + (corner >> 1);
                    const double pa = (off - n[b] * pb - n[cc] * pc) / n[a];
                    amin = std::min(amin, pa);
                    amax = std::max(amax, pa);
                }
                amin = std::max(amin, lo[a]);
                amax = std::min(amax, hi[a]);
                for (long ia = lowCell(amin, a), iaEnd = highCell(amax, a); ia <= iaEnd; ++ia) {
                    std::array<long, 3> cell;
                    cell[a] = ia;
                    cell[b] = ib;
                    cell[cc] = ic;
                    add(cell);
                }
            }
    }
}

template <int D> void PhantomNodes<D>::reset(int nn, int layers)
{
    // Unmarks last step's nodes (the cost follows the marked region), or resizes.
    if (numNodes_ != nn || mark_.size() != static_cast<std::size_t>(nn) ||
        twin_.size() != static_cast<std::size_t>(layers) * nn || layers_ != layers) {
        numNodes_ = nn;
        freshZeros(mark_, nn);
        freshZeros(twin_, static_cast<std::size_t>(layers) * nn);
        marked_.clear();
    }
    layers_ = layers;
    for (int I : marked_) {
        mark_[I] = 0;
        for (int c = 0; c < layers; ++c) twin_[static_cast<std::size_t>(c) * nn + I] = 0;
    }
    marked_.clear();
    numTwins_ = 0;
}

template <int D>
int PhantomNodes<D>::updateBodies(const Grid<D>& g, const std::vector<std::uint64_t>& reach, int numBodies)
{
    const int nn = g.numNodes();
    reset(nn, numBodies);
    for (int I = 0; I < nn; ++I) {
        std::uint64_t m = reach[I];
        if (!(m & (m - 1))) continue;  // no body or one
        mark_[I] = 1;
        marked_.push_back(I);
        m &= m - 1;  // the lowest body keeps the node
        for (int b = 0; m; ++b, m >>= 1)
            if (m & 1) twin_[static_cast<std::size_t>(b) * nn + I] = 1 + nn + numTwins_++;
    }
    return numTwins_;
}

template <int D> int PhantomNodes<D>::update(const Grid<D>& g, int rings)
{
    const int nn = g.numNodes();
    reset(nn, static_cast<int>(cracks_.size()));
    if constexpr (D == 3) {
        planes_.clear();
        for (const auto& v : cracks_) planes_.push_back(planeOf<Plane>(v));
    } else {
        segments_.clear();
        for (const auto& v : cracks_)
            for (std::size_t i = 0; i + 1 < v.size(); ++i) segments_.push_back(segmentOf(v[i], v[i + 1]));
    }
    planesStale_ = false;
    std::vector<long> cells, nodes;
    for (std::size_t c = 0; c < cracks_.size(); ++c) {
        cells.clear();
        markCells(static_cast<int>(c), g, cells);
        nodes.clear();
        // The corners of each cut cell and of the `rings` cells around it, each node once: the
        // crack's layer of the twin table (zero after reset) marks those listed, so that only
        // distinct nodes are sorted (a node is a corner of up to (2 + 2 rings)^D listed cells).
        int* listed = &twin_[c * nn];
        const auto list = [&](long I) {
            if (!listed[I]) {
                listed[I] = 1;
                nodes.push_back(I);
            }
        };
        for (long cell : cells) {
            std::array<long, D> ijk;
            long r = cell;
            for (int d = D - 1; d >= 0; --d) {
                ijk[d] = r / g.stride[d];
                r -= ijk[d] * g.stride[d];
            }
            std::array<long, D> lo, hi;
            for (int d = 0; d < D; ++d) {
                lo[d] = std::max(0L, ijk[d] - rings);
                hi[d] = std::min(static_cast<long>(g.n[d]) - 1, ijk[d] + 1 + rings);
            }
            if constexpr (D == 2) {
                for (long j = lo[1]; j <= hi[1]; ++j)
                    for (long i = lo[0]; i <= hi[0]; ++i) list(i + j * g.stride[1]);
            } else {
                for (long k = lo[2]; k <= hi[2]; ++k)
                    for (long j = lo[1]; j <= hi[1]; ++j)
                        for (long i = lo[0]; i <= hi[0]; ++i) list(i + j * g.stride[1] + k * g.stride[2]);
            }
        }
        std::sort(nodes.begin(), nodes.end());
        for (long I : nodes) {
            twin_[c * nn + I] = 1 + nn + numTwins_++;
            if (!mark_[I]) {
                mark_[I] = 1;
                marked_.push_back(static_cast<int>(I));
            }
        }
    }
    std::sort(marked_.begin(), marked_.end());
    return numTwins_;
}

template <int D> void PhantomNodes<D>::nearest(int c, const Vec<D>& x, Vec<D>& point, Vec<D>& normal) const
{
    const auto& v = cracks_[c];
    if constexpr (D == 2) {
        double best = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i + 1 < v.size(); ++i) {
            const Vec<2> d = v[i + 1] - v[i];
            const double len2 = d.squaredNorm();
            const double t = len2 > 0 ? std::clamp((x - v[i]).dot(d) / len2, 0.0, 1.0) : 0.0;
            const Vec<2> q = v[i] + t * d;
            const double dist = (x - q).squaredNorm();
            if (dist < best) {
                best = dist;
                point = q;
                normal = Vec<2>(-d[1], d[0]).normalized();
            }
        }
    } else {
        normal = newellNormal(v).normalized();
        point = x - (x - v[0]).dot(normal) * normal;  // in the polygon's plane
    }
}

template class PhantomNodes<2>;
template class PhantomNodes<3>;

}  // namespace emp
