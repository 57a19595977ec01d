#include "VelocityCondition.hpp"

#include <algorithm>

namespace emp {

template <int D> void VelocityCondition<D>::afterNodalVelocity(GridState<D>& s)
{
    active = nodes;
    if (pointNodesGiven)
        active.insert(active.end(), pointNodes.begin(), pointNodes.end());
    else
        for (int p : points) {
            const int I = s.grid.nearestNode(s.points.x[p]);
            if (I >= 0) active.push_back(I);
        }
    std::sort(active.begin(), active.end());
    active.erase(std::unique(active.begin(), active.end()), active.end());
    const Eigen::Vector3d vbar = value(s.time);
    auto& g = s.grid;
    forEachConstrained(s.phantom, [&](int I, int) {
        for (int d = 0; d < D; ++d) {
            if (!(mask & (1u << d))) continue;
            g.momentum[I][d] = g.mass[I] * vbar[d];
            g.velocity[I][d] = g.mass[I] > 0 ? vbar[d] : 0.0;
        }
    });
}

template <int D> void VelocityCondition<D>::afterForces(GridState<D>& s)
{
    const Eigen::Vector3d vbar = value(s.time);
    auto& g = s.grid;
    reaction.setZero();
    forEachConstrained(s.phantom, [&](int I, int regular) {
        const bool owned = s.owns(regular);
        for (int d = 0; d < D; ++d) {
            if (!(mask & (1u << d))) continue;
            const double applied = (g.mass[I] * vbar[d] - g.momentum[I][d]) / s.dt;
            if (owned) reaction[d] += applied - g.force[I][d];
            g.force[I][d] = applied;
        }
    });
    const Eigen::Vector3d before = value(std::max(s.time - s.dt, 0.0));
    for (int d = 0; d < D; ++d)
        if (mask & (1u << d)) work += s.dt * reaction[d] * 0.5 * (before[d] + vbar[d]);
}

template class VelocityCondition<2>;
template class VelocityCondition<3>;

}  // namespace emp
