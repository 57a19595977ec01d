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
//   affineTransfer        whether the APIC transfer works with it: its moment matrix D_p =
//                         sum N (x_I - x_p)(x_I - x_p)^T stays invertible (Kinematics.hpp)
// To add a kernel: copy one of these structs into a header of its own, give it a new name and
// add it to EMP_SOLVER_CONFIGURATIONS in Configurations.hpp.
#pragma once
#include <cmath>

#include "Inline.hpp"

namespace emp {

/// W doubles as one vector (GCC/Clang vector extensions: element-wise arithmetic, comparisons
/// and selects, on SIMD registers where the target has them and element by element elsewhere).
template <int W> struct Lanes;
template <> struct Lanes<2> {
    typedef double type __attribute__((vector_size(2 * sizeof(double))));
};

/// The largest integer not above y, for |y| < 2^31 (coordinates in cells of a grid): bitwise
/// static_cast<int>(std::floor(y)) there (tested), in half the instructions on the baseline
/// x86-64 target, which has no rounding instruction (SSE4.1) for std::floor to use.
EMP_ALWAYS_INLINE int floorToInt(double y)
{
    const int i = static_cast<int>(y);  // towards zero
    return y < i ? i - 1 : i;
}

/// A point's half-width lp in cells with its reciprocal, which uGIMP's weights use: computed once
/// per pass, not once per point (a division per point that GCC cannot hoist out of a pass's loop,
/// the half-width being read through a pointer the grid's stores might alias). The same value
/// either way, so the same weights.
struct HalfWidth {
    double lp, inv;
    HalfWidth(double halfWidth) : lp(halfWidth), inv(1.0 / halfWidth) {}  // NOLINT: implicit from lp
};

/// Standard MPM hat function: support of 2 nodes per direction, gradient jumps at cell faces.
struct LinearKernel {
    static constexpr int S = 2;  ///< nodes per direction in the support
    static constexpr int crackRings = 0;
    static constexpr bool gradientJumpsAtNodes = true;
    static constexpr const char* name = "linear";
    /// D_p vanishes in a direction where the point meets a node line: C_p = B_p D_p^-1 blows up.
    static constexpr bool affineTransfer = false;
    static constexpr bool laneEvaluation = false;  ///< (GimpKernel::evalLane)
    /// Weights w and derivatives dw of the S nodes starting at the returned base node index.
    static inline int base(double xi) { return floorToInt(xi); }
    static inline int eval(double xi, double /*lp*/, double* w, double* dw)
    {
        const int b = floorToInt(xi);
        const double f = xi - b;
        w[0] = 1.0 - f;
        w[1] = f;
        dw[0] = -1.0;
        dw[1] = 1.0;
        return b;
    }
    /// eval in each of the D directions (Stencil::compute).
    template <int D> static inline void evalAll(const double* xi, const HalfWidth& lp, int* base, double (*w)[S], double (*dw)[S])
    {
        for (int d = 0; d < D; ++d) base[d] = eval(xi[d], lp.lp, w[d], dw[d]);
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
    /// D_p >= lp^2 / 3 in every direction (the particle's own width).
    static constexpr bool affineTransfer = true;
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
    static inline int base(double xi) { return floorToInt(xi + 0.5) - 1; }
    static inline int eval(double xi, double lp, double* w, double* dw)
    {
        const int c = floorToInt(xi + 0.5);
        for (int k = 0; k < 3; ++k) w[k] = s(xi - (c - 1 + k), lp, dw[k]);
        return c - 1;
    }
    /// eval in each of the D directions, as the solver's passes call it (Stencil::compute): two
    /// directions at a time are the lanes of one vector, and s()'s pieces are chosen by selects, not
    /// branches. A point of an undeformed uGIMP lattice sits exactly on the boundaries between
    /// the pieces (|r| = lp, 1 - lp, 1 + lp), so a branch would be mispredicted about half the
    /// time; and the lanes share the instructions. The divisions by lp are products with its
    /// reciprocals: bitwise eval() when lp is a power of two (ppc = 1, 2, 4, ...), else within
    /// an ulp or two (test_shape_function.cpp).
    template <int D> static inline void evalAll(const double* xi, const HalfWidth& lp, int* base, double (*w)[S], double (*dw)[S])
    {
        evalPair(xi, D > 1 ? 2 : 1, lp, base, w, dw);
        if constexpr (D == 3) evalPair(xi + 2, 1, lp, base + 2, w + 2, dw + 2);
    }

    /// Whether evalLane exists (Stencil::computeRun).
    static constexpr bool laneEvaluation = true;

    /// evalPair for one direction on plain numbers, for a loop whose lanes are points
    /// (Stencil::computeRun): the same operations, so bitwise evalPair's weights. Writes w[k *
    /// Stride] and dw[k * Stride] (k = 0, 1, 2); returns the base node.
    template <int Stride>
    EMP_ALWAYS_INLINE static int evalLane(double xi, const HalfWidth& half, double* w, double* dw)
    {
        const double lp = half.lp, i1 = half.inv, i2 = 0.5 * i1, i4 = 0.25 * i1;
        const int b = floorToInt(xi + 0.5) - 1;
        const double first = b;
        const auto outerNode = [&](int k, double sg) EMP_LAMBDA_INLINE {
            const double r = xi - (first + k);
            const double a = sg * r;
            const double q = 1.0 + lp - a;
            const double wo = q * q * i4, dO = -sg * q * i2;
            w[k * Stride] = a <= 1.0 - lp ? 1.0 - a : a < 1.0 + lp ? wo : 0.0;
            dw[k * Stride] = a <= 1.0 - lp ? -sg : a < 1.0 + lp ? dO : 0.0;
        };
        outerNode(0, 1.0);
        {
            const double r = xi - (first + 1);
            const double a = r < 0.0 ? -r : r, sg = r < 0.0 ? -1.0 : 1.0;
            const double wi = 1.0 - (r * r + lp * lp) * i2, di = -r * i1;
            w[Stride] = a < lp ? wi : 1.0 - a;
            dw[Stride] = a < lp ? di : -sg;
        }
        outerNode(2, -1.0);
        return b;
    }

private:
    /// evalAll for `count` (1 or 2) directions, one per lane of a two-double vector (an SSE2
    /// register: wider vectors of generic code are split badly on the baseline x86-64 target).
    EMP_ALWAYS_INLINE static void evalPair(const double* xi, int count, const HalfWidth& half, int* base, double (*w)[S],
                                           double (*dw)[S])
    {
        const double lp = half.lp;
        using V = Lanes<2>::type;
        V x = {}, first = {};  // xi and the index of the first support node, per lane
        for (int d = 0; d < count; ++d) {
            base[d] = floorToInt(xi[d] + 0.5) - 1;
            x[d] = xi[d];
            first[d] = base[d];
        }
        const double i1 = half.inv, i2 = 0.5 * i1, i4 = 0.25 * i1;
        const V zero = {}, one = zero + 1.0;
        // s()'s pieces, node by node. With lp <= 1/2 (ppc >= 1) each node can be on only some
        // of them: the nearest node (k = 1, |r| <= 1/2 <= 1 - lp) on the inner piece or the
        // linear one; the other two (1/2 <= |r| <= 3/2, r > 0 for k = 0 and r < 0 for k = 2) on the
        // linear piece, the outer one or none. The pieces they cannot be on are not evaluated;
        // the values are those of the selects over all four pieces, bit for bit.
        const auto store = [&](int k, const V& wv, const V& dv) EMP_LAMBDA_INLINE {
            for (int d = 0; d < count; ++d) {
                w[d][k] = wv[d];
                dw[d][k] = dv[d];
            }
        };
        const auto outerNode = [&](int k, const V& sg) EMP_LAMBDA_INLINE {
            const V r = x - (first + k);
            const V a = sg * r;  // |r|: r's sign is known
            const V q = 1.0 + lp - a;
            const V wo = q * q * i4, dO = -sg * q * i2;
            store(k, a <= 1.0 - lp ? 1.0 - a : a < 1.0 + lp ? wo : zero, a <= 1.0 - lp ? -sg : a < 1.0 + lp ? dO : zero);
        };
        outerNode(0, one);
        {
            const V r = x - (first + 1);
            const V a = r < 0.0 ? -r : r, sg = r < 0.0 ? -one : one;
            const V wi = 1.0 - (r * r + lp * lp) * i2, di = -r * i1;
            store(1, a < lp ? wi : 1.0 - a, a < lp ? di : -sg);
        }
        outerNode(2, -one);
    }
};

}  // namespace emp
