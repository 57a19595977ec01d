// The impulse between two velocity fields that share a grid position: a node and its phantom
// twin across a crack (CrackFaceContact.hpp), or the fields of two bodies at one node
// (BodyFieldContact.hpp). Where both carry mass and approach along the unit normal e (pointing
// from field b's material towards field a's), the impulse gives both the normal velocity of their
// centre of mass (Bardenhagen et al.'s multi-velocity contact), with Coulomb friction capped at
// mu times the normal impulse; momentum is conserved and no tension is transmitted. onForce: on
// the force, so that the momentum P^{n+1/2} has no approach; otherwise on the momentum
// P^{n-1/2} and the velocity.
#pragma once
#include <algorithm>

#include "Grid.hpp"

namespace emp {

/// Applies the impulse between fields a and b (both with invMass > 0); returns whether they
/// approached.
template <int D, bool onForce>
inline bool fieldPairImpulse(Grid<D>& g, int a, int b, const Vec<D>& e, double friction, double dt)
{
    const double m1 = g.mass[a], m2 = g.mass[b];
    const Vec<D> v1 = onForce ? Vec<D>((g.momentum[a] + dt * g.force[a]) / m1) : Vec<D>(g.momentum[a] / m1);
    const Vec<D> v2 = onForce ? Vec<D>((g.momentum[b] + dt * g.force[b]) / m2) : Vec<D>(g.momentum[b] / m2);
    const Vec<D> rel = v1 - v2;
    const double vn = rel.dot(e);
    if (!(vn < 0)) return false;  // separating or at rest: no tension is transmitted
    const double k = 1.0 / m1 + 1.0 / m2;
    const double jn = -vn / k;
    Vec<D> J = jn * e;  // on field a; -J on field b
    if (friction > 0) {
        const Vec<D> slipVelocity = rel - vn * e;
        const double slip = slipVelocity.norm();
        if (slip > 0) J -= std::min(slip / k, friction * jn) / slip * slipVelocity;
    }
    if constexpr (onForce) {
        g.force[a] += J / dt;
        g.force[b] -= J / dt;
    } else {
        g.momentum[a] += J;
        g.momentum[b] -= J;
        g.velocity[a] = g.momentum[a] / m1;
        g.velocity[b] = g.momentum[b] / m2;
    }
    return true;
}

}  // namespace emp
