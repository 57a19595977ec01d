// One-dimensional interpolation kernels; the D-dimensional shape function is their tensor
// product, N_Ip = s(x) s(y) [s(z)] (paper Eq 15). Coordinates are in cell units (xi = x/h), so
// gradients returned here are per cell length and must be multiplied by 1/h.
//
// A kernel declares its own traits; the solver, the phantom-node marking and the tests read
// them and infer nothing from the support size:
//   S                     nodes per direction in the support
//   crackRings            rings of cells around a cut cell whose nodes a crack marks (a point
//                         in a cell reaches nodes that many cells away)
//   gradientJumpsAtNodes  whether grad N jumps at a node (a point exactly on a node then sees a
//                         nonzero gradient on a neighbour it has no weight on)
//   name                  the user's name of the shape function (MpmEngine(shape=...))
// To add a kernel: copy one of these structs into a header of its own, give it a new name and
// add it to EMP_SOLVER_CONFIGURATIONS in Configurations.hpp.
#pragma once
#include <cmath>

namespace emp {

/// Standard MPM hat function: support of 2 nodes per direction, gradient jumps at cell faces.
struct LinearKernel {
    static constexpr int S = 2;  ///< nodes per direction in the support
    static constexpr int crackRings = 0;
    static constexpr bool gradientJumpsAtNodes = true;
    static constexpr const char* name = "linear";
    /// Weights w and derivatives dw of the S nodes starting at the returned base node index.
    static inline int base(double xi) { return static_cast<int>(std::floor(xi)); }
    static inline int eval(double xi, double /*lp*/, double* w, double* dw)
    {
        const int b = static_cast<int>(std::floor(xi));
        const double f = xi - b;
        w[0] = 1.0 - f;
        w[1] = f;
        dw[0] = -1.0;
        dw[1] = 1.0;
        return b;
    }
};

/// Undeformed GIMP (paper Eq 16) for a particle of half-width lp cells. Eq 16 is the case
/// lp = 1/4 (2 points per cell per direction); with ppc points per direction lp = 1/(2 ppc).
/// The function is the convolution of the hat with a box of width 2 lp, hence C1.
struct GimpKernel {
    static constexpr int S = 3;
    static constexpr int crackRings = 1;  ///< the support reaches one cell beyond the point's own
    static constexpr bool gradientJumpsAtNodes = false;  ///< C1: grad N vanishes with N
    static constexpr const char* name = "uGIMP";
    static inline double s(double r, double lp, double& ds)
    {
        const double a = std::fabs(r);
        const double sg = r < 0.0 ? -1.0 : 1.0;
        if (a < lp) {
            ds = -r / lp;
            return 1.0 - (r * r + lp * lp) / (2.0 * lp);
        }
        if (a <= 1.0 - lp) {
            ds = -sg;
            return 1.0 - a;
        }
        if (a < 1.0 + lp) {
            const double q = 1.0 + lp - a;
            ds = -sg * q / (2.0 * lp);
            return q * q / (4.0 * lp);
        }
        ds = 0.0;
        return 0.0;
    }
    /// The nearest node c and its two neighbours cover the whole support (|r| < 1 + lp <= 1.5).
    static inline int base(double xi) { return static_cast<int>(std::floor(xi + 0.5)) - 1; }
    static inline int eval(double xi, double lp, double* w, double* dw)
    {
        const int c = static_cast<int>(std::floor(xi + 0.5));
        for (int k = 0; k < 3; ++k) w[k] = s(xi - (c - 1 + k), lp, dw[k]);
        return c - 1;
    }
};

}  // namespace emp
