// How points carry motion and deformation between steps: the particle-grid transfer and the
// stress update, each a setting of the solver (SolverSettings), and the polar decomposition the
// co-rotational update needs. doc/stability.md ("Rotating and flying fragments") derives and
// measures them.
//
// Transfer
//   flip   the paper's (Eqs 25, 30): P2G carries m_p v_p, G2P adds the nodal acceleration to
//          the point's velocity. A linear velocity field is not reproduced where a point's
//          support reaches empty nodes (free surfaces), and the transfer does not conserve
//          angular momentum.
//   apic   affine particle-in-cell (Jiang et al. 2015, 2017): each point also carries an affine
//          velocity C_p. P2G: m_I v_I = sum_p N_Ip m_p (v_p + C_p (x_I - x_p)); G2P: v_p =
//          sum_I N_Ip v_I, B_p = sum_I N_Ip v_I (x_I - x_p)^T and C_p = B_p D_p^-1 with the
//          moment matrix D_p = sum_I N_Ip (x_I - x_p)(x_I - x_p)^T (diagonal for a tensor-product
//          kernel). Any affine velocity field is carried exactly (every node of a point's support
//          has mass from that point), and angular momentum x_p x m_p v_p + m_p eps:(B_p^T) is
//          conserved by both transfers.
//
// Stress update
//   smallStrain    the paper's (Eq 27): eps += dt sym(L) with L from the nodal velocities after
//                  P2G. Not objective: a rotating body keeps its stress fixed in space, and the
//                  chord velocities of a rotation add strain of order (omega dt)^2 per step.
//   corotational   a deformation gradient per point, F <- (I - dt L)^-1 F, and the paper's law
//                  and split evaluated on the co-rotated strain eps = U - I of its polar
//                  decomposition F = R U. L is Eq 27's velocity gradient: that of the velocity
//                  v^{n-1/2}, which moved the points to x^n, taken at x^n (update stress first);
//                  the motion's gradient dx^n/dx^{n-1} is then (I - dt L)^-1 exactly, for any
//                  velocity field the transfer carries, so a rigid rotation by any angle gives
//                  F = R, U = I: no strain, no stress, no erosion (the small-strain increment
//                  dt sym(L) of a rotation's chord velocities is a spurious dilatation of
//                  (omega dt)^2 / 2 per step). The stress is the Kirchhoff stress tau =
//                  R sigma(eps) U R^T of the energy psi(U - I), divided by J = det F for the
//                  Cauchy stress the points report; the internal force is V_0 tau grad N.
//                  With APIC, G2P updates F instead: F <- (I + dt C_p) F with C_p = B_p D_p^-1
//                  from the sums it has just taken at x^n (the pairing of MLS-MPM, Hu et al.
//                  2018). The points then move by x <- x + dt sum_I N_I v_I, whose gradient is
//                  I + dt C_p exactly for any affine field of v_I (a rigid rotation's chord
//                  velocities included) and C_p its least-squares fit otherwise; the stress pass
//                  takes F as it is and sums no velocity gradients (Solver::deformationInG2P).
//                  The internal force is then MLS-MPM's, V_0 tau D_p^-1 (x_I - x_p) N_I: the
//                  transpose of the operator that gives C_p, so that the stress works only
//                  through the deformation F follows (scattered by P2G with the momentum,
//                  Solver::particleToGrid; with grad N the velocity modes the affine fit does
//                  not see were pushed by stresses they did not strain, and John-Shah's beam
//                  eroded spuriously: doc/stability.md).
#pragma once
#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>
#include <type_traits>
#include <utility>

#include "ElasticMaterial.hpp"
#include "Inline.hpp"

