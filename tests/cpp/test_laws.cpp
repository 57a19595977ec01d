// Typed tests of the constitutive laws (Law.hpp): every registered law (Laws.hpp) and the
// commented template (laws/TemplateLaw.hpp) pass them. A new law registered in Laws.hpp is
// picked up here with no edit. Properties, not tables:
//   - psi+ + psi- is the strain energy and sigma+ + sigma- is Hooke's law (the split only
//     splits); psi+ and psi- are non-negative;
//   - sigma+ and sigma- are the derivatives of psi+ and psi- (the split is hyperelastic);
//   - objectivity: rotating the strain rotates the stresses and keeps the energies;
//   - the promise `tensionFree` holds, and the split laws' promise is not empty;
//   - an eroded point keeps sigma-, which never pulls (negative semi-definite for nu >= 0);
//   - in the solver: the patch test (a homogeneous strain gives the law's stress at every
//     point) and a compressed block with a tiny Gc never erodes when the law promises it.
#include <algorithm>
#include <type_traits>
#include <vector>

#include "Laws.hpp"
#include "laws/TemplateLaw.hpp"
#include "test_helpers.hpp"

namespace {

using emp::Compression;
using emp::ElasticMaterial;
using emptest::Mat;
using emptest::Vec;

template <class... L> struct AppendTemplate;
template <class... L> struct AppendTemplate<emp::TypeList<L...>> {
    using type = ::testing::Types<L..., emp::TemplateLaw>;
};
/// Every registered law plus the template.
using TestedLaws = typename AppendTemplate<emp::RegisteredLaws>::type;

template <class L> struct LawTest : ::testing::Test {};
TYPED_TEST_SUITE(LawTest, TestedLaws);

/// The three plane conditions a law meets: 3D, 2D plane strain, 2D plane stress.
struct Case {
    int dim;
    bool planeStress;
    const char* name;
};
const Case kCases[] = {{3, false, "3D"}, {2, false, "plane strain"}, {2, true, "plane stress"}};

/// Calls check<D>(rng, case) for every plane condition, with D its dimension.
template <class F> void forEachCase(std::mt19937& rng, F&& check)
{
    for (const Case& c : kCases) {
        if (c.dim == 2) check(std::integral_constant<int, 2>{}, rng, c);
        else check(std::integral_constant<int, 3>{}, rng, c);
    }
}

ElasticMaterial material(std::mt19937& rng, const Case& c, double nuMin = -0.9)
{
    std::uniform_real_distribution<double> unu(nuMin, 0.49), uE(0.5, 3.0);
    // The law index is irrelevant here: the tests call the law's functions directly.
    return ElasticMaterial::make(uE(rng), unu(rng), 1.0 + uE(rng), c.planeStress, c.dim, 0);
}

template <class L, int D> void energyIdentities(std::mt19937& rng, const Case& c)
{
    for (int i = 0; i < 2000; ++i) {
        const ElasticMaterial m = material(rng, c);
        const Mat<D> eps = emptest::randomSymmetric<D>(rng, i % 2 ? 1e-3 : 1.0);
        const auto r = L::template response<D>(eps, m);
        const double scale = (std::fabs(m.lambda) + m.mu) * eps.squaredNorm();
        const double psi = emp::strainEnergy<D>(eps, m.lambda, m.mu);
        EXPECT_NEAR(r.psiPlus + r.psiMinus, psi, 1e-12 * scale) << L::name << ", " << c.name << "\n" << eps;
        EXPECT_GE(r.psiPlus, -1e-14 * scale) << L::name << ", " << c.name;
        EXPECT_GE(r.psiMinus, -1e-14 * scale) << L::name << ", " << c.name;
        const Mat<D> sigma = emp::hooke<D>(eps, m.lambda, m.mu);
        EXPECT_LT((r.sigmaPlus + r.sigmaMinus - sigma).norm(), 1e-12 * (std::fabs(m.lambda) + m.mu) * eps.norm())
            << L::name << ", " << c.name;
        EXPECT_LT((r.sigmaPlus - r.sigmaPlus.transpose()).norm(), 1e-14 * (std::fabs(m.lambda) + m.mu) * eps.norm());
    }
}

TYPED_TEST(LawTest, SplitPartsAddUpToTheStrainEnergyAndHookesLaw)
{
    std::mt19937 rng(11);
    forEachCase(rng, [](auto dim, std::mt19937& r, const Case& c) { energyIdentities<TypeParam, decltype(dim)::value>(r, c); });
}

template <class L, int D> void derivatives(std::mt19937& rng, const Case& c)
{
    // Central differences of psi+ and psi- along random symmetric directions: d psi = sigma : d eps.
    for (int i = 0; i < 300; ++i) {
        const ElasticMaterial m = material(rng, c);
        const Mat<D> eps = emptest::randomSymmetric<D>(rng, 1.0);
        const Mat<D> dir = emptest::randomSymmetric<D>(rng, 1.0);
        const double t = 1e-6;
        const auto a = L::template response<D>(Mat<D>(eps + t * dir), m);
        const auto b = L::template response<D>(Mat<D>(eps - t * dir), m);
        const auto r = L::template response<D>(eps, m);
        const double scale = (std::fabs(m.lambda) + m.mu) * eps.norm() * dir.norm();
        EXPECT_NEAR((a.psiPlus - b.psiPlus) / (2 * t), (r.sigmaPlus.cwiseProduct(dir)).sum(), 1e-6 * scale)
            << L::name << ", " << c.name;
        EXPECT_NEAR((a.psiMinus - b.psiMinus) / (2 * t), (r.sigmaMinus.cwiseProduct(dir)).sum(), 1e-6 * scale)
            << L::name << ", " << c.name;
    }
}

TYPED_TEST(LawTest, StressesAreTheDerivativesOfTheSplitEnergies)
{
    std::mt19937 rng(12);
    forEachCase(rng, [](auto dim, std::mt19937& r, const Case& c) { derivatives<TypeParam, decltype(dim)::value>(r, c); });
}

template <class L, int D> void objectivity(std::mt19937& rng, const Case& c)
{
    for (int i = 0; i < 300; ++i) {
        const ElasticMaterial m = material(rng, c);
        const Mat<D> eps = emptest::randomSymmetric<D>(rng, 1.0);
        const Mat<D> R = emptest::randomRotation<D>(rng);
        const auto a = L::template response<D>(eps, m);
        const auto b = L::template response<D>(Mat<D>(R * eps * R.transpose()), m);
        const double scale = (std::fabs(m.lambda) + m.mu) * eps.norm();
        EXPECT_LT((R * a.sigmaPlus * R.transpose() - b.sigmaPlus).norm(), 1e-11 * scale) << L::name << ", " << c.name;
        EXPECT_LT((R * a.sigmaMinus * R.transpose() - b.sigmaMinus).norm(), 1e-11 * scale) << L::name << ", " << c.name;
        EXPECT_NEAR(a.psiPlus, b.psiPlus, 1e-11 * scale * eps.norm()) << L::name << ", " << c.name;
    }
}

TYPED_TEST(LawTest, RotatingTheStrainRotatesTheStress)
{
    std::mt19937 rng(13);
    forEachCase(rng, [](auto dim, std::mt19937& r, const Case& c) { objectivity<TypeParam, decltype(dim)::value>(r, c); });
}

/// A compressive strain of the kind the law promises to keep free of tensile energy, or of any
/// kind (all principal strains negative) when it promises nothing.
template <int D> Mat<D> compression(std::mt19937& rng, Compression kind)
{
    std::uniform_real_distribution<double> u(0.1, 1.0);
    if (kind == Compression::hydrostatic) return -u(rng) * Mat<D>::Identity();
    const Mat<D> R = emptest::randomRotation<D>(rng);
    Vec<D> l;
    for (int d = 0; d < D; ++d) l[d] = -u(rng);
    return R * l.asDiagonal() * R.transpose();
}

template <class L, int D> void promise(std::mt19937& rng, const Case& c)
{
    // Plane strain: eps_zz = 0, so an in-plane -p I is not hydrostatic in 3D; the hydrostatic
    // promise is a 3D (or plane-stress) one.
    if (L::tensionFree == Compression::hydrostatic && c.dim == 2 && !c.planeStress) return;
    int withTension = 0;
    for (int i = 0; i < 200; ++i) {
        const ElasticMaterial m = material(rng, c, 0.0);
        const Mat<D> eps = compression<D>(rng, L::tensionFree);
        const auto r = L::template response<D>(eps, m);
        const double scale = (m.lambda + m.mu) * eps.squaredNorm();
        if (L::tensionFree == Compression::none) {
            withTension += r.psiPlus > 1e-6 * scale;
            continue;
        }
        EXPECT_LE(r.psiPlus, 1e-14 * scale) << L::name << ", " << c.name << ": tensile energy under\n" << eps;
        EXPECT_LT(r.sigmaPlus.norm(), 1e-12 * (m.lambda + m.mu) * eps.norm()) << L::name << ", " << c.name;
    }
    // A law that promises nothing must really have tensile energy in compression, else its
    // trait undersells it.
    if (L::tensionFree == Compression::none) EXPECT_GT(withTension, 0) << L::name << ", " << c.name;
}

TYPED_TEST(LawTest, CompressionTheLawPromisesToSpareHasNoTensileEnergy)
{
    std::mt19937 rng(14);
    forEachCase(rng, [](auto dim, std::mt19937& r, const Case& c) { promise<TypeParam, decltype(dim)::value>(r, c); });
}

template <class L, int D> void erodedStressNeverPulls(std::mt19937& rng, const Case& c)
{
    for (int i = 0; i < 1000; ++i) {
        const ElasticMaterial m = material(rng, c, 0.0);
        const Mat<D> eps = emptest::randomSymmetric<D>(rng, 1.0);
        const Mat<D> sm = L::template response<D>(eps, m).sigmaMinus;
        Eigen::SelfAdjointEigenSolver<Mat<D>> es(sm);
        EXPECT_LE(es.eigenvalues().maxCoeff(), 1e-12 * (m.lambda + m.mu) * eps.norm())
            << L::name << ", " << c.name << ": sigma- pulls\n" << sm;
    }
}

using emptest::bits;

/// 2D strains that take every path of a split: random ones of both signs and sizes, unequal
/// off-diagonal terms, the sign patterns one by one, repeated principal strains, zeros.
std::vector<Mat<2>> testStrains2D(std::mt19937& rng)
{
    std::vector<Mat<2>> out;
    std::uniform_real_distribution<double> u(-1, 1);
    for (int i = 0; i < 3000; ++i) {
        Mat<2> e = emptest::randomSymmetric<2>(rng, i % 3 == 0 ? 1e-3 : i % 3 == 1 ? 1.0 : 1e-200);
        if (i % 5 == 0) e(1, 0) += 1e-3 * e.norm() * u(rng);  // not quite symmetric
        out.push_back(e);
    }
    Mat<2> e;
    for (double a : {-2.0, -0.0, 0.0, 1e-300, 3.0})
        for (double b : {-1.0, -0.0, 0.0, 2.0})
            for (double s : {0.0, -0.0, 0.5}) {
                e << a, s, s, b;
                out.push_back(e);
            }
    return out;
}

TYPED_TEST(LawTest, PointwiseResponseIsBitwiseTheResponse2D)
{
    // A law's optional response2 (Law.hpp) is what the solver evaluates for runs of points;
    // response<2> is what every other stage uses. They must agree to the last bit.
    if constexpr (!emp::HasResponse2<TypeParam>::value) {
        GTEST_SKIP() << TypeParam::name << " has no pointwise 2D response";
    } else {
        std::mt19937 rng(23);
        const auto strains = testStrains2D(rng);
        for (const Case& cs : kCases) {
            if (cs.dim != 2) continue;
            for (std::size_t i = 0; i < strains.size(); ++i) {
                const ElasticMaterial m = material(rng, cs);
                const Mat<2>& e = strains[i];
                const double c = i % 4 == 0 ? 0.0 : i % 4 == 1 ? 1.0 : std::uniform_real_distribution<double>(0, 1)(rng);
                const auto r = TypeParam::template response<2>(e, m);
                const Mat<2> sigma = c * r.sigmaPlus + r.sigmaMinus;  // as the solver degrades it
                Mat<2> s;
                double pp, pm;
                TypeParam::response2(e(0, 0), e(0, 1), e(1, 0), e(1, 1), c, m.lambda, m.mu, s(0, 0), s(0, 1), s(1, 0),
                                     s(1, 1), pp, pm);
                for (int k = 0; k < 4; ++k) EXPECT_EQ(bits(s(k)), bits(sigma(k))) << cs.name << "\n" << e << "\nc = " << c;
                EXPECT_EQ(bits(pp), bits(r.psiPlus)) << cs.name << "\n" << e;
                EXPECT_EQ(bits(pm), bits(r.psiMinus)) << cs.name << "\n" << e;
            }
        }
    }
}

/// Symmetric 3D strains for the pointwise response: random ones at several scales (1e-200 and
/// 1e120 are not SpectralSplit::ordinary3), strains with repeated and zero principal values, and
/// special numbers.
std::vector<Mat<3>> testStrains3D(std::mt19937& rng)
{
    std::vector<Mat<3>> out;
    const double scales[] = {1e-3, 1.0, 1e-200, 1e120, 1e-120};
    for (int i = 0; i < 3000; ++i) out.push_back(emptest::randomSymmetric<3>(rng, scales[i % 5]));
    const double a = 1.3e-3, b = 0.7e-3;
    const std::vector<Vec<3>> principal = {{a, a, -b}, {a, -b, -b}, {a, a, a}, {-b, -b, -b}, {a, 0.0, -b}, {a, a, 0.0},
                                           {0.0, 0.0, -b}, {0.0, 0.0, 0.0}, {a, a * (1 + 1e-12), -b}, {a, a, -2 * a}};
    for (const Vec<3>& k : principal)
        for (int r = 0; r < 10; ++r) {
            const Mat<3> R = emptest::randomRotation<3>(rng);
            const Mat<3> e = R * k.asDiagonal() * R.transpose();
            out.push_back(0.5 * (e + e.transpose()));
        }
    Mat<3> e = Mat<3>::Zero();
    for (double d : {-0.0, 2.0, -1e-300}) {
        e.setConstant(-0.0);
        e.diagonal().setConstant(d);
        out.push_back(e);
    }
    return out;
}

TYPED_TEST(LawTest, PointwiseResponseIsBitwiseTheResponse3D)
{
    // response3 (Law.hpp) is what the solver's 3D stress pass evaluates for runs of points; a
    // point it calls not ordinary goes through response<3>, which every other stage uses. Where
    // ordinary, the two must agree to the last bit.
    if constexpr (!emp::HasResponse3<TypeParam>::value) {
        GTEST_SKIP() << TypeParam::name << " has no pointwise 3D response";
    } else {
        std::mt19937 rng(31);
        const auto strains = testStrains3D(rng);
        int ordinary = 0, other = 0;
        for (std::size_t i = 0; i < strains.size(); ++i) {
            const ElasticMaterial m = material(rng, kCases[0]);
            const Mat<3>& e = strains[i];
            const double c = i % 4 == 0 ? 0.0 : i % 4 == 1 ? 1.0 : std::uniform_real_distribution<double>(0, 1)(rng);
            const auto r = TypeParam::template response<3>(e, m);
            const Mat<3> sigma = c * r.sigmaPlus + r.sigmaMinus;  // as the solver degrades it
            double s[6], pp, pm;
            bool ok;
            TypeParam::response3(e(0, 0), e(1, 1), e(2, 2), e(1, 0), e(2, 0), e(2, 1), c, m.lambda, m.mu, s[0], s[1], s[2],
                                 s[3], s[4], s[5], pp, pm, ok);
            if (!ok) {
                ++other;
                continue;
            }
            ++ordinary;
            const int row[6] = {0, 1, 2, 1, 2, 2}, col[6] = {0, 1, 2, 0, 0, 1};
            for (int k = 0; k < 6; ++k) {
                EXPECT_EQ(bits(s[k]), bits(sigma(row[k], col[k]))) << e << "\nc = " << c;
                EXPECT_EQ(bits(s[k]), bits(sigma(col[k], row[k]))) << e << "\nc = " << c;
            }
            EXPECT_EQ(bits(pp), bits(r.psiPlus)) << e;
            EXPECT_EQ(bits(pm), bits(r.psiMinus)) << e;
        }
        EXPECT_GT(ordinary, 1200);
        EXPECT_GT(other, 1500);  // the strains at 1e-200, 1e120 and 1e-120
    }
}

TYPED_TEST(LawTest, StressOfASymmetricStrainIsBitwiseSymmetric2D)
{
    // A 2D point stores its strain and stress as three numbers (PointTensor.hpp). That loses
    // nothing only if each law's response to a symmetric strain is symmetric to the last bit,
    // in response<2> and in the pointwise response2, at every damage.
    std::mt19937 rng(29);
    for (const Case& cs : kCases) {
        if (cs.dim != 2) continue;
        for (Mat<2> e : testStrains2D(rng)) {
            e(1, 0) = e(0, 1);
            const ElasticMaterial m = material(rng, cs);
            const auto r = TypeParam::template response<2>(e, m);
            for (const double c : {0.0, 1.0, 0.37}) {
                const Mat<2> sigma = c * r.sigmaPlus + r.sigmaMinus;
                ASSERT_EQ(bits(sigma(0, 1)), bits(sigma(1, 0))) << cs.name << "\n" << e << "\nc = " << c;
                if constexpr (emp::HasResponse2<TypeParam>::value) {
                    double sxx, sxy, syx, syy, pp, pm;
                    TypeParam::response2(e(0, 0), e(0, 1), e(1, 0), e(1, 1), c, m.lambda, m.mu, sxx, sxy, syx, syy, pp, pm);
                    ASSERT_EQ(bits(sxy), bits(syx)) << cs.name << "\n" << e << "\nc = " << c;
                }
            }
        }
    }
}

TYPED_TEST(LawTest, StressOfAnErodedPointNeverPulls)
{
    std::mt19937 rng(15);
    forEachCase(rng, [](auto dim, std::mt19937& r, const Case& c) { erodedStressNeverPulls<TypeParam, decltype(dim)::value>(r, c); });
}

TYPED_TEST(LawTest, OutOfPlaneStressOfPlaneStrainAndWaveSpeed)
{
    using L = TypeParam;
    std::mt19937 rng(16);
    for (int i = 0; i < 200; ++i) {
        const ElasticMaterial strain = material(rng, kCases[1], 0.0), stress = material(rng, kCases[2], 0.0);
        const Mat<2> eps = emptest::randomSymmetric<2>(rng, 1.0);
        // Intact (c = 1): sigma_zz = lambda tr(eps) whatever the split; plane stress: 0.
        EXPECT_NEAR(L::outOfPlaneStress(eps, 1.0, strain), strain.lambda * eps.trace(),
                    1e-12 * (strain.lambda + strain.mu) * eps.norm()) << L::name;
        EXPECT_EQ(L::outOfPlaneStress(eps, 0.5, stress), 0.0) << L::name;
        EXPECT_NEAR(L::waveSpeed(strain), std::sqrt((strain.lambda + 2 * strain.mu) / strain.rho),
                    1e-12 * L::waveSpeed(strain)) << L::name;
    }
}

// --- the laws in the solver (registered laws only: a material selects one by index) ---------

template <class L> int registeredIndex() { return emp::lawIndex(L::name); }

template <class L, int D, class K> void patch(bool planeStress, const Mat<D>& A)
{
    const int law = registeredIndex<L>();
    ASSERT_GE(law, 0);
    emp::Solver<D, K> s(emptest::typicalSettings(0.01, 2));
    const int mat = s.addMaterial(2e7, 0.3, 1000, planeStress, law);
    std::array<int, D> lo, hi;
    lo.fill(3);
    hi.fill(D == 2 ? 8 : 6);
    emptest::addBlock<D>(s, lo, hi, mat);
    s.initialize();
    for (int I = 0; I < s.grid().numNodes(); ++I)
        s.addVelocityCondition({I}, {}, (1u << D) - 1, emptest::to3<D>(A * s.grid().nodePosition(I)), 0.0);
    const double dt = 0.5 * s.criticalTimeStep();
    s.step(dt, 1);
    const Mat<D> eps = 0.5 * dt * (A + A.transpose());
    const auto r = L::template response<D>(eps, s.materials()[mat]);
    const Mat<D> sigma = r.sigmaPlus + r.sigmaMinus;
    const auto& P = s.points();
    for (std::size_t p = 0; p < P.size(); ++p) {
        ASSERT_LT((emp::full(P.strain[p]) - eps).norm(), 1e-11 * eps.norm()) << L::name << ", point " << p;
        ASSERT_LT((s.stressOf(p) - sigma).norm(), 1e-9 * sigma.norm()) << L::name << ", point " << p;
        ASSERT_NEAR(P.energy[p], r.psiPlus + r.psiMinus, 1e-9 * (r.psiPlus + r.psiMinus)) << L::name << ", point " << p;
    }
}

template <class L> struct RegisteredLawTest : ::testing::Test {};
template <class... L> struct AsTypes;
template <class... L> struct AsTypes<emp::TypeList<L...>> {
    using type = ::testing::Types<L...>;
};
TYPED_TEST_SUITE(RegisteredLawTest, typename AsTypes<emp::RegisteredLaws>::type);

TYPED_TEST(RegisteredLawTest, PatchTestInTheSolver)
{
    std::mt19937 rng(17);
    for (int trial = 0; trial < 2; ++trial) {
        Mat<2> A2 = emptest::randomSymmetric<2>(rng, 1.0) + emptest::randomRotation<2>(rng);
        Mat<3> A3 = emptest::randomSymmetric<3>(rng, 1.0);
        patch<TypeParam, 2, emp::GimpKernel>(false, A2);
        patch<TypeParam, 2, emp::LinearKernel>(true, A2);
        patch<TypeParam, 3, emp::GimpKernel>(false, A3);
    }
}

/// Points eroded in a free block compressed by prescribed node velocities -r x for 20 steps,
/// with an erosion stage whose Gc is tiny (any tensile energy erodes).
template <int D> std::size_t erodedUnderCompression(int law, bool uniaxial)
{
    emp::Solver<D, emp::GimpKernel> s(emptest::typicalSettings(0.01, 2));
    const int mat = s.addMaterial(2e7, 0.25, 1000, D == 2, law);
    std::array<int, D> lo, hi;
    lo.fill(3);
    hi.fill(7);
    emptest::addBlock<D>(s, lo, hi, mat);
    s.initialize();
    Mat<D> A = -Mat<D>::Identity();
    if (uniaxial) {
        A.setZero();
        A(0, 0) = -1.0;
    }
    for (int I = 0; I < s.grid().numNodes(); ++I)
        s.addVelocityCondition({I}, {}, (1u << D) - 1, emptest::to3<D>(A * (s.grid().nodePosition(I) - Vec<D>::Constant(0.05))), 0.0);
    s.setErosion(std::make_shared<emp::EigenErosion<D>>(emp::ErosionSettings{1e-12, 2.0, 0.011}));
    const double dt = 0.5 * s.criticalTimeStep();
    for (int k = 0; k < 20; ++k) s.step(dt, 1);
    return s.erosion()->erodedCount();
}

TYPED_TEST(RegisteredLawTest, CompressionErodesOnlyWhereTheLawAllowsIt)
{
    using L = TypeParam;
    const int law = registeredIndex<L>();
    // Hydrostatic compression (3D; 2D plane stress, where the in-plane -p I is hydrostatic).
    const std::size_t hydro3 = erodedUnderCompression<3>(law, false), hydro2 = erodedUnderCompression<2>(law, false);
    // Uniaxial compression: every principal strain <= 0.
    const std::size_t uni3 = erodedUnderCompression<3>(law, true);
    if (L::tensionFree == Compression::allPrincipal) {
        EXPECT_EQ(hydro3 + hydro2 + uni3, 0u) << L::name;
    } else if (L::tensionFree == Compression::hydrostatic) {
        EXPECT_EQ(hydro3 + hydro2, 0u) << L::name;
        EXPECT_GT(uni3, 0u) << L::name << ": uniaxial compression has deviatoric energy";
    } else {
        EXPECT_GT(hydro3, 0u) << L::name << ": without a split compression erodes";
    }
}

}  // namespace

