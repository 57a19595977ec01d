"""The ramp of a prescribed velocity or traction (paper Eq 34): the value rises linearly from 0
over the ramp time t0, then stays. The solver applies it in C++ (emp::rampFactor in
pkg/BoundaryConditions.hpp, behind MpmEngine.velocityBC and traction with rampTime=t0); Python
code that prescribes or plans the same history uses these."""


def rampFactor(t, rampTime):
    """Factor of the prescribed value at time t: min(t / t0, 1), and 0 before t = 0, for a ramp
    time t0 > 0; 1 without a ramp (t0 <= 0)."""
    if rampTime <= 0:
        return 1.0
    return min(max(t / rampTime, 0.0), 1.0)


def rampDisplacement(t, velocity, rampTime):
    """Distance moved by time t >= 0 by a point driven at `velocity` (m/s) reached over the ramp
    `rampTime` (s), the integral of rampFactor: v t^2 / (2 t0) within the ramp, v (t - t0 / 2)
    after it, v t without a ramp. The inverse of :func:`rampTimeTo`."""
    v, t0 = velocity, rampTime
    if t0 <= 0:
        return v * t
    return v * (t - 0.5 * t0) if t >= t0 else v * t * t / (2 * t0)


def rampTimeTo(displacement, velocity, rampTime):
    """Time at which a point driven at `velocity` (m/s) reached over the ramp `rampTime` (s) has
    moved by `displacement` (m, same sign as the velocity): u = v t^2 / (2 t0) within the ramp,
    u = v (t - t0 / 2) after it."""
    u, v, t0 = displacement, velocity, rampTime
    return u / v + 0.5 * t0 if u / v > 0.5 * t0 else (2 * u * t0 / v) ** 0.5
