#include "ElasticMaterial.hpp"

#include <cmath>

#include "Errors.hpp"

namespace emp {

ElasticMaterial ElasticMaterial::make(double E, double nu, double rho, bool planeStress, int dim)
{
    require(std::isfinite(E) && E > 0, "E (Young's modulus, Pa)", E, "E > 0");
    require(std::isfinite(nu) && nu > -1.0 && nu < 0.5, "nu (Poisson's ratio)", nu, "-1 < nu < 0.5");
    require(std::isfinite(rho) && rho > 0, "rho (density, kg/m3)", rho, "rho > 0");
    ElasticMaterial m;
    m.E = E;
    m.nu = nu;
    m.rho = rho;
    m.planeStress = planeStress && dim == 2;
    m.mu = E / (2.0 * (1.0 + nu));
    m.lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    if (m.planeStress) m.lambda = 2.0 * m.lambda * m.mu / (m.lambda + 2.0 * m.mu);
    return m;
}

double ElasticMaterial::waveSpeed() const { return std::sqrt((lambda + 2.0 * mu) / rho); }

namespace {
inline double pos(double x) { return x > 0 ? x : 0.0; }
inline double neg(double x) { return x < 0 ? x : 0.0; }

// Principal strains and the tensile part eps+ (Eq 5). Fast paths avoid the eigenvectors when
// all principal strains have one sign, which is nearly every point in most scenes.
template <int D> void tensilePart(const Mat<D>& eps, Vec<D>& principal, Mat<D>& epsPlus);

template <> void tensilePart<2>(const Mat<2>& e, Vec<2>& l, Mat<2>& ep)
{
    const double m = 0.5 * (e(0, 0) + e(1, 1));
    const double d = 0.5 * (e(0, 0) - e(1, 1));
    const double r = std::sqrt(d * d + e(0, 1) * e(0, 1));
    l << m + r, m - r;
    if (l(1) >= 0) {
        ep = e;
    } else if (l(0) <= 0) {
        ep.setZero();
    } else {
        // l0 > 0 > l1, so the eigenvalues differ and the projector on n0 is (e - l1 I)/(l0 - l1).
        ep = (l(0) / (l(0) - l(1))) * (e - l(1) * Mat<2>::Identity());
    }
}

template <> void tensilePart<3>(const Mat<3>& e, Vec<3>& l, Mat<3>& ep)
{
    // Eigenvalues in closed form (no eigenvectors). They are accurate to round-off of the
    // deviator except within a nearly repeated pair, whose two values can be off by ~1e-8 of
    // the deviator while their sum stays exact.
    Eigen::SelfAdjointEigenSolver<Mat<3>> es;
    es.computeDirect(e, Eigen::EigenvaluesOnly);
    l = es.eigenvalues();  // ascending
    const double spread = l(2) - l(0);
    if (!(spread > 0)) {  // e = l I exactly
        if (l(0) >= 0) ep = e; else ep.setZero();
        return;
    }
    // All principal strains clearly of one sign (by much more than that error): Eq 5 directly.
    const double margin = 1e-6 * spread;
    if (l(0) >= margin) {
        ep = e;
        return;
    }
    if (l(2) <= -margin) {
        ep.setZero();
        return;
    }
    // Mixed or nearly zero principal strains. The eigenvalue l_k farther from the other two is
    // accurate, and so is its spectral projector P_k = (e - l_a I)(e - l_b I)/((l_k - l_a)(l_k - l_b))
    // (the pair's errors cancel to second order). The pair lives in the plane Q = I - P_k as
    // B = e - l_k P_k; its values m -+ r come from the trace and the norm of B's deviator in the
    // plane, with no cancellation, so a repeated pair (even at zero) is split exactly.
    const int k = l(1) - l(0) >= l(2) - l(1) ? 0 : 2, a = k == 0 ? 1 : 0, b = k == 0 ? 2 : 1;
    const Mat<3> I = Mat<3>::Identity();
    const Mat<3> Pk = (e - l(a) * I) * (e - l(b) * I) / ((l(k) - l(a)) * (l(k) - l(b)));
    const Mat<3> Q = I - Pk;
    const Mat<3> B = e - l(k) * Pk;
    const double m = 0.5 * (e.trace() - l(k));
    const double r = std::sqrt(0.5 * (B - m * Q).squaredNorm());
    const double lminus = m - r, lplus = m + r;
    ep = pos(l(k)) * Pk;
    if (lminus >= 0)
        ep += B;
    else if (lplus > 0)
        ep += (lplus / (2.0 * r)) * (B - lminus * Q);  // lplus times the projector on its vector
    l << l(k), lminus, lplus;  // only the set of values is used below
}
}  // namespace

template <int D> SplitState<D> spectralSplit(const Mat<D>& eps, double lambda, double mu)
{
    Vec<D> l;
    Mat<D> ep;
    tensilePart<D>(eps, l, ep);
    const Mat<D> em = eps - ep;  // Eq 6
    const double tr = eps.trace();
    double sp2 = 0, sm2 = 0;  // tr(eps+^2), tr(eps-^2) from the principal strains
    for (int i = 0; i < D; ++i) {
        sp2 += pos(l(i)) * pos(l(i));
        sm2 += neg(l(i)) * neg(l(i));
    }
    SplitState<D> s;
    s.psiPlus = 0.5 * lambda * pos(tr) * pos(tr) + mu * sp2;    // Eq 3
    s.psiMinus = 0.5 * lambda * neg(tr) * neg(tr) + mu * sm2;   // Eq 4
    s.sigmaPlus = lambda * pos(tr) * Mat<D>::Identity() + 2.0 * mu * ep;   // Eq 7
    s.sigmaMinus = lambda * neg(tr) * Mat<D>::Identity() + 2.0 * mu * em;
    return s;
}

template SplitState<2> spectralSplit<2>(const Mat<2>&, double, double);
template SplitState<3> spectralSplit<3>(const Mat<3>&, double, double);

}  // namespace emp