TEST(SpectralSplit3D, StrainsNearTheUnderflowLimitStayFinite)
{
    // A strain measured at the leading edge of a wave in a 3D block (1e-167: its squares
    // underflow). The split is homogeneous of degree one, so it must equal the split of the
    // same strain scaled by 2^600, scaled back (exactly: powers of two).
    Mat<3> e;
    e << -1.1297743482343185e-169, 2.6459623682349524e-169, -1.1156509394571967e-167,
        2.6459623682349524e-169, -5.7078050753008306e-169, 1.8831869776171252e-167,
        -1.1156509394571967e-167, 1.8831869776171252e-167, -1.3077761272082003e-167;
    Vec<3> l, lBig;
    Mat<3> ep, epBig;
    emp::SpectralSplit::tensilePart(e, l, ep);
    emp::SpectralSplit::tensilePart(std::ldexp(1.0, 600) * e, lBig, epBig);
    ASSERT_TRUE(ep.allFinite() && l.allFinite());
    EXPECT_EQ(ep, std::ldexp(1.0, -600) * epBig);
    EXPECT_GT(ep.cwiseAbs().maxCoeff(), 0.0);  // (norm() would underflow)
    // Subnormal strains (measured at h = 0.25 mm): finite, and again the scaled split.
    Mat<3> s;
    s << -4.3847247523105759e-316, 3.4946636632846807e-316, -4.3847247523105759e-316,
        3.4946636632846807e-316, -2.6046025248522208e-316, 3.4946636632846807e-316,
        -4.3847247523105759e-316, 3.4946636632846807e-316, -4.3847247523105759e-316;
    emp::SpectralSplit::tensilePart(s, l, ep);
    ASSERT_TRUE(ep.allFinite() && l.allFinite());
    emp::SpectralSplit::tensilePart(std::ldexp(1.0, 1000) * s, lBig, epBig);
    // (to the precision a subnormal carries: about 25 significant bits at 1e-316)
    EXPECT_LE((std::ldexp(1.0, 1000) * ep - epBig).cwiseAbs().maxCoeff(), 1e-5 * epBig.cwiseAbs().maxCoeff());
}

