// P2G and G2P through the Solver (paper Eqs 12, 13, 25-31): the stencil maps a point onto the
// nodes with the tensor-product weights, mass and momentum are conserved, the centre of mass
// moves with the total momentum, and a rigid translation is stress free.
#include "test_helpers.hpp"

namespace {

using emp::GimpKernel;
using emp::LinearKernel;
using emp::Solver;
using emptest::Mat;
using emptest::to3;
using emptest::Vec;

using emptest::Config;
template <class C> struct TransferTest : ::testing::Test {};
using Configs = emptest::AllSolvers;
TYPED_TEST_SUITE(TransferTest, Configs);

constexpr double kE = 1e6, kNu = 0.3, kRho = 1000, kH = 0.1;

double hat(double r) { return std::max(0.0, 1.0 - std::fabs(r)); }
double hatIntegral(double t)
{
    if (t <= -1) return 0.0;
    if (t <= 0) return 0.5 * (t + 1) * (t + 1);
    if (t <= 1) return 1.0 - 0.5 * (1 - t) * (1 - t);
    return 1.0;
}
/// Independent 1D weight: the hat (linear MPM) or the hat convolved with a box of half-width lp.
template <class K> double weight1D(double r, double lp)
{
    if constexpr (std::is_same_v<K, GimpKernel>)
        return (hatIntegral(r + lp) - hatIntegral(r - lp)) / (2 * lp);
    else
        return hat(r);
}

/// Random cloud of points in [2h, 6h]^D with random volumes and velocities, two materials.
template <int D, class K> void addRandomCloud(Solver<D, K>& s, std::mt19937& rng, int n, double vscale)
{
    const int m0 = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
    const int m1 = s.addMaterial(3 * kE, 0.2, 2 * kRho, false, emp::lawIndex("spectral"));
    std::uniform_real_distribution<double> ux(2 * kH, 6 * kH), uv(-vscale, vscale), uvol(0.5, 1.5);
    const double vol = std::pow(kH / s.settings().ppc, D);
    for (int p = 0; p < n; ++p) {
        Vec<D> x, v;
        for (int d = 0; d < D; ++d) {
            x[d] = ux(rng);
            v[d] = uv(rng);
        }
        s.addPoint(to3<D>(x), to3<D>(v), uvol(rng) * vol, p % 3 ? m0 : m1);
    }
}

TYPED_TEST(TransferTest, SinglePointIsSpreadWithTheTensorProductWeights)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int ppc = 1; ppc <= 4; ++ppc)
        for (int trial = 0; trial < 5; ++trial) {
            emp::SolverSettings st = emptest::typicalSettings();
            st.h = kH;
            st.ppc = ppc;
            typename TypeParam::S s(st);
            const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
            Vec<D> x, v;
            for (int d = 0; d < D; ++d) {
                // Trials 0 and 1 put the point on a node and on a cell face.
                x[d] = kH * (4 + (trial == 0 ? 0.0 : trial == 1 ? 0.5 : u(rng)));
                v[d] = 0.5 - u(rng);
            }
            const double vol = std::pow(kH / ppc, D);
            s.addPoint(to3<D>(x), to3<D>(v), vol, mat);
            const double mp = kRho * vol;
            s.step(1e-3 * s.criticalTimeStep(), 1);
            const auto& g = s.grid();
            const double lp = 0.5 / ppc;
            double total = 0;
            for (int I = 0; I < g.numNodes(); ++I) {
                const Vec<D> xI = g.nodePosition(I);
                EXPECT_EQ(g.nearestNode(xI), I);
                double N = 1;
                for (int d = 0; d < D; ++d) N *= weight1D<K>((x[d] - xI[d]) / kH, lp);
                EXPECT_NEAR(g.mass[I], N * mp, 1e-14 * mp) << "node " << I << " at " << xI.transpose();
                total += g.mass[I];
            }
            EXPECT_NEAR(total, mp, 1e-14 * mp);
        }
}