namespace emp {

enum class Transfer { unset, flip, apic };
enum class StressUpdate { unset, smallStrain, corotational };

inline const char* name(Transfer t) { return t == Transfer::flip ? "FLIP" : t == Transfer::apic ? "APIC" : "unset"; }
inline const char* name(StressUpdate u)
{
    return u == StressUpdate::smallStrain ? "smallStrain" : u == StressUpdate::corotational ? "corotational" : "unset";
}
/// The setting of a user's name (case-insensitive for the transfer), or unset.
inline Transfer transferOf(std::string s)
{
    for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return s == "FLIP" ? Transfer::flip : s == "APIC" ? Transfer::apic : Transfer::unset;
}
inline StressUpdate stressUpdateOf(const std::string& s)
{
    return s == "smallStrain" ? StressUpdate::smallStrain : s == "corotational" ? StressUpdate::corotational
                                                                                : StressUpdate::unset;
}

/// Polar decomposition F = R U (R a rotation, U symmetric) of a deformation gradient with
/// det F > 0. 2D: closed form; 3D: Higham's Newton iteration X <- (X + X^-T) / 2, which
/// converges quadratically from F (a few iterations for the small strains of brittle solids).
/// Returns false when F is degenerate (det F <= 0 or no convergence).
EMP_ALWAYS_INLINE bool polarDecomposition(const Mat<2>& F, Mat<2>& R, Mat<2>& U)
{
    const double s = F(1, 0) - F(0, 1), c = F(0, 0) + F(1, 1), r2 = s * s + c * c;  // (not hypot: 5x slower)
    if (!(r2 > 0) || !(F.determinant() > 0)) return false;
    const double ir = 1.0 / std::sqrt(r2), cr = c * ir, sr = s * ir;
    R << cr, -sr, sr, cr;
    const Mat<2> M = R.transpose() * F;
    U = 0.5 * (M + M.transpose());
    return true;
}

/// The change of an iteration below which the 3D polar decomposition takes its settling step.
constexpr double polarSettle = 1e-4;

inline bool polarDecomposition(const Mat<3>& F, Mat<3>& R, Mat<3>& U)
{
    if (!(F.determinant() > 0)) return false;
    // The iteration converges quadratically, e_{k+1} ~ e_k^2 / 2 near a rotation, and an
    // iteration's change is about the error it started from: once it is below 1e-4 the error
    // left is below about 5e-9, and one more iteration (the settling step) takes it to round-off.
    // (Until session 48 the bound was 1e-8, which cost one more iteration at strains from about
    // 1e-4 to 1e-2 for the same R to round-off: 4e-15 against an SVD's, strains 1e-6 to 0.6.)
    Mat<3> X = F;
    for (int it = 0; it < 40; ++it) {
        const Mat<3> next = 0.5 * (X + X.inverse().transpose());
        const double change = (next - X).cwiseAbs().maxCoeff();
        X = next;
        if (change < polarSettle) {
            R = 0.5 * (X + X.inverse().transpose());
            const Mat<3> M = R.transpose() * F;
            U = 0.5 * (M + M.transpose());
            return true;
        }
    }
    return false;
}

/// A 2 x 2 matrix on plain numbers: the co-rotational update of a run of 2D points in one
/// vectorised loop (Solver::corotationalOfRun2) works on these, one point per lane.
struct Plain2 {
    double xx, xy, yx, yy;
};

/// F <- (I - dt L)^-1 F on plain numbers: bitwise Eigen's (I - dt L).inverse() * F for 2 x 2
/// matrices (the same operations in the same order; a sum of two products is the same either way).
EMP_ALWAYS_INLINE Plain2 deformationUpdate2(double dt, const Plain2& L, const Plain2& F)
{
    const double axx = 1.0 - dt * L.xx, axy = 0.0 - dt * L.xy, ayx = 0.0 - dt * L.yx, ayy = 1.0 - dt * L.yy;
    const double inv = 1.0 / (axx * ayy - ayx * axy);
    const double bxx = ayy * inv, bxy = -axy * inv, byx = -ayx * inv, byy = axx * inv;
    return {bxx * F.xx + bxy * F.yx, bxx * F.xy + bxy * F.yy, byx * F.xx + byy * F.yx, byx * F.xy + byy * F.yy};
}

/// polarDecomposition of a 2D F on plain numbers and without branches: R = (cr, -sr; sr, cr) and
/// U, bitwise those of the Eigen form. Returns whether F was accepted; for a refused F the
/// outputs are meaningless (possibly NaN) and must not be used.
EMP_ALWAYS_INLINE bool polarDecomposition2(const Plain2& F, double& cr, double& sr, Plain2& U)
{
    const double s = F.yx - F.xy, c = F.xx + F.yy, r2 = s * s + c * c;
    const bool ok = (r2 > 0) & (F.xx * F.yy - F.yx * F.xy > 0);
    const double ir = 1.0 / std::sqrt(r2);
    cr = c * ir;
    sr = s * ir;
    const double mxx = cr * F.xx + sr * F.yx, mxy = cr * F.xy + sr * F.yy;  // R^T F
    const double myx = -sr * F.xx + cr * F.yx, myy = -sr * F.xy + cr * F.yy;
    U = {0.5 * (mxx + mxx), 0.5 * (mxy + myx), 0.5 * (myx + mxy), 0.5 * (myy + myy)};
    return ok;
}

/// cauchyStress for 2D on plain numbers (R = (cr, -sr; sr, cr)): bitwise the Eigen form.
EMP_ALWAYS_INLINE Plain2 cauchyStress2(double cr, double sr, const Plain2& U, const Plain2& s)
{
    const double axx = s.xx * U.xx + s.xy * U.yx, axy = s.xx * U.xy + s.xy * U.yy;  // s U
    const double ayx = s.yx * U.xx + s.yy * U.yx, ayy = s.yx * U.xy + s.yy * U.yy;
    const double bxx = cr * axx + -sr * ayx, bxy = cr * axy + -sr * ayy;  // R (s U)
    const double byx = sr * axx + cr * ayx, byy = sr * axy + cr * ayy;
    const double txx = bxx * cr + bxy * -sr, txy = bxx * sr + bxy * cr;  // (R s U) R^T
    const double tyx = byx * cr + byy * -sr, tyy = byx * sr + byy * cr;
    const double k = 0.5 / (U.xx * U.yy - U.yx * U.xy);
    return {k * (txx + txx), k * (txy + tyx), k * (tyx + txy), k * (tyy + tyy)};
}

/// A 3 x 3 matrix on plain numbers, a[row][column]: the co-rotational update of a run of 3D
/// points with its algebra in vectorised loops (Solver::corotationalOfRun3). The functions below
/// do Eigen's operations in Eigen's order (a product's three terms summed from the first), so
/// that the results are bitwise those of the Eigen forms (tested).
struct Plain3 {
    double a[3][3];
};

/// Calls f(std::integral_constant<int, k>) for k = 0 ... 8: the entries of a Plain3 with their
/// indices known at compile time, so that the compiler keeps each lane's matrices in registers
/// and can vectorise the loops over a run.
template <class F, int... K> EMP_ALWAYS_INLINE void forEntries(F&& f, std::integer_sequence<int, K...>)
{
    (f(std::integral_constant<int, K>{}), ...);
}
template <class F> EMP_ALWAYS_INLINE void forEntries(F&& f) { forEntries(f, std::make_integer_sequence<int, 9>{}); }

EMP_ALWAYS_INLINE double cofactor3(const Plain3& m, int i, int j)
{
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
    return m.a[i1][j1] * m.a[i2][j2] - m.a[i1][j2] * m.a[i2][j1];
}

/// det m as Eigen's determinant() computes it.
EMP_ALWAYS_INLINE double determinant3(const Plain3& m)
{
    const auto h = [&](int a, int b, int c) EMP_LAMBDA_INLINE { return m.a[0][a] * (m.a[1][b] * m.a[2][c] - m.a[1][c] * m.a[2][b]); };
    return h(0, 1, 2) - h(1, 0, 2) + h(2, 0, 1);
}

/// m^-1 (transposed: m^-T) as Eigen's inverse() computes it: cofactors over the determinant
/// from the first column's cofactors.
template <bool transposed> EMP_ALWAYS_INLINE Plain3 inverse3(const Plain3& m)
{
    const double det = cofactor3(m, 0, 0) * m.a[0][0] + cofactor3(m, 1, 0) * m.a[1][0] + cofactor3(m, 2, 0) * m.a[2][0];
    const double inv = 1.0 / det;
    Plain3 r;
    forEntries([&](auto k) EMP_LAMBDA_INLINE {
        constexpr int i = k / 3, j = k % 3;
        r.a[i][j] = (transposed ? cofactor3(m, i, j) : cofactor3(m, j, i)) * inv;
    });
    return r;
}

/// A B (A^T B with transposeA, A B^T with transposeB), Eigen's order of the sums: for a
/// column-major left factor Eigen sums rows 0 and 1 with SSE2 packets, (p0 + p1) + p2, and
/// row 2 as a reduction, p0 + (p1 + p2); A^T B sums every row as the packets do.
template <bool transposeA = false, bool transposeB = false>
EMP_ALWAYS_INLINE Plain3 product3(const Plain3& A, const Plain3& B)
{
    const auto a = [&](int i, int k) EMP_LAMBDA_INLINE { return transposeA ? A.a[k][i] : A.a[i][k]; };
    const auto b = [&](int k, int j) EMP_LAMBDA_INLINE { return transposeB ? B.a[j][k] : B.a[k][j]; };
    Plain3 r;
    forEntries([&](auto k) EMP_LAMBDA_INLINE {
        constexpr int i = k / 3, j = k % 3;
        const double p0 = a(i, 0) * b(0, j), p1 = a(i, 1) * b(1, j), p2 = a(i, 2) * b(2, j);
        r.a[i][j] = !transposeA && i == 2 ? p0 + (p1 + p2) : (p0 + p1) + p2;
    });
    return r;
}

/// One Newton step of the 3D polar decomposition, (X + X^-T) / 2.
EMP_ALWAYS_INLINE Plain3 polarNewton3(const Plain3& X)
{
    const Plain3 T = inverse3<true>(X);
    Plain3 r;
    forEntries([&](auto k) EMP_LAMBDA_INLINE {
        constexpr int i = k / 3, j = k % 3;
        r.a[i][j] = 0.5 * (X.a[i][j] + T.a[i][j]);
    });
    return r;
}

/// The largest change of an entry from X to next (NaN entries are passed over, as std::max does).
EMP_ALWAYS_INLINE double polarChange3(const Plain3& X, const Plain3& next)
{
    double change = 0;
    forEntries([&](auto k) EMP_LAMBDA_INLINE {
        constexpr int i = k / 3, j = k % 3;
        change = std::max(change, std::abs(next.a[i][j] - X.a[i][j]));
    });
    return change;
}

/// U = sym(R^T F) for the rotation R of F's polar decomposition.
EMP_ALWAYS_INLINE Plain3 stretch3(const Plain3& R, const Plain3& F)
{
    const Plain3 M = product3<true, false>(R, F);
    Plain3 U;
    forEntries([&](auto k) EMP_LAMBDA_INLINE { U.a[k / 3][k % 3] = 0.5 * (M.a[k / 3][k % 3] + M.a[k % 3][k / 3]); });
    return U;
}

/// cauchyStress for 3D on plain numbers: bitwise the Eigen form.
EMP_ALWAYS_INLINE Plain3 cauchyStress3(const Plain3& R, const Plain3& U, const Plain3& s)
{
    const Plain3 t = product3<false, true>(product3(R, product3(s, U)), R);
    const double k = 0.5 / determinant3(U);
    Plain3 r;
    forEntries([&](auto n) EMP_LAMBDA_INLINE { r.a[n / 3][n % 3] = k * (t.a[n / 3][n % 3] + t.a[n % 3][n / 3]); });
    return r;
}

/// Four points' 3 x 3 matrices between a run's nine lane arrays (point i's entry k = 3 row +
/// column at a[k][i], as Solver::corotationalOfRun3 keeps them) and Eigen's column-major storage
/// (9 numbers from m[p], points i0 .. i0 + 3): memory position 0 .. 7 by two 4 x 4 transposes in
/// 4-lane vectors, position 8 one by one. The same numbers as copying entry by entry (a copy),
/// in about a third of the instructions.
namespace lanes9 {
typedef double V4 __attribute__((vector_size(4 * sizeof(double))));
/// The entry at memory position m of a column-major 3 x 3 matrix.
constexpr int entryAt[9] = {0, 3, 6, 1, 4, 7, 2, 5, 8};
/// Rows r[0..3] (4 lanes each) transposed into t[0..3]: t[p][q] = r[q][p].
EMP_ALWAYS_INLINE void transpose4(const V4 (&r)[4], V4 (&t)[4])
{
    const V4 a = __builtin_shufflevector(r[0], r[1], 0, 4, 2, 6), b = __builtin_shufflevector(r[0], r[1], 1, 5, 3, 7);
    const V4 c = __builtin_shufflevector(r[2], r[3], 0, 4, 2, 6), d = __builtin_shufflevector(r[2], r[3], 1, 5, 3, 7);
    t[0] = __builtin_shufflevector(a, c, 0, 1, 4, 5);
    t[1] = __builtin_shufflevector(b, d, 0, 1, 4, 5);
    t[2] = __builtin_shufflevector(a, c, 2, 3, 6, 7);
    t[3] = __builtin_shufflevector(b, d, 2, 3, 6, 7);
}
}  // namespace lanes9

template <int R> EMP_ALWAYS_INLINE void lanesToMatrices3(const double (*a)[R], int i0, double* const (&m)[4])
{
    using lanes9::V4;
#pragma GCC unroll 2
    for (int h = 0; h < 2; ++h) {
        V4 r[4], t[4];
#pragma GCC unroll 4
        for (int q = 0; q < 4; ++q) __builtin_memcpy(&r[q], &a[lanes9::entryAt[4 * h + q]][i0], sizeof(V4));
        lanes9::transpose4(r, t);
#pragma GCC unroll 4
        for (int p = 0; p < 4; ++p) __builtin_memcpy(m[p] + 4 * h, &t[p], sizeof(V4));
    }
#pragma GCC unroll 4
    for (int p = 0; p < 4; ++p) m[p][8] = a[8][i0 + p];
}

template <int R> EMP_ALWAYS_INLINE void matricesToLanes3(const double* const (&m)[4], double (*a)[R], int i0)
{
    using lanes9::V4;
#pragma GCC unroll 2
    for (int h = 0; h < 2; ++h) {
        V4 r[4], t[4];
#pragma GCC unroll 4
        for (int p = 0; p < 4; ++p) __builtin_memcpy(&r[p], m[p] + 4 * h, sizeof(V4));
        lanes9::transpose4(r, t);
#pragma GCC unroll 4
        for (int q = 0; q < 4; ++q) __builtin_memcpy(&a[lanes9::entryAt[4 * h + q]][i0], &t[q], sizeof(V4));
    }
#pragma GCC unroll 4
    for (int p = 0; p < 4; ++p) a[8][i0 + p] = m[p][8];
}

/// C = B D^-1 for the diagonal d of a moment matrix (APIC). A direction with d = 0 (a linear
/// kernel's point exactly on a node line: its only node there has no offset) gets 0.
template <int D> EMP_ALWAYS_INLINE Mat<D> affineOf(const Mat<D>& B, const Vec<D>& d)
{
    Mat<D> C;
    for (int k = 0; k < D; ++k) C.col(k) = d[k] > 0 ? Vec<D>(B.col(k) / d[k]) : Vec<D>::Zero();
    return C;
}

/// The Cauchy stress R s U R^T / det U of a co-rotated stress s (coaxial with U for an
/// isotropic law: s U is symmetric up to round-off, and is symmetrised).
template <int D> EMP_ALWAYS_INLINE Mat<D> cauchyStress(const Mat<D>& R, const Mat<D>& U, const Mat<D>& s)
{
    const Mat<D> t = R * (s * U) * R.transpose();
    return (0.5 / U.determinant()) * (t + t.transpose());
}

}  // namespace emp