namespace {
/// eps+ = sum <l_i>+ n_i n_i from Eigen's iterative eigen-decomposition (QL, eigenvectors): an
/// independent reference for SpectralSplit's closed form.
Mat<3> eigenTensilePart(const Mat<3>& e, Vec<3>& l)
{
    const Eigen::SelfAdjointEigenSolver<Mat<3>> es(e);
    l = es.eigenvalues();
    Mat<3> ep = Mat<3>::Zero();
    for (int i = 0; i < 3; ++i) ep += std::max(l(i), 0.0) * es.eigenvectors().col(i) * es.eigenvectors().col(i).transpose();
    return ep;
}
}  // namespace

TEST(SpectralSplit3D, TensilePartIsThatOfTheEigenDecomposition)
{
    // The closed form (tensilePart3: no eigenvectors, no trigonometric function) against the
    // eigenvectors' sum, for random strains and strains with repeated principal values: the
    // principal strains (as a set) and eps+ to round-off of the strain's size.
    std::mt19937 rng(37);
    for (const Mat<3>& e : testStrains3D(rng)) {
        Vec<3> l, lr;
        Mat<3> ep;
        emp::SpectralSplit::tensilePart(e, l, ep);
        const Mat<3> epr = eigenTensilePart(e, lr);
        std::sort(l.data(), l.data() + 3);
        const double size = e.cwiseAbs().maxCoeff();
        EXPECT_LE((l - lr).cwiseAbs().maxCoeff(), 1e-14 * size) << e << "\n" << l.transpose() << "\n" << lr.transpose();
        EXPECT_LE((ep - epr).cwiseAbs().maxCoeff(), 1e-14 * size) << e << "\n" << ep << "\n" << epr;
    }
}

