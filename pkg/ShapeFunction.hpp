// One-dimensional interpolation kernels; the D-dimensional shape function is their tensor
// product, N_Ip = s(x) s(y) [s(z)] (paper Eq 15). Coordinates are in cell units (xi = x/h), so
// gradients returned here are per cell length and must be multiplied by 1/h.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace emp {

enum class ShapeKind { Linear, UGIMP };

/// Standard MPM hat function: support of 2 nodes per direction, gradient jumps at cell faces.
struct LinearKernel {
    static constexpr int S = 2;  ///< nodes per direction in the support
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

    /// s and ds of the nodes c-1, c, c+1 (same values as s() above, written without branches).
    /// With f = xi - c in [-1/2, 1/2), Eq 16 has two cases: inside the band |f| < lp the particle
    /// straddles node c and all three weights are quadratic; outside it the particle lies in
    /// one cell and the weights are the hat's, 1 - |r|, on the two nodes of that cell. Both
    /// are evaluated and one is selected bitwise: points initialised on a lattice with ppc
    /// points per cell sit exactly at |f| = lp, so a branch on the band is a coin toss that
    /// the processor mispredicts about every other time. The expressions are those of s() (so
    /// the results are bitwise equal to it when 1/lp is exact, i.e. ppc a power of two, and
    /// equal to round-off otherwise).
    static inline int eval(double xi, double lp, double* w, double* dw)
    {
        const int c = static_cast<int>(std::floor(xi + 0.5));
        const double r0 = xi - (c - 1), r1 = xi - c, r2 = xi - (c + 1);  // r = xi - node
        const double il = 1.0 / lp, il2 = 0.5 * il, il4 = 0.25 * il;
        // Band |r1| < lp: outer parabola q^2/(4 lp) on c-1 and c+1, inner one on c.
        const double q0 = (1.0 + lp) - r0, q2 = (1.0 + lp) + r2;
        const double bw0 = q0 * q0 * il4, bd0 = -q0 * il2;
        const double bw1 = 1.0 - (r1 * r1 + lp * lp) * il2, bd1 = -r1 * il;
        const double bw2 = q2 * q2 * il4, bd2 = q2 * il2;
        // Outside the band: the hat on the cell [c-1, c] (r1 < 0) or [c, c+1] (r1 > 0).
        const double ld1 = -std::copysign(1.0, r1);
        const double lw0 = std::max(1.0 - r0, 0.0), ld0 = 0.5 * (-1.0 - ld1);
        const double lw1 = 1.0 - std::fabs(r1);
        const double lw2 = std::max(1.0 + r2, 0.0), ld2 = 0.5 * (1.0 - ld1);
        const bool band = std::fabs(r1) < lp;
        w[0] = select(band, bw0, lw0);
        w[1] = select(band, bw1, lw1);
        w[2] = select(band, bw2, lw2);
        dw[0] = select(band, bd0, ld0);
        dw[1] = select(band, bd1, ld1);
        dw[2] = select(band, bd2, ld2);
        return c - 1;
    }

private:
    /// c ? a : b by bit masks, so that the compiler cannot turn it into a branch.
    static inline double select(bool c, double a, double b)
    {
        const std::uint64_t m = 0 - static_cast<std::uint64_t>(c);
        std::uint64_t ia, ib;
        std::memcpy(&ia, &a, sizeof ia);
        std::memcpy(&ib, &b, sizeof ib);
        const std::uint64_t r = (ia & m) | (ib & ~m);
        double out;
        std::memcpy(&out, &r, sizeof out);
        return out;
    }
};

}  // namespace emp
