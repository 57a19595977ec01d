#include "CrackFaceContact.hpp"

#include <algorithm>

namespace emp {

template <int D> template <bool onForce> int CrackFaceContact<D>::apply(GridState<D>& s)
{
    auto& g = s.grid;
    const auto& ph = s.phantom;
    int pairs = 0;
    for (int c = 0; c < static_cast<int>(ph.numCracks()); ++c)
        for (int I : ph.markedNodes()) {
            const int t = ph.twin(c, I);
            if (t < 0 || g.invMass[I] == 0 || g.invMass[t] == 0) continue;
            const double m1 = g.mass[I], m2 = g.mass[t];
            const Vec<D> v1 = onForce ? Vec<D>((g.momentum[I] + s.dt * g.force[I]) / m1) : Vec<D>(g.momentum[I] / m1);
            const Vec<D> v2 = onForce ? Vec<D>((g.momentum[t] + s.dt * g.force[t]) / m2) : Vec<D>(g.momentum[t] / m2);
            const Vec<D> xI = g.nodePosition(I);
            Vec<D> point, n;
            ph.nearest(c, xI, point, n);
            // e points from the crack towards the node's own side: the node's field is the
            // material there, the twin's the material on the other side.
            const Vec<D> e = (xI - point).dot(n) >= 0 ? n : Vec<D>(-n);
            const Vec<D> rel = v1 - v2;
            const double vn = rel.dot(e);
            if (!(vn < 0)) continue;  // separating or at rest: no tension is transmitted
            const double k = 1.0 / m1 + 1.0 / m2;
            const double jn = -vn / k;
            Vec<D> J = jn * e;  // on the node's field; -J on the twin's
            if (friction > 0) {
                const Vec<D> slipVelocity = rel - vn * e;
                const double slip = slipVelocity.norm();
                if (slip > 0) J -= std::min(slip / k, friction * jn) / slip * slipVelocity;
            }
            if constexpr (onForce) {
                g.force[I] += J / s.dt;
                g.force[t] -= J / s.dt;
            } else {
                g.momentum[I] += J;
                g.momentum[t] -= J;
                g.velocity[I] = g.momentum[I] / m1;
                g.velocity[t] = g.momentum[t] / m2;
            }
            ++pairs;
        }
    return pairs;
}

template <int D> void CrackFaceContact<D>::afterNodalVelocity(GridState<D>& s) { apply<false>(s); }

template <int D> void CrackFaceContact<D>::afterForces(GridState<D>& s) { pairsInContact = apply<true>(s); }

template class CrackFaceContact<2>;
template class CrackFaceContact<3>;

}  // namespace emp
