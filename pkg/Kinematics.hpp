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
