// Patch tests of the strain update (paper Eq 27) and the material law (Eqs 2-7) through the
// Solver: a homogeneous velocity gradient A (v = A x) gives every point the strain increment
// dt sym(A), and the stress is Hooke's law of that strain (3D, plane strain, plane stress,
// uniaxial stress).
#include "test_helpers.hpp"

namespace {

using emp::GimpKernel;
using emp::LinearKernel;
using emp::Solver;
using emptest::hooke;
using emptest::Mat;
using emptest::to3;
using emptest::Vec;

using emptest::Config;
template <class C> struct PatchTest : ::testing::Test {};
using Configs = emptest::AllSolvers;
TYPED_TEST_SUITE(PatchTest, Configs);

constexpr double kE = 2e9, kRho = 2000, kH = 0.05;

/// Closed-form stress of a small strain (not computed from the solver's Lame constants).
template <int D> Mat<D> closedFormStress(const Mat<D>& eps, double E, double nu, bool planeStress)
{
    const double G = E / (2 * (1 + nu));
    if (D == 2 && planeStress) {
        Mat<D> s = Mat<D>::Zero();
        s(0, 0) = E / (1 - nu * nu) * (eps(0, 0) + nu * eps(1, 1));
        s(1, 1) = E / (1 - nu * nu) * (eps(1, 1) + nu * eps(0, 0));
        s(0, 1) = s(1, 0) = 2 * G * eps(0, 1);
        return s;
    }
    // 3D and plane strain: sigma = E/((1+nu)(1-2nu)) [(1-nu) eps_ii + nu (others)] on the diagonal.
    const double c = E / ((1 + nu) * (1 - 2 * nu));
    Mat<D> s;
    for (int i = 0; i < D; ++i)
        for (int j = 0; j < D; ++j) s(i, j) = i == j ? c * ((1 - nu) * eps(i, i) + nu * (eps.trace() - eps(i, i))) : 2 * G * eps(i, j);
    return s;
}

/// One step of a block of ppc^D points per cell whose grid velocity is prescribed node by node
/// as v_I = A x_I (one velocity condition per node). Checks strain, stress and positions of all
/// points. Returns the solver for further checks.
template <int D, class K>
void runPrescribedGradient(const Mat<D>& A, double nu, bool planeStress, int ppc, const std::string& what,
                           Mat<D>* stressOut = nullptr, Mat<D>* strainOut = nullptr)
{
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    st.ppc = ppc;
    Solver<D, K> s(st);
    const int mat = s.addMaterial(kE, nu, kRho, planeStress, emp::lawIndex("spectral"));
    std::array<int, D> lo, hi;
    lo.fill(3);
    hi.fill(D == 2 ? 9 : 6);
    emptest::addBlock<D>(s, lo, hi, mat);
    s.initialize();
    const auto& g = s.grid();
    for (int I = 0; I < g.numNodes(); ++I)
        s.addVelocityCondition({I}, {}, (1u << D) - 1, to3<D>(A * g.nodePosition(I)), 0.0);
    const auto& P = s.points();
    const std::vector<Vec<D>> x0 = P.x;
    const double dt = 0.5 * s.criticalTimeStep();
    s.step(dt, 1);
    const Mat<D> epsExpected = 0.5 * dt * (A + A.transpose());
    const Mat<D> sigExpected = closedFormStress<D>(epsExpected, kE, nu, planeStress);
    const double sigScale = kE * epsExpected.norm();
    for (std::size_t p = 0; p < P.size(); ++p) {
        ASSERT_LT((emp::full(P.strain[p]) - epsExpected).norm(), 1e-11 * epsExpected.norm())
            << what << ", ppc " << ppc << ": point " << p << " at " << x0[p].transpose() << "\nstrain\n"
            << emp::full(P.strain[p]) << "\nexpected\n" << epsExpected;
        ASSERT_LT((s.stressOf(p) - sigExpected).norm(), 1e-9 * sigScale)
            << what << ", ppc " << ppc << ": point " << p << "\nstress\n" << s.stressOf(p) << "\nexpected\n" << sigExpected;
        // Eq 31 with a linear nodal velocity field: x += dt A x.
        ASSERT_LT((P.x[p] - x0[p] - dt * A * x0[p]).norm(), 1e-12 * (dt * (A * x0[p]).norm()) + 1e-15 * x0[p].norm())
            << what << ", ppc " << ppc << ": point " << p;
    }
    if (stressOut) *stressOut = s.stressOf(0);
    if (strainOut) *strainOut = emp::full(P.strain[0]);
}

TYPED_TEST(PatchTest, PrescribedVelocityGradientGivesHookesLaw)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    std::mt19937 rng(71 + D);
    // A general gradient (stretch, shear and rotation), in tension and with mixed signs.
    for (int trial = 0; trial < 3; ++trial) {
        Mat<D> A;
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        for (int i = 0; i < D; ++i)
            for (int j = 0; j < D; ++j) A(i, j) = u(rng);
        if (trial == 0) A += 3.0 * Mat<D>::Identity();  // all principal strains positive
        for (int ppc = 1; ppc <= 3; ++ppc) {
            runPrescribedGradient<D, K>(A, 0.3, false, ppc, "general gradient (plane strain in 2D)");
            if (D == 2) runPrescribedGradient<D, K>(A, 0.3, true, ppc, "general gradient, plane stress");
        }
    }
}