/// Mass, momentum and the motion of the centre of mass over several steps. With massCutoff = 0
/// every node that carries mass gets its force, so the internal forces sum to zero exactly.
TYPED_TEST(TransferTest, MassAndMomentumConservedOverSteps)
{
    constexpr int D = TypeParam::D;
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    st.ppc = 2;
    st.massCutoff = 0;
    typename TypeParam::S s(st);
    std::mt19937 rng(17 + D);
    addRandomCloud<D>(s, rng, D == 2 ? 300 : 400, 2.0);
    const auto& P = s.points();
    const double totalMass = emptest::sum(P.masses());
    const Vec<D> p0 = emptest::totalMomentum<D>(P);
    double scale = 0;  // momentum scale sum m |v|
    for (std::size_t p = 0; p < P.size(); ++p) scale += P.mass(p) * P.v[p].norm();
    for (int n = 0; n < 8; ++n) {
        const Vec<D> c0 = emptest::massMoment<D>(P);
        const double dt = 0.4 * s.criticalTimeStep();
        s.step(dt, 1);
        EXPECT_NEAR(emptest::sum(s.grid().mass), totalMass, 1e-13 * totalMass) << "step " << n;
        EXPECT_NEAR(emptest::sum(P.masses()), totalMass, 1e-13 * totalMass);
        const Vec<D> p1 = emptest::totalMomentum<D>(P);
        EXPECT_LT((p1 - p0).norm(), 1e-12 * scale) << "step " << n << ": momentum " << p0.transpose() << " -> "
                                                   << p1.transpose();
        Vec<D> gridMomentum = Vec<D>::Zero();
        for (const auto& q : s.grid().momentum) gridMomentum += q;
        EXPECT_LT((gridMomentum - p0).norm(), 1e-12 * scale) << "step " << n;
        // Eq 31: sum m_p x_p advances by dt * sum_I P_I^{n+1/2} = dt * total momentum.
        const Vec<D> c1 = emptest::massMoment<D>(P);
        EXPECT_LT(((c1 - c0) - dt * p1).norm(), 1e-12 * dt * scale + 1e-14 * c0.norm()) << "step " << n;
    }
    // Something did happen: the points have stresses.
    double maxStress = 0;
    for (std::size_t p = 0; p < P.size(); ++p) maxStress = std::max(maxStress, s.stressOf(p).norm());
    EXPECT_GT(maxStress, 0.0);
}

/// The default small-mass cut-off drops the forces of a few nearly empty nodes; one step with a
/// tiny dt (zero initial strain, so forces are O(dt)) still conserves momentum to round-off.
TYPED_TEST(TransferTest, MomentumConservedInOneTinyStepWithDefaultCutoff)
{
    constexpr int D = TypeParam::D;
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    st.ppc = 2;
    typename TypeParam::S s(st);
    std::mt19937 rng(27 + D);
    addRandomCloud<D>(s, rng, 300, 2.0);
    const auto& P = s.points();
    const double totalMass = emptest::sum(P.masses());
    const Vec<D> p0 = emptest::totalMomentum<D>(P);
    double scale = 0;
    for (std::size_t p = 0; p < P.size(); ++p) scale += P.mass(p) * P.v[p].norm();
    s.step(1e-4 * s.criticalTimeStep(), 2);
    EXPECT_NEAR(emptest::sum(s.grid().mass), totalMass, 1e-13 * totalMass);
    EXPECT_LT((emptest::totalMomentum<D>(P) - p0).norm(), 1e-12 * scale);
}