namespace {
/// The 2D tensile part as first written with Eigen (selects on the principal strains): the plain
/// reference of SpectralSplit::tensilePart2, which the solver runs for several points at once.
void referenceTensilePart(const Mat<2>& e, Vec<2>& l, Mat<2>& ep)
{
    const double m = 0.5 * (e(0, 0) + e(1, 1));
    const double d = 0.5 * (e(0, 0) - e(1, 1));
    const double r = std::sqrt(d * d + e(0, 1) * e(0, 1));
    l << m + r, m - r;
    const bool allTensile = l(1) >= 0, allCompressive = l(0) <= 0;
    const double q = l(0) / (allTensile || allCompressive ? 1.0 : l(0) - l(1));
    const double s = allTensile ? 1.0 : allCompressive ? 0.0 : q;
    const double shift = allTensile || allCompressive ? 0.0 : l(1);
    ep(0, 0) = s * (e(0, 0) - shift);
    ep(1, 1) = s * (e(1, 1) - shift);
    ep(0, 1) = s * e(0, 1);
    ep(1, 0) = s * e(1, 0);
}
}  // namespace

TEST(SpectralSplit2D, TensilePartIsBitwiseThePlainReference)
{
    std::mt19937 rng(29);
    for (const Mat<2>& e : testStrains2D(rng)) {
        Vec<2> l, lr;
        Mat<2> ep, epr;
        emp::SpectralSplit::tensilePart(e, l, ep);
        referenceTensilePart(e, lr, epr);
        for (int k = 0; k < 2; ++k) EXPECT_EQ(bits(l(k)), bits(lr(k))) << e;
        for (int k = 0; k < 4; ++k) EXPECT_EQ(bits(ep(k)), bits(epr(k))) << e;
    }
}

