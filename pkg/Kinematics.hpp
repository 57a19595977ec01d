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
#pragma once
#include <cctype>
#include <cmath>
#include <string>

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

inline bool polarDecomposition(const Mat<3>& F, Mat<3>& R, Mat<3>& U)
{
    if (!(F.determinant() > 0)) return false;
    // Once an iteration changes X by less than 1e-8, the error left is of order 1e-16
    // (quadratic convergence); one more iteration settles the last bits.
    Mat<3> X = F;
    for (int it = 0; it < 40; ++it) {
        const Mat<3> next = 0.5 * (X + X.inverse().transpose());
        const double change = (next - X).cwiseAbs().maxCoeff();
        X = next;
        if (change < 1e-8) {
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