/// All points share one velocity: the grid reproduces it, no strain and no stress appear, the
/// velocity is kept and every point moves by v dt.
TYPED_TEST(TransferTest, RigidTranslationIsStressFree)
{
    constexpr int D = TypeParam::D;
    std::mt19937 rng(37 + D);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    for (int ppc = 1; ppc <= 3; ++ppc) {
        emp::SolverSettings st = emptest::typicalSettings();
        st.h = kH;
        st.ppc = ppc;
        typename TypeParam::S s(st);
        const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
        Vec<D> v0;
        for (int d = 0; d < D; ++d) v0[d] = u(rng);
        std::array<int, D> lo, hi;
        lo.fill(2);
        hi.fill(D == 2 ? 8 : 5);
        emptest::addBlock<D>(s, lo, hi, mat, [&](const Vec<D>&) { return v0; });
        const auto& P = s.points();
        for (int n = 0; n < 10; ++n) {
            const std::vector<Vec<D>> x0 = P.x;
            const double dt = 0.5 * s.criticalTimeStep();
            s.step(dt, 1);
            // Stress that a velocity difference |v0| across one cell would produce in dt.
            const double sigmaScale = kE * v0.norm() * dt / kH;
            for (std::size_t p = 0; p < P.size(); ++p) {
                ASSERT_LT(s.stressOf(p).norm(), 1e-11 * sigmaScale)
                    << "ppc " << ppc << ", step " << n << ", point " << p << " at " << x0[p].transpose();
                ASSERT_LT((P.v[p] - v0).norm(), 1e-12 * v0.norm()) << "ppc " << ppc << ", step " << n << ", point " << p;
                ASSERT_LT((P.x[p] - x0[p] - v0 * dt).norm(), 1e-12 * v0.norm() * dt + 1e-15 * x0[p].norm())
                    << "ppc " << ppc << ", step " << n << ", point " << p;
            }
        }
    }
}

/// A rigid translation whose first step ends with the block's leading edge a hair inside the
/// support of the next row of nodes, so that these nodes get a mass below the small-mass
/// cut-off (settings().massCutoff of the mean point mass). The translation must still be stress
/// free: the nodal velocity P_I / m_I is a weighted mean of the point velocities, whatever m_I.
/// (A node below the cut-off that is given velocity 0 while its shape-function gradients still
/// enter Eq 27 breaks sum_I grad N_Ip = 0 and strains the block by ~sqrt(massCutoff).)
TYPED_TEST(TransferTest, RigidTranslationIsStressFreeWhenNodesAreNearlyEmpty)
{
    constexpr int D = TypeParam::D;
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    st.ppc = 2;
    typename TypeParam::S s(st);
    const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
    Vec<D> v0 = Vec<D>::Zero();
    v0[0] = 1.0;
    std::array<int, D> lo, hi;
    lo.fill(2);
    hi.fill(D == 2 ? 8 : 5);
    emptest::addBlock<D>(s, lo, hi, mat, [&](const Vec<D>&) { return v0; });
    const auto& P = s.points();
    // The last layer of points sits 1.25 h (= 1 + lp cells) from the next row of nodes. A move
    // by q h gives these nodes the GIMP weight q^2 / (4 lp) = 1e-3 massCutoff per point.
    const double lp = 0.25;
    const double q = std::sqrt(4 * lp * 1e-3 * std::max(st.massCutoff, 1e-300));
    const double dt = q * kH / v0.norm();
    ASSERT_LT(dt, s.criticalTimeStep());
    for (int n = 0; n < 3; ++n) {
        const std::vector<Vec<D>> x0 = P.x;
        s.step(dt, 1);
        const double sigmaScale = kE * v0.norm() * dt / kH;
        double worst = 0;
        for (std::size_t p = 0; p < P.size(); ++p) worst = std::max(worst, s.stressOf(p).norm());
        EXPECT_LT(worst, 1e-11 * sigmaScale) << "step " << n << ": largest |sigma| = " << worst << " Pa, "
                                             << worst / sigmaScale << " of E |v| dt / h";
        for (std::size_t p = 0; p < P.size(); ++p)
            ASSERT_LT((P.x[p] - x0[p] - v0 * dt).norm(), 1e-12 * v0.norm() * dt + 1e-15 * x0[p].norm())
                << "step " << n << ", point " << p;
    }
}

}  // namespace
