// What a constitutive law is to the solver: a compile-time policy, one struct per law, chosen
// per material by its index in RegisteredLaws (Laws.hpp). The solver dispatches once per point
// with a switch over that list (withLaw); there is no virtual call per point.
//
// A law is a struct with (see laws/TemplateLaw.hpp for a commented starting point):
//   static constexpr const char* name;             user's name: ElasticMaterial(split=name)
//   static constexpr Compression tensionFree;       which compressive states have psi+ = 0,
//                                                  i.e. never erode (tested for every law)
//   template <int D> static LawResponse<D> response(const Mat<D>& eps, const ElasticMaterial& m);
//       sigma+ and sigma- with sigma = g(c) sigma+ + sigma- (Eq 7), and psi+/psi- (Eqs 3-4);
//       an eroded point (c = 0) keeps sigma-; a 2D point stores the stress's symmetric part (three
//       numbers, PointTensor.hpp), and psi+/psi- are evaluated again from the strain where
//       they are asked for, so the response must be a function of eps and m alone
//   static double outOfPlaneStress(const Mat<2>& eps, double c, const ElasticMaterial& m);
//       sigma_zz of a 2D point (plane strain; plane stress returns 0)
//   static double waveSpeed(const ElasticMaterial& m);   dilatational wave speed (critical dt)
// and, optionally, for speed (HasResponse2 below):
//   static void response2(double exx, double exy, double eyx, double eyy, double c, double lambda,
//                         double mu, double& sxx, double& sxy, double& syx, double& syy,
//                         double& psiPlus, double& psiMinus);
//       the 2D stress c sigma+ + sigma- and psi+/psi- on plain numbers, inlinable and without
//       branches; the solver then evaluates the law for runs of points in one vectorised loop
//       (Solver::lawOfRun2, and with the co-rotational update Solver::corotationalOfRun2). It
//       must give bitwise what response<2> gives (tested for every law).
//   static void response3(double xx, double yy, double zz, double yx, double zx, double zy,
//                         double c, double lambda, double mu, double& sxx, double& syy,
//                         double& szz, double& syx, double& szx, double& szy,
//                         double& psiPlus, double& psiMinus, bool& ordinary);
//       the same in 3D for a symmetric strain (its lower triangle in, the stress's out); the
//       solver's 3D stress pass then runs the law for runs of points (Solver::lawOfRun3) and
//       takes a point whose `ordinary` is false through response<3> (a law may need a scaling or
//       a branch for rare strains). Bitwise response<3> where ordinary (tested for every law).
#pragma once
#include <type_traits>

#include <Eigen/Dense>

namespace emp {

template <int D> using Vec = Eigen::Matrix<double, D, 1>;
template <int D> using Mat = Eigen::Matrix<double, D, D>;

/// The split of one point's response: sigma+ and sigma- (Eq 7 with g = 1), psi+ and psi- (3, 4).
template <int D> struct LawResponse {
    Mat<D> sigmaPlus, sigmaMinus;
    double psiPlus, psiMinus;
};

/// Which compressive strain states a law promises to leave free of tensile energy (psi+ = 0).
enum class Compression {
    none,           ///< no promise: every strain has tensile energy
    hydrostatic,    ///< eps = -p I with p > 0
    allPrincipal    ///< every principal strain <= 0
};

/// Hooke's law sigma = lambda tr(eps) I + 2 mu eps (the unsplit law).
template <int D> inline Mat<D> hooke(const Mat<D>& eps, double lambda, double mu)
{
    return lambda * eps.trace() * Mat<D>::Identity() + 2.0 * mu * eps;
}

/// psi = lambda/2 tr(eps)^2 + mu eps:eps (the unsplit energy).
template <int D> inline double strainEnergy(const Mat<D>& eps, double lambda, double mu)
{
    const double tr = eps.trace();
    return 0.5 * lambda * tr * tr + mu * eps.squaredNorm();
}

/// Whether law L offers the optional pointwise 2D response (response2).
template <class L, class = void> struct HasResponse2 : std::false_type {};
template <class L> struct HasResponse2<L, std::void_t<decltype(&L::response2)>> : std::true_type {};
/// Whether law L offers the optional pointwise 3D response (response3).
template <class L, class = void> struct HasResponse3 : std::false_type {};
template <class L> struct HasResponse3<L, std::void_t<decltype(&L::response3)>> : std::true_type {};
/// Whether law L offers the pointwise response of dimension D.
template <int D, class L> constexpr bool hasPointwiseResponse = D == 2 ? HasResponse2<L>::value : HasResponse3<L>::value;

inline double positivePart(double x) { return x > 0 ? x : 0.0; }
inline double negativePart(double x) { return x < 0 ? x : 0.0; }

}  // namespace emp