TYPED_TEST(PatchTest, UniaxialStress)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    const double nu = 0.25, a = 2.0;
    // v = (a x, -nu a y[, -nu a z]): uniaxial stress in 3D and in plane stress.
    Mat<D> A = Mat<D>::Identity() * (-nu * a);
    A(0, 0) = a;
    Mat<D> sig, eps;
    runPrescribedGradient<D, K>(A, nu, true, 2, "uniaxial stress", &sig, &eps);
    // sigma_xx = E eps_xx, all other components zero.
    EXPECT_GT(eps(0, 0), 0.0);
    EXPECT_NEAR(sig(0, 0), kE * eps(0, 0), 1e-9 * kE * eps(0, 0));
    EXPECT_NEAR(eps(1, 1), -nu * eps(0, 0), 1e-12 * eps(0, 0));
    for (int i = 0; i < D; ++i)
        for (int j = 0; j < D; ++j)
            if (i || j) {
                EXPECT_NEAR(sig(i, j), 0.0, 1e-9 * sig(0, 0)) << "component " << i << j;
            }
}

TYPED_TEST(PatchTest, UniaxialStrainInPlaneStrainAnd3D)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    Mat<D> A = Mat<D>::Zero();
    A(0, 0) = -1.5;  // compression: the whole stress comes from sigma-
    runPrescribedGradient<D, K>(A, 0.2, false, 2, "uniaxial compression strain");
}

/// Point velocities v_p = A x_p (no boundary conditions): P2G gives v_I = A x_I at every node
/// surrounded symmetrically by points, so the points whose support has only such nodes get the
/// strain increment dt sym(A) exactly (the others sit near the free surface).
TYPED_TEST(PatchTest, LinearPointVelocityFieldIsReproducedInTheInterior)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    Mat<D> A = Mat<D>::Zero();
    A(0, 0) = 1.0;   // v = (a x, 0[, 0]) plus a shear
    A(1, 0) = 0.4;
    for (bool planeStress : {false, true}) {
        if (D == 3 && planeStress) continue;
        emp::SolverSettings st = emptest::typicalSettings();
        st.h = kH;
        st.ppc = 2;
        Solver<D, K> s(st);
        const double nu = 0.3;
        const int mat = s.addMaterial(kE, nu, kRho, planeStress, emp::lawIndex("spectral"));
        const int lo = 2, hi = D == 2 ? 14 : 10;
        std::array<int, D> clo, chi;
        clo.fill(lo);
        chi.fill(hi);
        emptest::addBlock<D>(s, clo, chi, mat, [&](const Vec<D>& x) { return Vec<D>(A * x); });
        const auto& P = s.points();
        const std::vector<Vec<D>> x0 = P.x;
        const double dt = 0.5 * s.criticalTimeStep();
        s.step(dt, 1);
        const Mat<D> epsExpected = 0.5 * dt * (A + A.transpose());
        const Mat<D> sigExpected = closedFormStress<D>(epsExpected, kE, nu, planeStress);
        int checked = 0;
        for (std::size_t p = 0; p < P.size(); ++p) {
            bool interior = true;
            for (int d = 0; d < D; ++d)
                interior = interior && x0[p][d] > (lo + 3) * kH && x0[p][d] < (hi - 3) * kH;
            if (!interior) continue;
            ++checked;
            ASSERT_LT((emp::full(P.strain[p]) - epsExpected).norm(), 1e-9 * epsExpected.norm())
                << "point " << p << " at " << x0[p].transpose() << "\n" << emp::full(P.strain[p]);
            ASSERT_LT((s.stressOf(p) - sigExpected).norm(), 1e-9 * kE * epsExpected.norm())
                << "point " << p << "\n" << s.stressOf(p) << "\nexpected\n" << sigExpected;
        }
        EXPECT_GT(checked, 10);
    }
}

}  // namespace
