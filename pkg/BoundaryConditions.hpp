// Time factors of prescribed quantities and tractions on boundary points (Eq 28). Velocity
// conditions on grid nodes are grid conditions (VelocityCondition.hpp).
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

/// Traction t on boundary points: nodal force N_Ip t V_p / layer (Eq 28 with layer = h; the
/// points within one layer of thickness `layer` carry the traction of the surface).
struct TractionCondition {
    std::vector<int> points;
    Eigen::Vector3d traction = Eigen::Vector3d::Zero();
    double rampTime = 0;
    double layer = 0;
};

}  // namespace emp
