// Essential (velocity) conditions on grid nodes and tractions on boundary points (Eq 28).
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <vector>

namespace emp {

/// Time factor of a prescribed quantity: 1, or the ramp min(t/t0, 1) of Eq 34 when t0 > 0.
inline double rampFactor(double t, double rampTime)
{
    if (rampTime <= 0) return 1.0;
    return std::clamp(t / rampTime, 0.0, 1.0);
}

/// Velocity prescribed on the components in `mask` (bit d = direction d) of a node set. The
/// nodes are either a fixed list (chosen by region once) or, each step, the node nearest to
/// each of the listed boundary points. A fixed support or a symmetry/roller plane is a zero
/// velocity on some components.
struct VelocityCondition {
    std::vector<int> nodes;   ///< static node list (region selection)
    std::vector<int> points;  ///< boundary points (point selection)
    unsigned mask = 0;
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
    double rampTime = 0;
    std::vector<int> active;  ///< nodes constrained in the current step
    Eigen::Vector3d reaction = Eigen::Vector3d::Zero();  ///< force the condition exerts, N
    Eigen::Vector3d value(double t) const { return rampFactor(t, rampTime) * velocity; }
};

/// Traction t on boundary points: nodal force N_Ip t V_p / layer (Eq 28 with layer = h; the
/// points within one layer of thickness `layer` carry the traction of the surface).
struct TractionCondition {
    std::vector<int> points;
    Eigen::Vector3d traction = Eigen::Vector3d::Zero();
    double rampTime = 0;
    double layer = 0;
};

}  // namespace emp
