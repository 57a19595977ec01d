#include "BodyContact.hpp"

#include "Lanes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace emp {

namespace {

using V3 = Eigen::Vector3d;

/// Closest point to x on the triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5:
/// the Voronoi regions of the vertices, edges and face in turn).
V3 closestOnTriangle(const V3& x, const V3& a, const V3& b, const V3& c)
{
    const V3 ab = b - a, ac = c - a, ax = x - a;
    const double d1 = ab.dot(ax), d2 = ac.dot(ax);
    if (d1 <= 0 && d2 <= 0) return a;
    const V3 bx = x - b;
    const double d3 = ab.dot(bx), d4 = ac.dot(bx);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
    const V3 cx = x - c;
    const double d5 = ab.dot(cx), d6 = ac.dot(cx);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    const double denom = 1.0 / (va + vb + vc);
    return a + ab * (vb * denom) + ac * (vc * denom);
}

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

void RigidShape::closest(const V3& x, double& phi, V3& s, V3& n) const
{
    switch (kind) {
    case sphere: {
        const V3 d = x - a;
        const double r = d.norm();
        n = r > 0 ? V3(d / r) : V3(0, 1, 0);
        phi = r - radius;
        s = a + radius * n;
        return;
    }
    case wall: {
        const double t = (x - a).dot(b);
        if (twoSided && t < 0) {
            n = -b;
            phi = -t;
        } else {
            n = b;
            phi = t;
        }
        s = x - phi * n;
        return;
    }
    case facet: {
        s = closestOnTriangle(x, a, b, c);
        const V3 d = x - s;
        phi = d.norm();
        if (phi > 0) {
            n = d / phi;
        } else {  // on the facet: its normal, either way
            n = (b - a).cross(c - a).normalized();
        }
        return;
    }
    default: {  // box
        const V3 q = rotation.transpose() * (x - a);
        const V3 over = q.cwiseAbs() - b;
        if (over.maxCoeff() > 0) {
            const V3 clamped = q.cwiseMax(-b).cwiseMin(b);
            s = a + rotation * clamped;
            const V3 d = x - s;
            phi = d.norm();
            n = phi > 0 ? V3(d / phi) : V3(rotation.col(0));
        } else {  // inside: out through the nearest face
            int i = 0;
            over.maxCoeff(&i);
            const double side = q[i] >= 0 ? 1.0 : -1.0;
            V3 qs = q;
            qs[i] = side * b[i];
            s = a + rotation * qs;
            n = side * rotation.col(i);
            phi = over[i];
        }
        return;
    }
    }
}

void RigidShape::bounds(V3& lo, V3& hi) const
{
    switch (kind) {
    case sphere:
        lo = a.array() - radius;
        hi = a.array() + radius;
        return;
    case wall: {
        lo.setConstant(-kInf);
        hi.setConstant(kInf);
        int axis = -1;
        for (int d = 0; d < 3; ++d)
            if (std::fabs(b[d]) == 1.0) axis = d;
        if (axis < 0) return;  // an oblique plane: everywhere
        // The plane of a two-sided wall, or the body side of a one-sided one (the search widens
        // the bounds by a point's half-width, which finds the points in front of it).
        if (twoSided || b[axis] > 0) hi[axis] = a[axis];
        if (twoSided || b[axis] < 0) lo[axis] = a[axis];
        return;
    }
    case facet:
        lo = a.cwiseMin(b).cwiseMin(c);
        hi = a.cwiseMax(b).cwiseMax(c);
        return;
    default: {
        const V3 e = rotation.cwiseAbs() * b;
        lo = a - e;
        hi = a + e;
        return;
    }
    }
}

template <int D> bool BodyContact<D>::cellRange(const Grid<D>& g, const RigidShape& shape, double reach,
                                                 int lo[3], int hi[3]) const
{
    V3 a, b;
    shape.bounds(a, b);
    if (D == 2 && (a[2] - reach > 0 || b[2] + reach < 0)) return false;  // the section by z = 0
    for (int d = 0; d < 3; ++d) lo[d] = hi[d] = 0;
    for (int d = 0; d < D; ++d) {
        const int nc = std::max(g.n[d] - 1, 1);
        const double x = (a[d] - reach - g.origin[d]) * g.invh, y = (b[d] + reach - g.origin[d]) * g.invh;
        lo[d] = x <= 0 ? 0 : static_cast<int>(std::min(std::floor(x), double(nc)));
        hi[d] = y >= nc - 1 ? nc - 1 : static_cast<int>(std::max(std::floor(y), -1.0));
        if (lo[d] > hi[d]) return false;
    }
    return true;
}

template <int D> void BodyContact<D>::binPoints(const Grid<D>& g, const MaterialPoints<D>& P,
                                                 const PointSupport<D>* support)
{
    // The points in the cells of binLo_..binHi_ (the union of the shapes' ranges), by cell
    // (counting sort, in point order within a cell), so that each shape tests only the points
    // near it. The others are rejected by their coordinates first: with few bodies near a large
    // body of points, most points cost two comparisons.
    int width[3] = {1, 1, 1}, nc[3] = {1, 1, 1};
    double xlo[3], xhi[3];
    int cells = 1;
    for (int d = 0; d < D; ++d) {
        nc[d] = std::max(g.n[d] - 1, 1);
        width[d] = binHi_[d] - binLo_[d] + 1;
        cells *= width[d];
        // A point below the first cell (or above the last) is clamped into it: no bound there.
        xlo[d] = binLo_[d] == 0 ? -kInf : g.origin[d] + (binLo_[d] - 1) * g.h;
        xhi[d] = binHi_[d] == nc[d] - 1 ? kInf : g.origin[d] + (binHi_[d] + 2) * g.h;
    }
    cellStart_.assign(cells + 1, 0);
    const int np = static_cast<int>(P.size());
    // First the points inside the box (no branch per direction, so the loop stays tight), then
    // their cells, counted and placed in point order.
    // In the step the solver names the points of the box's rows (from its binning by strips, in
    // increasing id order, as the scan of every point finds them): the same candidates in the
    // same order, without a pass over every point.
    candidates_.clear();
    const auto inBox = [&](int p) {
        const auto& x = P.x[p];
        bool in = true;
        for (int d = 0; d < D; ++d) in &= (x[d] >= xlo[d]) & (x[d] <= xhi[d]);
        return in;
    };
    if (support) {
        support->pointsInRows(binLo_[D - 1], binHi_[D - 1], rowPoints_);
        for (const int p : rowPoints_)
            if (inBox(p)) candidates_.push_back(p);
    } else {
        // Every point: whether each lies in the box, a block of points at a time in one loop
        // without a branch that GCC vectorises (in the lanes' width, pkg/Lanes.hpp, into a local
        // array, which the positions cannot alias), then the few inside, eight flags at a time.
        // (Point by point with a branch, the scan of 1e5 points cost 24 instructions a point:
        // most of the stage's own cost before a step.)
        const double* x = P.x.data()->data();
        double lo[D], hi[D];
        for (int d = 0; d < D; ++d) lo[d] = xlo[d], hi[d] = xhi[d];
        withLaneIsa([&]() EMP_LAMBDA_INLINE {
            constexpr int B = 256;
            alignas(64) unsigned char flag[B + 8];
            double l[D], u[D];  // (locals of this copy: read through the closure, GCC would not vectorise)
            for (int d = 0; d < D; ++d) l[d] = lo[d], u[d] = hi[d];
            const double* const xs = x;
            const int n = np;
            for (int begin = 0; begin < n; begin += B) {
                const int m = std::min(B, n - begin);
                const double* xb = xs + static_cast<std::ptrdiff_t>(D) * begin;
                for (int i = 0; i < m; ++i) {
                    int in = 1;
                    for (int d = 0; d < D; ++d) in &= (xb[D * i + d] >= l[d]) & (xb[D * i + d] <= u[d]);
                    flag[i] = static_cast<unsigned char>(in);
                }
                for (int i = m; i < m + 8; ++i) flag[i] = 0;
                for (int i = 0; i < m; i += 8) {
                    std::uint64_t word;
                    std::memcpy(&word, flag + i, sizeof word);
                    if (word == 0) continue;
                    for (int q = i; q < i + 8 && q < m; ++q)
                        if (flag[q]) candidates_.push_back(begin + q);
                }
            }
        });
    }
    cellOf_.clear();
    std::size_t kept = 0;
    for (const int p : candidates_) {
        const auto& x = P.x[p];
        int index = 0, stride = 1;
        for (int d = 0; d < D; ++d) {
            const int i = std::clamp(static_cast<int>(std::floor((x[d] - g.origin[d]) * g.invh)), 0, nc[d] - 1);
            if (i < binLo_[d] || i > binHi_[d]) {
                index = -1;
                break;
            }
            index += (i - binLo_[d]) * stride;
            stride *= width[d];
        }
        if (index < 0) continue;
        candidates_[kept++] = p;
        cellOf_.push_back(index);
        ++cellStart_[index + 1];
    }
    for (int c = 0; c < cells; ++c) cellStart_[c + 1] += cellStart_[c];
    cellPoints_.resize(cellStart_[cells]);
    fill_.assign(cellStart_.begin(), cellStart_.end() - 1);
    for (std::size_t k = 0; k < kept; ++k) cellPoints_[fill_[cellOf_[k]]++] = candidates_[k];
}

template <int D> bool BodyContact<D>::binNear(const Grid<D>& g, const MaterialPoints<D>& P, double reach,
                                               const std::vector<RigidShape>& list, const PointSupport<D>* support)
{
    // The cell range of each shape, and their union: only the points there are binned.
    ranges_.resize(list.size());
    bool any = false;
    for (std::size_t k = 0; k < list.size(); ++k) {
        Range& r = ranges_[k];
        r.live = cellRange(g, list[k], reach, r.lo, r.hi);
        if (!r.live) continue;
        for (int d = 0; d < 3; ++d) {
            binLo_[d] = any ? std::min(binLo_[d], r.lo[d]) : r.lo[d];
            binHi_[d] = any ? std::max(binHi_[d], r.hi[d]) : r.hi[d];
        }
        any = true;
    }
    if (any) binPoints(g, P, support);
    return any;
}

template <int D>
template <class F>
void BodyContact<D>::forEachNear(const std::vector<RigidShape>& list, const MaterialPoints<D>& P, double reach,
                                  F&& f) const
{
    const int w0 = binHi_[0] - binLo_[0] + 1, w1 = binHi_[1] - binLo_[1] + 1;
    for (int k = 0; k < static_cast<int>(list.size()); ++k) {
        const RigidShape& shape = list[k];
        const Range& r = ranges_[k];
        if (!r.live) continue;
        // A sphere rejects most points of its cells on the squared distance, before closest()'s
        // square root and division. The bound is loose by 1e-9 (relative), so that no point
        // closest() would find within reach (phi < reach, rounded) is rejected.
        const bool sphere = shape.kind == RigidShape::sphere;
        const double lim = (shape.radius + reach) * (1 + 1e-9), lim2 = lim * lim;
        bool more = true;
        for (int k2 = r.lo[2]; more && k2 <= r.hi[2]; ++k2)
            for (int j = r.lo[1]; more && j <= r.hi[1]; ++j)
                for (int i = r.lo[0]; more && i <= r.hi[0]; ++i) {
                    const int cell = (i - binLo_[0]) + w0 * ((j - binLo_[1]) + w1 * (k2 - binLo_[2]));
                    for (int c = cellStart_[cell]; more && c < cellStart_[cell + 1]; ++c) {
                        const int p = cellPoints_[c];
                        V3 x = V3::Zero();
                        x.head<D>() = P.x[p];
                        if (sphere && (x - shape.a).squaredNorm() > lim2) continue;
                        more = f(k, p, x);
                    }
                }
    }
}

template <int D>
void BodyContact<D>::touching(const Grid<D>& grid, const MaterialPoints<D>& points, double reach,
                              const std::vector<RigidShape>& candidates, std::vector<char>& touched)
{
    touched.assign(candidates.size(), 0);
    if (candidates.empty() || points.size() == 0 || !binNear(grid, points, reach, candidates)) return;
    forEachNear(candidates, points, reach, [&](int k, int, const V3& x) {
        double phi;
        V3 sp, n;
        candidates[k].closest(x, phi, sp, n);
        touched[k] = phi < reach;
        return !touched[k];  // one point is enough
    });
}

template <int D> void BodyContact<D>::afterForces(GridState<D>& s)
{
    work = 0;
    pointsInContact = nodesInContact = 0;
    for (auto& b : bodies) {
        b.force.setZero();
        b.torque.setZero();
    }
    if (shapes.empty() || s.points.size() == 0 || !s.support) return;
    const auto& P = s.points;
    const double reach = s.support->halfWidth();
    if (!binNear(s.grid, P, reach, shapes, s.support)) return;

    // 1. The points touching each shape, and the nodes of their supports.
    touches_.clear();
    forEachNear(shapes, P, reach, [&](int k, int p, const V3& x) {
        double phi;
        V3 sp, n;
        shapes[k].closest(x, phi, sp, n);
        if (!(phi < reach)) return true;
        if (D == 2) {
            n[2] = 0;
            const double len = n.norm();
            if (!(len > 1e-12)) return true;
            n /= len;
        }
        ++pointsInContact;
        const double m = P.mass(p);
        s.support->forEachNode(p, [&](int I, double N) {
            if (N > 0) touches_.push_back(Touch{k, I, N * m, N * m * n, N * m * sp});
        });
        return true;
    });
    if (touches_.empty()) return;
    // Merge per (shape, node); stable, so the sums keep the point order (deterministic). The
    // touches come shape by shape (forEachNear), so sorting each shape's run by node is the
    // stable sort by (shape, node): a few touches each, by insertion, without the buffer and the
    // merges of one sort of them all.
    const auto byNode = [](const Touch& a, const Touch& b) { return a.node < b.node; };
    for (std::size_t begin = 0; begin < touches_.size();) {
        std::size_t end = begin + 1;
        while (end < touches_.size() && touches_[end].shape == touches_[begin].shape) ++end;
        if (end - begin > 32) {
            std::stable_sort(touches_.begin() + begin, touches_.begin() + end, byNode);
        } else {
            for (std::size_t i = begin + 1; i < end; ++i) {
                if (!byNode(touches_[i], touches_[i - 1])) continue;
                const Touch t = touches_[i];
                std::size_t j = i;
                for (; j > begin && byNode(t, touches_[j - 1]); --j) touches_[j] = touches_[j - 1];
                touches_[j] = t;
            }
        }
        begin = end;
    }
    std::size_t out = 0;
    for (std::size_t t = 0; t < touches_.size(); ++t) {
        if (out > 0 && touches_[out - 1].shape == touches_[t].shape && touches_[out - 1].node == touches_[t].node) {
            Touch& m = touches_[out - 1];
            m.weight += touches_[t].weight;
            m.normal += touches_[t].normal;
            m.point += touches_[t].point;
        } else {
            touches_[out++] = touches_[t];
        }
    }
    touches_.resize(out);

    // 2. Sequential impulses, shape by shape, node by node.
    auto& G = s.grid;
    const double dt = s.dt;
    std::vector<std::pair<int, V3>> impulses;  // (node, J) for the work
    for (const Touch& t : touches_) {
        const int I = t.node;
        if (G.invMass[I] == 0) continue;
        const double len = t.normal.norm();
        if (!(len > 0)) continue;
        const V3 n = t.normal / len;
        const double m = G.mass[I];
        V3 v = V3::Zero();
        v.head<D>() = (G.momentum[I] + dt * G.force[I]) / m;
        RigidBody& B = bodies[shapes[t.shape].body];
        const V3 r = t.point / t.weight - B.centre;
        V3 rel = v - B.velocity - B.angularVelocity.cross(r);
        if (D == 2) rel[2] = 0;
        const double vn = rel.dot(n);
        if (!(vn < 0)) continue;
        auto inverseMassAlong = [&](const V3& e) {
            const V3 re = r.cross(e);
            return 1.0 / m + e.dot(B.invMass.cwiseProduct(e)) + re.dot(B.invInertia * re);
        };
        auto apply = [&](const V3& J) {  // J: impulse on the node; -J on the body at r
            G.force[I] += (J / dt).template head<D>();
            v += J / m;
            B.velocity -= B.invMass.cwiseProduct(J);
            B.angularVelocity -= B.invInertia * r.cross(J);
            B.force -= J / dt;
            if (!B.central) B.torque -= r.cross(J) / dt;
        };
        const double jn = -vn / inverseMassAlong(n);
        V3 J = jn * n;
        apply(J);
        if (friction > 0) {
            V3 after = v - B.velocity - B.angularVelocity.cross(r);
            if (D == 2) after[2] = 0;
            V3 tangential = after - after.dot(n) * n;
            const double slip = tangential.norm();
            if (slip > 0) {
                const V3 e = tangential / slip;
                const double jt = std::min(slip / inverseMassAlong(e), friction * jn);
                apply(-jt * e);
                J -= jt * e;
            }
        }
        impulses.emplace_back(I, J);
        ++nodesInContact;
    }
    // Work of the contact forces on the points: J . (v^{n-1/2} + v^{n+1/2}) / 2 at each node, with
    // the velocities after all the impulses.
    for (const auto& [I, J] : impulses) {
        V3 vOld = V3::Zero(), vNew = V3::Zero();
        vOld.head<D>() = G.momentum[I] / G.mass[I];
        vNew.head<D>() = (G.momentum[I] + dt * G.force[I]) / G.mass[I];
        work += 0.5 * J.dot(vOld + vNew);
    }
}

template class BodyContact<2>;
template class BodyContact<3>;

}  // namespace emp
