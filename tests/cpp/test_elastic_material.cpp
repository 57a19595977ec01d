// Properties of the elastic law and of the spectral tension/compression split (paper Eqs 2-7):
// Lame constants of the 3D, plane-strain and plane-stress laws, psi = psi+ + psi-, Hooke's law
// for sigma+ + sigma-, signs, sigma+- = d psi+- / d eps, objectivity and repeated eigenvalues.
#include "ElasticMaterial.hpp"
#include "test_helpers.hpp"

namespace {

using emp::ElasticMaterial;
using emptest::hooke;
using emptest::Mat;
using emptest::Vec;

double psiTotal(const Mat<2>& e, double l, double m) { return 0.5 * l * e.trace() * e.trace() + m * (e * e).trace(); }
double psiTotal(const Mat<3>& e, double l, double m) { return 0.5 * l * e.trace() * e.trace() + m * (e * e).trace(); }

TEST(ElasticMaterial, LameConstantsGiveHookesLawIn3D)
{
    const double E = 2.5e10, nu = 0.27;
    const ElasticMaterial m = ElasticMaterial::make(E, nu, 2400, false, 3, emp::lawIndex("spectral"));
    EXPECT_FALSE(m.planeStress);
    // Uniaxial stress: strain (e, -nu e, -nu e) gives sigma = (E e, 0, 0).
    const double e = 1e-4;
    const Mat<3> eps = Vec<3>(e, -nu * e, -nu * e).asDiagonal();
    const Mat<3> sig = hooke<3>(eps, m.lambda, m.mu);
    EXPECT_NEAR(sig(0, 0), E * e, 1e-9 * E * e);
    EXPECT_NEAR(sig(1, 1), 0.0, 1e-9 * E * e);
    EXPECT_NEAR(sig(2, 2), 0.0, 1e-9 * E * e);
    // Pure shear: sigma_xy = E / (2 (1 + nu)) * 2 eps_xy.
    EXPECT_NEAR(m.mu, E / (2 * (1 + nu)), 1e-12 * E);
    // Dilatational wave speed sqrt(E (1 - nu) / ((1 + nu)(1 - 2 nu) rho)).
    EXPECT_NEAR(m.waveSpeed(), std::sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu) * 2400)), 1e-9 * m.waveSpeed());
    // planeStress is meaningless in 3D and must be ignored.
    const ElasticMaterial m3 = ElasticMaterial::make(E, nu, 2400, true, 3, emp::lawIndex("spectral"));
    EXPECT_FALSE(m3.planeStress);
    EXPECT_DOUBLE_EQ(m3.lambda, m.lambda);
}

TEST(ElasticMaterial, PlaneStrainAndPlaneStressLaws)
{
    const double E = 7e10, nu = 0.33, e = 2e-4;
    const ElasticMaterial strain = ElasticMaterial::make(E, nu, 2700, false, 2, emp::lawIndex("spectral"));
    const ElasticMaterial stress = ElasticMaterial::make(E, nu, 2700, true, 2, emp::lawIndex("spectral"));
    EXPECT_FALSE(strain.planeStress);
    EXPECT_TRUE(stress.planeStress);
    // Plane strain, eps = (e, 0): sigma_xx = E (1 - nu) e / ((1 + nu)(1 - 2 nu)), sigma_yy = nu/(1-nu) sigma_xx.
    const Mat<2> ex = Vec<2>(e, 0).asDiagonal();
    const Mat<2> s1 = hooke<2>(ex, strain.lambda, strain.mu);
    const double sxx = E * (1 - nu) * e / ((1 + nu) * (1 - 2 * nu));
    EXPECT_NEAR(s1(0, 0), sxx, 1e-9 * sxx);
    EXPECT_NEAR(s1(1, 1), nu / (1 - nu) * sxx, 1e-9 * sxx);
    // Plane stress: sigma = E / (1 - nu^2) (eps_xx + nu eps_yy, eps_yy + nu eps_xx).
    const Mat<2> exy = Vec<2>(e, -0.4 * e).asDiagonal();
    const Mat<2> s2 = hooke<2>(exy, stress.lambda, stress.mu);
    const double c = E / (1 - nu * nu);
    EXPECT_NEAR(s2(0, 0), c * (e - nu * 0.4 * e), 1e-9 * E * e);
    EXPECT_NEAR(s2(1, 1), c * (-0.4 * e + nu * e), 1e-9 * E * e);
    // Uniaxial stress in plane stress: (e, -nu e) gives (E e, 0).
    const Mat<2> s3 = hooke<2>(Mat<2>(Vec<2>(e, -nu * e).asDiagonal()), stress.lambda, stress.mu);
    EXPECT_NEAR(s3(0, 0), E * e, 1e-9 * E * e);
    EXPECT_NEAR(s3(1, 1), 0.0, 1e-9 * E * e);
    EXPECT_NEAR(stress.waveSpeed(), std::sqrt(E / ((1 - nu * nu) * 2700)), 1e-9 * stress.waveSpeed());
}

