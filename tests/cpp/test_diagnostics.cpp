// The diagnostics' sums over the points (Solver::diagnostics and the four functions that return
// its parts): within round-off of a plain sum in point order, written here as the reference;
// the same bits in every lane width; the four functions the same bits as diagnostics().
#include "test_helpers.hpp"

#include "Lanes.hpp"

namespace {

using emp::GimpKernel;
using emp::LinearKernel;
using emp::Solver;
using emptest::Mat;
using emptest::Vec;

/// A block with random velocities (one or two materials), 3 points more than a multiple of 8
/// (so that the sums' last, partial group is used), stepped a few times so that the points carry
/// elastic energy and, with APIC, an affine velocity of their own.
template <int D, class K> Solver<D, K> makeScene(emp::Transfer transfer, bool twoMaterials)
{
    emp::SolverSettings st = emptest::typicalSettings(0.05, 2);
    st.transfer = transfer;
    Solver<D, K> s(st);
    const int mat = s.addMaterial(1e6, 0.3, 1000, D == 2, emp::lawIndex("spectral"));
    const int soft = twoMaterials ? s.addMaterial(3e5, 0.1, 800, D == 2, emp::lawIndex("spectral")) : mat;
    std::array<int, D> lo, hi;
    lo.fill(3);
    hi.fill(D == 2 ? 15 : 7);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    const auto velocity = [&](const Vec<D>& x) {
        Vec<D> v;
        for (int d = 0; d < D; ++d) v[d] = u(rng);
        if constexpr (D == 2) v += 3.0 * Vec<2>(-x[1], x[0]);  // a spin, for the angular momentum
        return v;
    };
    emptest::addBlock<D>(s, lo, hi, mat, velocity);
    while (s.numGlobalPoints() % 8 != 3) {
        Vec<D> x = Vec<D>::Constant(0.3);
        x[0] += 0.01 * s.numGlobalPoints();
        s.addPoint(emptest::to3<D>(x), emptest::to3<D>(velocity(x)), 1e-4, mat);
    }
    for (int p = 0; p < s.numGlobalPoints(); p += 3) s.points().material[p] = soft;
    if (transfer == emp::Transfer::apic)
        for (int p = 0; p < s.numGlobalPoints(); p += 2) {
            Mat<D> C;
            for (int i = 0; i < D * D; ++i) C.data()[i] = 20 * u(rng);
            s.setVelocityGradient(p, C);
        }
    const double dt = 0.5 * s.criticalTimeStep();
    for (int n = 0; n < 5; ++n) s.step(dt, 1);
    return s;
}

/// One sum per quantity, point by point in id order, and the sum of its terms' magnitudes.
struct Plain {
    double kinetic = 0, elastic = 0;
    Eigen::Vector3d momentum = Eigen::Vector3d::Zero(), angular = Eigen::Vector3d::Zero();
    double kineticScale = 0, elasticScale = 0;
    Eigen::Vector3d momentumScale = Eigen::Vector3d::Zero(), angularScale = Eigen::Vector3d::Zero();
};

template <int D, class K> Plain plainSums(const Solver<D, K>& s)
{
    const auto& P = s.points();
    const bool apic = s.settings().transfer == emp::Transfer::apic;
    Plain r;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const double m = P.mass(p);
        Eigen::Vector3d x = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
        x.head<D>() = P.x[p];
        v.head<D>() = P.v[p];
        Eigen::Vector3d l = m * x.cross(v);
        if (apic) {  // m eps_abc B_cb
            Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
            B.topLeftCorner<D, D>() = P.affineVelocity[p];
            l += m * Eigen::Vector3d(B(2, 1) - B(1, 2), B(0, 2) - B(2, 0), B(1, 0) - B(0, 1));
        }
        const double k = 0.5 * m * v.squaredNorm(), e = P.volume[p] * P.energy[p];
        r.kinetic += k;
        r.elastic += e;
        r.momentum += m * v;
        r.angular += l;
        r.kineticScale += std::abs(k);
        r.elasticScale += std::abs(e);
        r.momentumScale += (m * v).cwiseAbs();
        r.angularScale += l.cwiseAbs();
    }
    return r;
}

