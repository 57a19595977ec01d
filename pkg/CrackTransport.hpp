// Crack transport: the vertices of pre-existing cracks move with the material (DESIGN.md,
// "crack geometry moving with the material"), so that a cracked body can translate and rotate
// far. The last stage of the step, after G2P, on the grid of the step.
#pragma once
#include "Grid.hpp"
#include "PhantomNodes.hpp"

namespace emp {

/// Moves every crack vertex by dt times the material velocity there (see the .cpp), for the
/// kernel K with particle half-width lp (cells). The grid holds the nodal mass and the momentum
/// P^{n+1/2} of the step.
template <int D, class K> void transportCracks(PhantomNodes<D>& phantom, const Grid<D>& g, double lp, double dt);

}  // namespace emp