template <class Dim> struct SplitTest : ::testing::Test {};
using Dims = ::testing::Types<std::integral_constant<int, 2>, std::integral_constant<int, 3>>;
TYPED_TEST_SUITE(SplitTest, Dims);

/// The spectral split of a material with Lame constants l and m.
template <int D> emp::LawResponse<D> split(const Mat<D>& eps, double l, double m)
{
    emp::ElasticMaterial mat;
    mat.lambda = l;
    mat.mu = m;
    return emp::SpectralSplit::response<D>(eps, mat);
}

/// Random Lame constants covering negative lambda (nu < 0) and plane stress.
std::pair<double, double> randomLame(std::mt19937& rng, int dim)
{
    std::uniform_real_distribution<double> unu(-0.9, 0.49), uE(0.5, 3.0);
    std::uniform_int_distribution<int> coin(0, 1);
    const ElasticMaterial m = ElasticMaterial::make(uE(rng), unu(rng), 1.0, coin(rng) == 1, dim, emp::lawIndex("spectral"));
    return {m.lambda, m.mu};
}

TYPED_TEST(SplitTest, PartsAddUpToTheUnsplitLawAndAreNonNegative)
{
    constexpr int D = TypeParam::value;
    std::mt19937 rng(100 + D);
    for (int i = 0; i < 3000; ++i) {
        const auto [l, m] = randomLame(rng, D);
        const Mat<D> eps = emptest::randomSymmetric<D>(rng, i % 2 ? 1e-3 : 1.0);
        const auto s = split<D>(eps, l, m);
        const double psi = psiTotal(eps, l, m);
        const double scale = (std::fabs(l) + m) * eps.squaredNorm();
        EXPECT_NEAR(s.psiPlus + s.psiMinus, psi, 1e-12 * scale) << eps;
        EXPECT_GE(s.psiPlus, -1e-14 * scale);
        EXPECT_GE(s.psiMinus, -1e-14 * scale);
        const Mat<D> sig = hooke<D>(eps, l, m);
        EXPECT_LT((s.sigmaPlus + s.sigmaMinus - sig).norm(), 1e-12 * (std::fabs(l) + m) * eps.norm()) << eps;
        // Symmetric parts.
        EXPECT_LT((s.sigmaPlus - s.sigmaPlus.transpose()).norm(), 1e-13 * (std::fabs(l) + m) * eps.norm());
        // Euler's theorem for functions homogeneous of degree 2: sigma+- : eps = 2 psi+-.
        EXPECT_NEAR((s.sigmaPlus.array() * eps.array()).sum(), 2 * s.psiPlus, 1e-11 * scale) << eps;
        EXPECT_NEAR((s.sigmaMinus.array() * eps.array()).sum(), 2 * s.psiMinus, 1e-11 * scale) << eps;
    }
}

