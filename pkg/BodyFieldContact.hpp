// Contact between separate bodies in one grid (doc/contact.md, "Bodies in one engine"). Each
// point carries a body id; a node that points of two or more bodies reach gets a velocity field
// per body (PhantomNodes::updateBodies: the lowest body keeps the node, the others get twins), so
// the bodies move independently there instead of bonding. Between each pair of fields at such a
// node, an impulse removes their approach along the normal (FieldPair.hpp: centre-of-mass normal
// velocity, Coulomb friction, no tension), at both points of the step like the crack-face
// contact. The normal comes from the fields' sums g_a = sum m_p grad N_I(x_p) over their points:
// g_a points from body a's points towards the node, out of body a, so e = (g_b - g_a) / |...|
// points from body b towards body a; the two fields get exactly opposite normals, and momentum is
// conserved pair by pair.
#pragma once
#include <vector>

#include "Grid.hpp"
#include "PhantomNodes.hpp"

namespace emp {

template <int D> class BodyFieldContact {
public:
    double friction = 0;     ///< Coulomb coefficient between the bodies
    int pairsInContact = 0;  ///< field pairs corrected after the forces in the last step
    /// Per node (regular and twin): sum of m_p grad N_I(x_p) over the points mapped to it (filled
    /// by the solver after P2G at the marked nodes): it points out of the field's body.
    std::vector<Vec<D>> gradient;

    /// The impulses at every marked node (onForce: on the force, else on the momentum).
    template <bool onForce> int apply(Grid<D>& g, const PhantomNodes<D>& ph, double dt);
};

}  // namespace emp