template <int D, class K> void checkAgainstPlainSums(emp::Transfer transfer, bool twoMaterials)
{
    const Solver<D, K> s = makeScene<D, K>(transfer, twoMaterials);
    const auto d = s.diagnostics();
    const Plain r = plainSums(s);
    const double tol = 1e-13;
    ASSERT_GT(r.elastic, 0);  // (the scene is strained)
    EXPECT_NEAR(d.kinetic, r.kinetic, tol * r.kineticScale);
    EXPECT_NEAR(d.elastic, r.elastic, tol * r.elasticScale);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(d.momentum[c], r.momentum[c], tol * r.momentumScale[c]) << "component " << c;
        EXPECT_NEAR(d.angularMomentum[c], r.angular[c], tol * r.angularScale[c]) << "component " << c;
    }
    // The four functions return diagnostics()'s sums.
    EXPECT_EQ(emptest::bits(s.kineticEnergy()), emptest::bits(d.kinetic));
    EXPECT_EQ(emptest::bits(s.elasticEnergy()), emptest::bits(d.elastic));
    for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(emptest::bits(s.linearMomentum()[c]), emptest::bits(d.momentum[c]));
        EXPECT_EQ(emptest::bits(s.angularMomentum()[c]), emptest::bits(d.angularMomentum[c]));
    }
    if (D == 2) {  // (no x or y angular momentum, no z momentum: +0)
        EXPECT_EQ(emptest::bits(d.angularMomentum[0]), 0u);
        EXPECT_EQ(emptest::bits(d.angularMomentum[1]), 0u);
        EXPECT_EQ(emptest::bits(d.momentum[2]), 0u);
    }
}

template <int D, class K> void checkLaneWidths(emp::Transfer transfer, bool twoMaterials)
{
    const emp::LaneIsa widest = emp::processorLaneIsa(), before = emp::laneIsa();
    if (widest == emp::LaneIsa::baseline) GTEST_SKIP() << "this processor has neither AVX2 nor AVX-512";
    emp::setLaneIsa(emp::LaneIsa::baseline);
    const Solver<D, K> s = makeScene<D, K>(transfer, twoMaterials);
    std::vector<std::uint64_t> first;
    for (emp::LaneIsa w : {emp::LaneIsa::baseline, emp::LaneIsa::avx2, emp::LaneIsa::avx512}) {
        if (emp::setLaneIsa(w) != w) continue;
        const auto d = s.diagnostics();
        std::vector<std::uint64_t> b{emptest::bits(d.kinetic), emptest::bits(d.elastic)};
        for (int c = 0; c < 3; ++c) b.push_back(emptest::bits(d.momentum[c]));
        for (int c = 0; c < 3; ++c) b.push_back(emptest::bits(d.angularMomentum[c]));
        if (first.empty())
            first = b;
        else
            EXPECT_EQ(b, first) << emp::name(w);
    }
    emp::setLaneIsa(before);
}

}  // namespace

TEST(Diagnostics, WithinRoundOffOfPlainSums2D)
{
    checkAgainstPlainSums<2, GimpKernel>(emp::Transfer::flip, true);
    checkAgainstPlainSums<2, GimpKernel>(emp::Transfer::flip, false);
    checkAgainstPlainSums<2, GimpKernel>(emp::Transfer::apic, true);
    checkAgainstPlainSums<2, LinearKernel>(emp::Transfer::flip, false);
}

TEST(Diagnostics, WithinRoundOffOfPlainSums3D)
{
    checkAgainstPlainSums<3, GimpKernel>(emp::Transfer::flip, true);
    checkAgainstPlainSums<3, GimpKernel>(emp::Transfer::apic, false);
    checkAgainstPlainSums<3, GimpKernel>(emp::Transfer::apic, true);
}

TEST(Diagnostics, SameBitsInEveryLaneWidth)
{
    checkLaneWidths<2, GimpKernel>(emp::Transfer::flip, true);
    checkLaneWidths<2, GimpKernel>(emp::Transfer::apic, false);
    checkLaneWidths<3, GimpKernel>(emp::Transfer::apic, true);
    checkLaneWidths<3, GimpKernel>(emp::Transfer::flip, false);
}