TYPED_TEST(SplitTest, CompressionHasNoTensilePartAndTensionNoCompressivePart)
{
    constexpr int D = TypeParam::value;
    std::mt19937 rng(200 + D);
    std::uniform_real_distribution<double> u(0.1, 2.0);
    for (int i = 0; i < 1000; ++i) {
        const auto [l, m] = randomLame(rng, D);
        const Mat<D> R = emptest::randomRotation<D>(rng);
        Vec<D> k;
        for (int d = 0; d < D; ++d) k[d] = u(rng) * 1e-3;
        const Mat<D> tension = R * k.asDiagonal() * R.transpose();
        const Mat<D> compression = -tension;
        const auto c = split<D>(compression, l, m);
        EXPECT_EQ(c.psiPlus, 0.0);
        EXPECT_EQ(c.sigmaPlus.cwiseAbs().maxCoeff(), 0.0) << c.sigmaPlus;
        EXPECT_GT(c.psiMinus, 0.0);
        const auto t = split<D>(tension, l, m);
        EXPECT_EQ(t.psiMinus, 0.0);
        EXPECT_EQ(t.sigmaMinus.cwiseAbs().maxCoeff(), 0.0) << t.sigmaMinus;
        EXPECT_GT(t.psiPlus, 0.0);
    }
}

/// Central difference of psi+ (or psi-) in the symmetric direction (i, j).
template <int D> Mat<D> numericalStress(const Mat<D>& eps, double l, double m, bool plus, double t)
{
    Mat<D> out;
    for (int i = 0; i < D; ++i)
        for (int j = 0; j < D; ++j) {
            Mat<D> dir = Mat<D>::Zero();
            dir(i, j) += 0.5;
            dir(j, i) += 0.5;
            const auto a = split<D>(eps + t * dir, l, m), b = split<D>(eps - t * dir, l, m);
            out(i, j) = plus ? (a.psiPlus - b.psiPlus) / (2 * t) : (a.psiMinus - b.psiMinus) / (2 * t);
        }
    return out;
}

TYPED_TEST(SplitTest, StressPartsAreDerivativesOfEnergyParts)
{
    constexpr int D = TypeParam::value;
    std::mt19937 rng(300 + D);
    std::uniform_real_distribution<double> u(0.3, 1.5);
    for (int i = 0; i < 200; ++i) {
        const auto [l, m] = randomLame(rng, D);
        const Mat<D> R = emptest::randomRotation<D>(rng);
        Vec<D> k;
        // Mixed signs, distinct principal strains, trace of either sign.
        k[0] = u(rng);
        k[1] = -u(rng);
        if (D == 3) k[D - 1] = (i % 2 ? 1 : -1) * (2.0 + u(rng));
        const Mat<D> eps = R * k.asDiagonal() * R.transpose();
        const auto s = split<D>(eps, l, m);
        const double tol = 1e-7 * (std::fabs(l) + m) * eps.norm();
        EXPECT_LT((numericalStress<D>(eps, l, m, true, 1e-6) - s.sigmaPlus).norm(), tol)
            << "eps =\n" << eps << "\nsigma+ =\n" << s.sigmaPlus;
        EXPECT_LT((numericalStress<D>(eps, l, m, false, 1e-6) - s.sigmaMinus).norm(), tol)
            << "eps =\n" << eps << "\nsigma- =\n" << s.sigmaMinus;
    }
}

TYPED_TEST(SplitTest, SplitIsObjective)
{
    constexpr int D = TypeParam::value;
    std::mt19937 rng(400 + D);
    for (int i = 0; i < 500; ++i) {
        const auto [l, m] = randomLame(rng, D);
        const Mat<D> eps = emptest::randomSymmetric<D>(rng, 1.0);
        const Mat<D> R = emptest::randomRotation<D>(rng);
        const auto a = split<D>(eps, l, m);
        const auto b = split<D>(Mat<D>(R * eps * R.transpose()), l, m);
        const double tol = 1e-11 * (std::fabs(l) + m) * eps.norm();
        EXPECT_LT((R * a.sigmaPlus * R.transpose() - b.sigmaPlus).norm(), tol);
        EXPECT_LT((R * a.sigmaMinus * R.transpose() - b.sigmaMinus).norm(), tol);
        EXPECT_NEAR(a.psiPlus, b.psiPlus, tol * eps.norm());
    }
}

