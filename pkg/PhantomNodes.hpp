// Pre-existing cracks by phantom nodes (paper Section 3.3.1). The nodes of the cells a crack
// cuts (and, for uGIMP, of their neighbours, reached by the wider support) are "marked" and get a
// phantom twin at the same coordinates. A point maps to the twin of a marked node when the
// straight segment from the point to the node crosses the crack, to the node itself otherwise.
// Nodes beyond the crack tip are reached without crossing, so they stay shared. This gives the
// two faces independent velocity fields in a single-field solver.
//
// Cracks are polylines in 2D and planar polygons in 3D, in scene coordinates. Their vertices move
// with the material (the mass-weighted velocity of a node and its twins), so a cracked body can
// translate and rotate far; the marked nodes are recomputed every step, at a cost proportional
// to the marked region.
//
// Determinism: a point exactly on the crack counts as being on its positive side (the side its
// normal points to: left of the segment direction in 2D, the side of the Newell normal in 3D);
// a segment through an interior polyline vertex counts one crossing (parameters in [0, 1) along
// each crack segment), and a segment through either end of the crack (a tip) counts none.
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include "ElasticMaterial.hpp"
#include "Grid.hpp"
#include "Inline.hpp"
#include "ZeroPages.hpp"

namespace emp {

namespace phantom {

inline double orient(const Vec<2>& a, const Vec<2>& b, const Vec<2>& p)
{
    return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
}

/// Segment p-q against crack segment a-b: p and q on different sides of the line a-b (a point on
/// the line counts as the positive side) and the crossing at a parameter t in [0, 1) along a-b,
/// or in (0, 1) when a is the crack's first vertex (a tip, like the last one).
inline bool crossesSegment(const Vec<2>& p, const Vec<2>& q, const Vec<2>& a, const Vec<2>& b, bool aIsTip)
{
    if ((orient(a, b, p) >= 0) == (orient(a, b, q) >= 0)) return false;
    const double oa = orient(p, q, a), ob = orient(p, q, b);
    if (oa == ob) return false;
    const double t = oa / (oa - ob);
    return (aIsTip ? t > 0 : t >= 0) && t < 1;
}

}  // namespace phantom

template <int D> class PhantomNodes {
public:
    /// Adds a crack; returns its id. 2D: a polyline of >= 2 distinct vertices. 3D: a planar
    /// polygon of >= 3 vertices (non-planarity above 1e-6 of its size is refused).
    int addCrack(const std::vector<Vec<D>>& vertices);
    /// Appends a crack exactly as saved (Solver::loadState): its vertices moved with the
    /// material since addCrack checked them, so they are not checked again.
    int restoreCrack(const std::vector<Vec<D>>& vertices)
    {
        cracks_.push_back(vertices);
        planesStale_ = true;
        return static_cast<int>(cracks_.size()) - 1;
    }
    bool empty() const { return cracks_.empty(); }
    std::size_t numCracks() const { return cracks_.size(); }
    const std::vector<Vec<D>>& vertices(int c) const { return cracks_[c]; }
    /// Crack c's vertices, to move them (CrackTransport): the 3D planes kept for crosses() are
    /// stale until the next update().
    std::vector<Vec<D>>& vertices(int c)
    {
        planesStale_ = true;
        return cracks_[c];
    }

    /// Marks the cells cut by the cracks, dilated by `rings` cells, and numbers the twins from
    /// g.numNodes() on. Returns the number of twins.
    int update(const Grid<D>& g, int rings);

    /// Separate bodies in one grid (points carry a body id; Solver::setPointBodies), in place of
    /// cracks: a regular node that points of two or more bodies reach (reach[I] has a bit per
    /// body) is marked; its own field is the lowest of those bodies' and each other body gets a
    /// twin there (numbered from g.numNodes() on, node by node). Layer b of the twin table is
    /// body b. Returns the number of twins. Not together with cracks (the Solver refuses it).
    int updateBodies(const Grid<D>& g, const std::vector<std::uint64_t>& reach, int numBodies);
    /// The node a point of `body` uses in place of the regular node I: its twin there, or I.
    int mapBody(int body, int I) const
    {
        if (mark_.empty() || !mark_[I]) return I;
        const int t = twin_[static_cast<std::size_t>(body) * numNodes_ + I] - 1;
        return t >= 0 ? t : I;
    }

    bool marked(int node) const { return mark_[node] != 0; }
    const std::vector<int>& markedNodes() const { return marked_; }
    /// The node a point at x uses in place of the marked node I at xI: a twin or I itself.
    /// (Inline, with the 2D test: P2G calls it for every marked node of the points near a crack.)
    int map(const Vec<D>& x, int I, const Vec<D>& xI) const
    {
        for (std::size_t c = 0; c < cracks_.size(); ++c) {
            const int t = twin_[c * numNodes_ + I] - 1;
            if (t >= 0 && crosses(static_cast<int>(c), x, xI)) return t;
        }
        return I;
    }
    /// 2D, a whole support at once: the S x S nodes at (xs[i], ys[j]) (node k = i + S j), which
    /// hold the point p; bit k of `marked` set for the marked ones. Replaces each marked node[k]
    /// by map(p, node[k], its position), the same decisions: crossesSegment's expressions,
    /// whose products each depend on the node's column or its row only, formed once per
    /// segment and support instead of once per node (bitwise the same values), and the twins
    /// looked up only for the nodes a crack's segments cross an odd number of times. Returns
    /// whether any node changed.
    template <int S> bool mapSupport(const Vec<2>& p, const double* xs, const double* ys, unsigned marked, int* node) const
    {
        static_assert(D == 2 && S * S <= 32, "2D supports");
        unsigned open = marked;  // marked nodes no earlier crack has mapped
        for (std::size_t c = 0; c < cracks_.size() && open; ++c) {
            const auto& v = cracks_[c];
            unsigned odd = 0;
            for (std::size_t s = 0; s + 1 < v.size(); ++s) {
                const Vec<2>& a = v[s];
                const Vec<2>& b = v[s + 1];
                const bool aIsTip = s == 0;
                // orient(a, b, q) = rs[j] - cs[i]; orient(p, q, a) = ca[i] - ra[j]; orient(p, q, b) = cb[i] - rb[j].
                const bool sp = phantom::orient(a, b, p) >= 0;
                double rs[S], cs[S], ca[S], ra[S], cb[S], rb[S];
                for (int m = 0; m < S; ++m) {
                    rs[m] = (b[0] - a[0]) * (ys[m] - a[1]);
                    cs[m] = (b[1] - a[1]) * (xs[m] - a[0]);
                    ca[m] = (xs[m] - p[0]) * (a[1] - p[1]);
                    ra[m] = (ys[m] - p[1]) * (a[0] - p[0]);
                    cb[m] = (xs[m] - p[0]) * (b[1] - p[1]);
                    rb[m] = (ys[m] - p[1]) * (b[0] - p[0]);
                }
                for (int j = 0; j < S; ++j)
                    for (int i = 0; i < S; ++i) {
                        const int k = i + S * j;
                        if (!((open >> k) & 1u) || sp == (rs[j] - cs[i] >= 0)) continue;
                        const double oa = ca[i] - ra[j], ob = cb[i] - rb[j];
                        if (oa == ob) continue;
                        const double t = oa / (oa - ob);
                        if ((aIsTip ? t > 0 : t >= 0) && t < 1) odd ^= 1u << k;
                    }
            }
            for (int k = 0; odd; ++k, odd >>= 1)
                if (odd & 1u) {
                    const int t = twin_[c * numNodes_ + node[k]] - 1;
                    if (t >= 0) {
                        node[k] = t;
                        open &= ~(1u << k);
                    }
                }
        }
        return open != marked;
    }
    /// Calls f(twin) for every twin of node I.
    template <class F> void forEachTwin(int I, F&& f) const
    {
        if (!mark_.empty() && mark_[I])
            for (int c = 0; c < layers_; ++c) {
                const int t = twin_[static_cast<std::size_t>(c) * numNodes_ + I] - 1;
                if (t >= 0) f(t);
            }
    }
    int numTwins() const { return numTwins_; }
    /// The twin that crack c gives node I, or -1.
    int twin(int c, int I) const { return mark_.empty() ? -1 : twin_[c * static_cast<std::size_t>(numNodes_) + I] - 1; }

    /// The point of crack c nearest to x and the crack's unit normal there (2D: left of the
    /// nearest segment's direction; 3D: the polygon's Newell normal): the positive side.
    void nearest(int c, const Vec<D>& x, Vec<D>& point, Vec<D>& normal) const;

    /// 2D: whether no segment between two points of the box [lo, hi] can cross a crack, by a
    /// margin far above round-off: each crack segment's bounding box lies apart from the box
    /// widened by `margin`, or that widened box lies on one side of the segment's line (its
    /// corners farther than margin times the segment's length). Conservative: false when unsure.
    bool clearOf(const Vec<D>& lo, const Vec<D>& hi, double margin) const
    {
        if constexpr (D != 2) {
            return false;
        } else {
            const double x0 = lo[0] - margin, x1 = hi[0] + margin, y0 = lo[1] - margin, y1 = hi[1] + margin;
            // One segment: whether it lets the box pass (its box apart, or the box on one side).
            const auto passes = [&](const Segment& e) EMP_LAMBDA_INLINE {
                if (e.xMax < x0 || e.xMin > x1 || e.yMax < y0 || e.yMin > y1) return true;
                const double tol = margin * e.length;
                const double o0 = phantom::orient(e.a, e.b, Vec<2>(x0, y0)), o1 = phantom::orient(e.a, e.b, Vec<2>(x1, y0));
                const double o2 = phantom::orient(e.a, e.b, Vec<2>(x0, y1)), o3 = phantom::orient(e.a, e.b, Vec<2>(x1, y1));
                return (o0 > tol && o1 > tol && o2 > tol && o3 > tol) || (o0 < -tol && o1 < -tol && o2 < -tol && o3 < -tol);
            };
            if (!planesStale_) {  // (update()'s records: the same numbers, formed once a step)
                for (const Segment& e : segments_)
                    if (!passes(e)) return false;
                return true;
            }
            for (const auto& v : cracks_)
                for (std::size_t i = 0; i + 1 < v.size(); ++i)
                    if (!passes(segmentOf(v[i], v[i + 1]))) return false;
            return true;
        }
    }

    /// Whether the segment p-q crosses crack c (the rule above).
    bool crosses(int c, const Vec<D>& p, const Vec<D>& q) const
    {
        if constexpr (D == 2) {
            const auto& v = cracks_[c];
            bool odd = false;
            for (std::size_t i = 0; i + 1 < v.size(); ++i)
                if (phantom::crossesSegment(p, q, v[i], v[i + 1], i == 0)) odd = !odd;
            return odd;
        } else {
            return crossesPolygon(c, p, q);
        }
    }

private:
    bool crossesPolygon(int c, const Vec<D>& p, const Vec<D>& q) const;  ///< crosses() in 3D
    void markCells(int c, const Grid<D>& g, std::vector<long>& cells) const;

    std::vector<std::vector<Vec<D>>> cracks_;
    /// 3D: each crack's plane as crossesPolygon uses it (Newell normal, offset, dominant axis),
    /// formed by update() for the step's P2G; while stale, crossesPolygon forms it per call.
    struct Plane {
        Vec<3> normal;
        double offset;
        int axis;
    };
    std::vector<Plane> planes_;
    /// 2D: every crack segment as clearOf uses it (its ends, box and length), formed by update()
    /// for the step's P2G; while stale, clearOf forms them per call.
    struct Segment {
        Vec<2> a, b;
        double xMin, xMax, yMin, yMax, length;
    };
    static Segment segmentOf(const Vec<D>& a, const Vec<D>& b)
    {
        const Vec<2> a2 = a.template head<2>(), b2 = b.template head<2>();
        return {a2, b2, std::min(a2[0], b2[0]), std::max(a2[0], b2[0]), std::min(a2[1], b2[1]), std::max(a2[1], b2[1]),
                (b2 - a2).norm()};
    }
    std::vector<Segment> segments_;
    bool planesStale_ = true;  ///< planes_ (3D) or segments_ (2D) not those of the vertices
    // Per regular node, zeros until written (ZeroPages): a rank of a distributed run writes
    // only near the cracks, and only those pages take memory.
    std::vector<char, ZeroPages<char>> mark_;
    std::vector<int> marked_;                  ///< marked regular nodes, ascending
    std::vector<int, ZeroPages<int>> twin_;    ///< twin_[c * numNodes + I]: 1 + the twin crack c gives I, or 0
    int numNodes_ = 0, numTwins_ = 0;
    int layers_ = 0;  ///< layers of twin_: the cracks, or the bodies (updateBodies)
    void reset(int numNodes, int layers);
};

}  // namespace emp
