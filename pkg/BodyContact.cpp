#include "BodyContact.hpp"

#include <algorithm>
#include <cmath>
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

template <int D> void BodyContact<D>::binPoints(const GridState<D>& s)
{
    // Points by grid cell (counting sort), so that each shape tests only the points near it.
    const auto& g = s.grid;
    int cells = 1;
    for (int d = 0; d < D; ++d) cells *= std::max(g.n[d] - 1, 1);
    cellStart_.assign(cells + 1, 0);
    const int np = static_cast<int>(s.points.size());
    std::vector<int> cellOf(np);
    for (int p = 0; p < np; ++p) {
        int index = 0, stride = 1;
        for (int d = 0; d < D; ++d) {
            const int nc = std::max(g.n[d] - 1, 1);
            const int i = std::clamp(static_cast<int>(std::floor((s.points.x[p][d] - g.origin[d]) * g.invh)), 0, nc - 1);
            index += i * stride;
            stride *= nc;
        }
        cellOf[p] = index;
        ++cellStart_[index + 1];
    }
    for (int c = 0; c < cells; ++c) cellStart_[c + 1] += cellStart_[c];
    cellPoints_.resize(np);
    std::vector<int> fill(cellStart_.begin(), cellStart_.end() - 1);
    for (int p = 0; p < np; ++p) cellPoints_[fill[cellOf[p]]++] = p;
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
    binPoints(s);
    const auto& g = s.grid;
    const auto& P = s.points;
    const double reach = s.support->halfWidth();

    // 1. The points touching each shape, and the nodes of their supports.
    touches_.clear();
    for (int k = 0; k < static_cast<int>(shapes.size()); ++k) {
        const RigidShape& shape = shapes[k];
        V3 lo, hi;
        shape.bounds(lo, hi);
        int clo[3] = {0, 0, 0}, chi[3] = {0, 0, 0}, nc[3] = {1, 1, 1};
        bool empty = false;
        for (int d = 0; d < D; ++d) {
            nc[d] = std::max(g.n[d] - 1, 1);
            const double a = (lo[d] - reach - g.origin[d]) * g.invh, b = (hi[d] + reach - g.origin[d]) * g.invh;
            clo[d] = a <= 0 ? 0 : static_cast<int>(std::min(std::floor(a), double(nc[d])));
            chi[d] = b >= nc[d] - 1 ? nc[d] - 1 : static_cast<int>(std::max(std::floor(b), -1.0));
            empty = empty || clo[d] > chi[d];
        }
        if (empty) continue;
        if (D == 2) {  // the section by z = 0
            if (lo[2] - reach > 0 || hi[2] + reach < 0) continue;
        }
        for (int k2 = clo[2]; k2 <= chi[2]; ++k2)
            for (int j = clo[1]; j <= chi[1]; ++j)
                for (int i = clo[0]; i <= chi[0]; ++i) {
                    const int cell = i + nc[0] * (j + nc[1] * k2);
                    for (int c = cellStart_[cell]; c < cellStart_[cell + 1]; ++c) {
                        const int p = cellPoints_[c];
                        V3 x = V3::Zero();
                        x.head<D>() = P.x[p];
                        double phi;
                        V3 sp, n;
                        shape.closest(x, phi, sp, n);
                        if (!(phi < reach)) continue;
                        if (D == 2) {
                            n[2] = 0;
                            const double len = n.norm();
                            if (!(len > 1e-12)) continue;
                            n /= len;
                        }
                        ++pointsInContact;
                        const double m = P.mass[p];
                        s.support->forEachNode(p, [&](int I, double N) {
                            if (N > 0) touches_.push_back(Touch{k, I, N * m, N * m * n, N * m * sp});
                        });
                    }
                }
    }
    if (touches_.empty()) return;
    // Merge per (shape, node); stable, so the sums keep the point order (deterministic).
    std::stable_sort(touches_.begin(), touches_.end(), [](const Touch& a, const Touch& b) {
        return a.shape != b.shape ? a.shape < b.shape : a.node < b.node;
    });
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
            B.torque -= r.cross(J) / dt;
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