/// Expected split from known principal strains k and axes R.
template <int D> void checkKnownSplit(const Vec<D>& k, const Mat<D>& R, double l, double m)
{
    const Mat<D> eps = R * k.asDiagonal() * R.transpose();
    const Vec<D> kp = k.cwiseMax(0.0), km = k.cwiseMin(0.0);
    const double tr = k.sum(), trp = std::max(tr, 0.0), trm = std::min(tr, 0.0);
    const Mat<D> epsPlus = R * kp.asDiagonal() * R.transpose();
    const Mat<D> sigPlus = l * trp * Mat<D>::Identity() + 2 * m * epsPlus;
    const Mat<D> sigMinus = l * trm * Mat<D>::Identity() + 2 * m * (eps - epsPlus);
    const double psiPlus = 0.5 * l * trp * trp + m * kp.squaredNorm();
    const double psiMinus = 0.5 * l * trm * trm + m * km.squaredNorm();
    const auto s = split<D>(eps, l, m);
    const double scale = (std::fabs(l) + m) * k.norm();
    // Round-off level: an eigen-decomposition of a symmetric 3x3 matrix is accurate to ~1e-15
    // relative, repeated eigenvalues included (the projector on a repeated pair is well defined).
    EXPECT_LE((s.sigmaPlus - sigPlus).norm(), 1e-12 * scale)
        << "k = " << k.transpose() << ", relative error " << (s.sigmaPlus - sigPlus).norm() / scale << "\n" << eps;
    EXPECT_LE((s.sigmaMinus - sigMinus).norm(), 1e-12 * scale)
        << "k = " << k.transpose() << ", relative error " << (s.sigmaMinus - sigMinus).norm() / scale;
    EXPECT_NEAR(s.psiPlus, psiPlus, 1e-12 * scale * k.norm()) << "k = " << k.transpose();
    EXPECT_NEAR(s.psiMinus, psiMinus, 1e-12 * scale * k.norm()) << "k = " << k.transpose();
}

TEST(SpectralSplit, RepeatedPrincipalStrains3D)
{
    std::mt19937 rng(501);
    const double a = 1.3e-3, b = 0.7e-3, l = 1.2, m = 0.9;
    const std::vector<Vec<3>> cases = {
        {a, a, -b}, {a, -b, -b}, {-b, a, a}, {a, a, a}, {-b, -b, -b}, {a, 0.0, -b},
        {a, a, 0.0}, {0.0, 0.0, -b}, {0.0, 0.0, 0.0}, {a, a * (1 + 1e-9), -b}, {a, -b, -b * (1 - 1e-9)},
        {a, a, -3 * a},  // zero trace
    };
    for (const Vec<3>& k : cases) {
        checkKnownSplit<3>(k, Mat<3>::Identity(), l, m);
        for (int r = 0; r < 20; ++r) checkKnownSplit<3>(k, emptest::randomRotation<3>(rng), l, m);
    }
}

TEST(SpectralSplit, RepeatedPrincipalStrains2D)
{
    std::mt19937 rng(502);
    const double a = 1.3e-3, b = 0.7e-3, l = 1.2, m = 0.9;
    const std::vector<Vec<2>> cases = {{a, a}, {-b, -b}, {a, -b}, {a, 0.0}, {0.0, -b}, {0.0, 0.0}, {a, -a}, {a, a * (1 + 1e-9)}};
    for (const Vec<2>& k : cases) {
        checkKnownSplit<2>(k, Mat<2>::Identity(), l, m);
        for (int r = 0; r < 20; ++r) checkKnownSplit<2>(k, emptest::randomRotation<2>(rng), l, m);
    }
}

}  // namespace
