// Linear elasticity with the spectral tension/compression split (paper Eqs 2-7).
#pragma once
#include <Eigen/Dense>

namespace emp {

template <int D> using Vec = Eigen::Matrix<double, D, 1>;
template <int D> using Mat = Eigen::Matrix<double, D, D>;

/// Isotropic linear elastic material. In 2D it is plane strain or plane stress; plane stress
/// replaces lambda by 2 lambda mu / (lambda + 2 mu), so the 2D law is the plane-stress law.
struct ElasticMaterial {
    double E = 0, nu = 0, rho = 0;
    bool planeStress = false;
    double lambda = 0, mu = 0;  ///< Lame constants used by the (2D or 3D) law

    /// Validates E > 0, -1 < nu < 0.5, rho > 0 and computes the Lame constants.
    static ElasticMaterial make(double E, double nu, double rho, bool planeStress, int dim);
    /// Speed of the dilatational wave sqrt((lambda + 2 mu)/rho) of the law actually used.
    double waveSpeed() const;
};

/// Result of the split at one point: sigma+ and sigma- (Eq 7 with g = 1) and psi+/psi- (3, 4).
template <int D> struct SplitState {
    Mat<D> sigmaPlus, sigmaMinus;
    double psiPlus, psiMinus;
};

/// Spectral split of the strain eps (Eqs 3-7) for Lame constants lambda and mu.
template <int D> SplitState<D> spectralSplit(const Mat<D>& eps, double lambda, double mu);

}  // namespace emp
