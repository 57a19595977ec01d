// Contact between the two faces of a pre-existing (phantom-node) crack: the faces may separate
// freely but not pass through each other (doc/contact.md). At every marked node and its twin
// (PhantomNodes.hpp), the two velocity fields are the two faces' material, the node's on the side
// of the crack where the node lies and the twin's on the other. Where both carry mass and they
// approach along the crack's normal, an impulse between them gives both the normal velocity of
// their centre of mass (Bardenhagen et al.'s multi-velocity contact), with Coulomb friction capped
// at mu times the normal impulse. Momentum is conserved; the faces transmit no tension. It acts at
// both points of the step: on the momentum P^{n-1/2} (so that the strain increment sees no
// interpenetration) and on the force (so that P^{n+1/2} has none).
#pragma once
#include "GridCondition.hpp"

namespace emp {

template <int D> class CrackFaceContact : public GridCondition<D> {
public:
    double friction = 0;  ///< Coulomb coefficient between the faces
    int pairsInContact = 0;  ///< (node, twin) pairs corrected after the forces in the last step

    void afterNodalVelocity(GridState<D>& s) override;
    void afterForces(GridState<D>& s) override;

private:
    template <bool onForce> int apply(GridState<D>& s);
};

}  // namespace emp
