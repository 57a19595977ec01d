#include "CrackFaceContact.hpp"

#include "FieldPair.hpp"

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
            const Vec<D> xI = g.nodePosition(I);
            Vec<D> point, n;
            ph.nearest(c, xI, point, n);
            // e points from the crack towards the node's own side: the node's field is the
            // material there, the twin's the material on the other side.
            const Vec<D> e = (xI - point).dot(n) >= 0 ? n : Vec<D>(-n);
            if (!fieldPairImpulse<D, onForce>(g, I, t, e, friction, s.dt)) continue;
            ++pairs;
        }
    return pairs;
}

template <int D> void CrackFaceContact<D>::afterNodalVelocity(GridState<D>& s) { apply<false>(s); }

template <int D> void CrackFaceContact<D>::afterForces(GridState<D>& s) { pairsInContact = apply<true>(s); }

template class CrackFaceContact<2>;
template class CrackFaceContact<3>;

}  // namespace emp
