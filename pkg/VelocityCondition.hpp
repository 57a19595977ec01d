// Essential (velocity) condition on grid nodes: the velocity prescribed on the components in
// `mask` (bit d = direction d). The nodes are either a fixed list (chosen by region once) or,
// each step, the node nearest to each of the listed boundary points. A fixed support or a
// symmetry/roller plane is a zero velocity on some components. A condition holds at a location:
// it applies to the phantom twins of its nodes too.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <vector>

#include "BoundaryConditions.hpp"
#include "GridCondition.hpp"

namespace emp {

template <int D> class VelocityCondition : public GridCondition<D> {
public:
    std::vector<int> nodes;   ///< static node list (region selection)
    std::vector<int> points;  ///< boundary points (point selection)
    unsigned mask = 0;
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
    double rampTime = 0;
    std::vector<int> active;  ///< nodes constrained in the current step
    /// A distributed run gives the nodes of its `points` for this step here (the ranks' points
    /// are spread over them; Solver::applyConditionsAfterVelocity) instead of the points' ids.
    std::vector<int> pointNodes;
    bool pointNodesGiven = false;
    Eigen::Vector3d reaction = Eigen::Vector3d::Zero();  ///< force the condition exerts, N
    /// Work of the reaction on the body so far, J: each step reaction . (v^{n-1/2} + v^{n+1/2})
    /// dt / 2 with the prescribed velocities at t^{n-1/2} and t^{n+1/2}.
    double work = 0;

    /// The prescribed velocity at time t (the ramp of Eq 34 when rampTime > 0).
    Eigen::Vector3d value(double t) const { return rampFactor(t, rampTime) * velocity; }

    /// Chooses this step's nodes and sets their momentum m v and velocity v (Eq 26 constrained).
    void afterNodalVelocity(GridState<D>& s) override;
    /// Replaces the force by the one that makes the node reach m v at t^{n+1/2}; the reaction
    /// is what that adds to the internal and external forces.
    void afterForces(GridState<D>& s) override;
    /// With a node list only: its lowest and highest node (points move: no range).
    bool nodeRange(int& lo, int& hi) const override
    {
        if (!points.empty()) return false;
        lo = INT_MAX, hi = -1;
        for (const int I : nodes) lo = std::min(lo, I), hi = std::max(hi, I);
        return true;
    }

private:
    template <class F> void forEachConstrained(const PhantomNodes<D>& ph, F&& f) const
    {
        for (int I : active) {  // f(node, its regular node): a twin is where its node is
            f(I, I);
            ph.forEachTwin(I, [&](int t) { f(t, I); });
        }
    }
};

}  // namespace emp
