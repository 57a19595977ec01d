// What Eq 23 gives for a sharp crack: the constant alpha that makes eigenerosion start a crack at
// Griffith's energy release rate (doc/fracture.md, "Initiation at Griffith's energy").
//
// Near the tip of a straight crack the strain is the singular field eps = K / sqrt(2 pi rho) e(theta)
// (Williams; mode I or II), so every law here, homogeneous of degree 2 in the strain, gives
// psi+ = Phi(theta) / rho with Phi the law's psi+ of that field at rho = 1 and K = 1. The mean of
// psi+ over the neighbourhood of Eq 23 (radius kappa; a disc in 2D, a ball around a point of a
// straight front in 3D, where the field is plane strain) is then proportional to 1/kappa, and
//     kappa <psi+> = ratio * G,   G = K^2 / E'   (E' = E/(1 - nu^2) in plane strain and 3D, E in plane stress),
// with a ratio that depends on the law, nu, the plane condition, the dimension and where the
// neighbourhood is centred, but not on kappa or K. Eq 24 (alpha kappa <psi+> >= Gc) starts the
// crack at G = Gc / (alpha ratio): alpha = 1 / ratio is Griffith's. The ratio is computed here by
// quadrature with the law's own response, the mean taken as a volume mean (the discrete points'
// mass-weighted mean approaches it as kappa/h grows; test_erosion_calibration.cpp measures the
// difference on point lattices).
#pragma once
#include <cmath>
#include <vector>

#include "Laws.hpp"

namespace emp {

enum class CrackMode { I, II };

/// In-plane stress of the singular field at rho = 1 for K = 1 (xx, yy, xy).
inline Eigen::Vector3d singularStress(CrackMode mode, double theta)
{
    const double f = 1.0 / std::sqrt(2.0 * M_PI);
    const double c = std::cos(0.5 * theta), s = std::sin(0.5 * theta);
    const double c3 = std::cos(1.5 * theta), s3 = std::sin(1.5 * theta);
    if (mode == CrackMode::I) return f * Eigen::Vector3d(c * (1 - s * s3), c * (1 + s * s3), c * s * c3);
    return f * Eigen::Vector3d(-s * (2 + c * c3), s * c * c3, c * (1 - s * s3));
}

/// The strain of the in-plane stress s = (xx, yy, xy) for material m: plane stress in 2D when m is,
/// else plane strain (sigma_zz = nu (sxx + syy); the 3D strain's out-of-plane parts are 0).
template <int D> Mat<D> strainOf(const Eigen::Vector3d& s, const ElasticMaterial& m)
{
    const double E = m.E, nu = m.nu;
    const double szz = D == 2 && m.planeStress ? 0.0 : nu * (s[0] + s[1]);
    const double tr = s[0] + s[1] + szz;
    Mat<D> eps = Mat<D>::Zero();
    eps(0, 0) = ((1 + nu) * s[0] - nu * tr) / E;
    eps(1, 1) = ((1 + nu) * s[1] - nu * tr) / E;
    eps(0, 1) = eps(1, 0) = (1 + nu) * s[2] / E;
    return eps;
}

/// Length of the ray from the tip at angle theta inside the circle of radius a centred at (d, 0).
inline double chordFromTip(double theta, double d, double a)
{
    const double disc = a * a - d * d * std::sin(theta) * std::sin(theta);
    if (disc <= 0) return 0.0;
    const double root = std::sqrt(disc), mid = d * std::cos(theta);
    if (d < a) return mid + root;             // the tip inside: from 0 to the far crossing
    return mid > 0 ? 2.0 * root : 0.0;        // the tip outside: between the two crossings
}

/// kappa <psi+> / G for material m in dimension D (2D: its plane condition; 3D: plane strain
/// along a straight front), the neighbourhood centred `offset` kappa ahead of the tip (0: on it),
/// for the mixed field K_I = cos(mixity), K_II = sin(mixity) (G = (K_I^2 + K_II^2) / E' = 1 / E').
template <int D> double initiationRatioMixed(const ElasticMaterial& m, double mixity, double offset = 0.0)
{
    const double Eprime = D == 2 && m.planeStress ? m.E : m.E / (1.0 - m.nu * m.nu);
    // Phi(theta) on a midpoint rule (Phi is continuous; its slope jumps where the split's case
    // changes, so the rule converges as 1/n^2).
    const int nTheta = 4096;
    std::vector<double> phi(nTheta), theta(nTheta);
    for (int i = 0; i < nTheta; ++i) {
        theta[i] = -M_PI + (i + 0.5) * 2.0 * M_PI / nTheta;
        const Eigen::Vector3d sg = std::cos(mixity) * singularStress(CrackMode::I, theta[i]) +
                                   std::sin(mixity) * singularStress(CrackMode::II, theta[i]);
        phi[i] = lawResponse<D>(strainOf<D>(sg, m), m).psiPlus;
    }
    const double dTheta = 2.0 * M_PI / nTheta;
    const double d = offset;  // kappa = 1
    double integral = 0;      // of psi+ over the neighbourhood, kappa = 1, K = 1
    if constexpr (D == 2) {
        for (int i = 0; i < nTheta; ++i) integral += phi[i] * chordFromTip(theta[i], d, 1.0) * dTheta;
        return integral / M_PI / (1.0 / Eprime);  // kappa <psi+> = integral / (pi kappa^2) * kappa
    } else {
        // Slices across the front (z along it): discs of radius sqrt(1 - z^2).
        const int nz = 1024;
        for (int k = 0; k < nz; ++k) {
            const double z = -1.0 + (k + 0.5) * 2.0 / nz;
            const double a = std::sqrt(1.0 - z * z);
            double slice = 0;
            for (int i = 0; i < nTheta; ++i) slice += phi[i] * chordFromTip(theta[i], d, a) * dTheta;
            integral += slice * 2.0 / nz;
        }
        return integral / (4.0 / 3.0 * M_PI) / (1.0 / Eprime);
    }
}

/// initiationRatioMixed for pure mode I or II.
template <int D> double initiationRatio(const ElasticMaterial& m, CrackMode mode, double offset = 0.0)
{
    return initiationRatioMixed<D>(m, mode == CrackMode::I ? 0.0 : 0.5 * M_PI, offset);
}

/// Griffith's alpha for Eq 24: 1 / initiationRatio in mode I, neighbourhood on the tip.
template <int D> double griffithAlpha(const ElasticMaterial& m) { return 1.0 / initiationRatio<D>(m, CrackMode::I, 0.0); }

}  // namespace emp