/// After a step of a vibrating 2D block, every point's stress (as the stress pass made it, and
/// stressOf), psi+, psi- are bitwise those of its material's law at its strain (degraded by its
/// damage): whether the stress pass evaluated the law for a whole run of points at once (a run
/// whose points share a law with response2) or point by point (a run mixing laws: blocks side by
/// side put several in one strip).
TEST(LawInTheSolver, RunsOfPointsGiveEachPointItsOwnLawBitwise)
{
    emp::Solver<2, emp::GimpKernel> s(emptest::typicalSettings(0.01, 2));
    const int spectral = emp::lawIndex("spectral"), volumetric = emp::lawIndex("volumetric");
    const int m0 = s.addMaterial(2e7, 0.25, 1000, false, spectral);
    const int m1 = s.addMaterial(3e7, 0.2, 1200, true, volumetric);
    const int m2 = s.addMaterial(1e7, 0.3, 900, true, spectral);
    const auto vel = [](const Vec<2>& x) { return Vec<2>(std::sin(40 * x[1]), std::cos(30 * x[0]) - 0.5); };
    emptest::addBlock<2>(s, {3, 3}, {6, 9}, m0, vel);
    emptest::addBlock<2>(s, {6, 3}, {7, 9}, m1, vel);
    emptest::addBlock<2>(s, {7, 3}, {12, 9}, m2, vel);
    s.initialize();
    auto& P = s.points();
    for (std::size_t p = 0; p < P.size(); p += 3) P.damage[p] = 0.5 * (p % 2);  // some damaged or eroded
    const auto made = emptest::recordStresses(s);
    const double dt = 0.5 * s.criticalTimeStep();
    for (int k = 0; k < 3; ++k) s.step(dt, 1);
    int tensile = 0;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const auto r = emp::lawResponse<2>(emp::full(P.strain[p]), s.materials()[P.material[p]]);
        const Mat<2> sigma = P.damage[p] * r.sigmaPlus + r.sigmaMinus;
        for (int k = 0; k < 4; ++k) ASSERT_EQ(bits((*made)[p](k)), bits(sigma(k))) << "point " << p;
        for (int k = 0; k < 4; ++k) ASSERT_EQ(bits(s.stressOf(p)(k)), bits(sigma(k))) << "point " << p;
        // (psi+ and psi- are the law's at the stored strain: Solver and _eigenmpm recompute them)
        ASSERT_EQ(bits(P.energy[p]), bits(P.damage[p] * r.psiPlus + r.psiMinus)) << "point " << p;
        tensile += r.psiPlus > 0 && r.psiMinus > 0;
    }
    EXPECT_GT(tensile, 10);  // mixed states: the split's every case is met
}

/// The same in 3D: the stress pass evaluates the spectral split for runs of points (lawOfRun3,
/// response3), the other laws point by point; each point's stress (the pass's, and stressOf) and
/// energy are bitwise its material's law at its strain.
TEST(LawInTheSolver, RunsOfPointsGiveEachPointItsOwnLawBitwise3D)
{
    emp::Solver<3, emp::GimpKernel> s(emptest::typicalSettings(0.01, 2));
    const int spectral = emp::lawIndex("spectral"), volumetric = emp::lawIndex("volumetric");
    const int m0 = s.addMaterial(2e7, 0.25, 1000, false, spectral);
    const int m1 = s.addMaterial(3e7, 0.2, 1200, false, volumetric);
    const int m2 = s.addMaterial(1e7, 0.3, 900, false, spectral);
    const auto vel = [](const Vec<3>& x) {
        return Vec<3>(std::sin(40 * x[1]), std::cos(30 * x[0]) - 0.5, std::sin(25 * x[2] + 30 * x[0]));
    };
    emptest::addBlock<3>(s, {3, 3, 3}, {5, 7, 6}, m0, vel);
    emptest::addBlock<3>(s, {5, 3, 3}, {6, 7, 6}, m1, vel);
    emptest::addBlock<3>(s, {6, 3, 3}, {9, 7, 6}, m2, vel);
    s.initialize();
    auto& P = s.points();
    for (std::size_t p = 0; p < P.size(); p += 3) P.damage[p] = 0.5 * (p % 2);  // some damaged or eroded
    const auto made = emptest::recordStresses(s);
    const double dt = 0.5 * s.criticalTimeStep();
    for (int k = 0; k < 3; ++k) s.step(dt, 1);
    int mixed = 0;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const auto r = emp::lawResponse<3>(P.strain[p], s.materials()[P.material[p]]);
        const Mat<3> sigma = P.damage[p] * r.sigmaPlus + r.sigmaMinus;
        for (int k = 0; k < 9; ++k) ASSERT_EQ(bits((*made)[p](k)), bits(sigma(k))) << "point " << p;
        for (int k = 0; k < 9; ++k) ASSERT_EQ(bits(s.stressOf(p)(k)), bits(sigma(k))) << "point " << p;
        ASSERT_EQ(bits(P.energy[p]), bits(P.damage[p] * r.psiPlus + r.psiMinus)) << "point " << p;
        mixed += r.psiPlus > 0 && r.psiMinus > 0;
    }
    EXPECT_GT(mixed, 10);  // mixed states: the split's every case is met
}
