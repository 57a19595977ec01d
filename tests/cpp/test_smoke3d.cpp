// A small 3D uGIMP column under gravity with a fixed base: 20 steps stay finite, the fixed
// nodes do not move, the base reaction carries (part of) the weight and energy appears.
#include "test_helpers.hpp"

namespace {

using emptest::Vec;

TEST(Smoke3D, GimpColumnWithFixedBaseStaysFinite)
{
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = 0.05;
    st.ppc = 2;
    st.gravity = Eigen::Vector3d(0, 0, -9.81);
    emp::Solver<3, emp::GimpKernel> s(st);
    const int mat = s.addMaterial(5e6, 0.2, 1200, false, emp::lawIndex("spectral"));
    emptest::addBlock<3>(s, {0, 0, 0}, {3, 3, 6}, mat);
    s.initialize();
    const auto& g = s.grid();
    std::vector<int> base;
    for (int I = 0; I < g.numNodes(); ++I)
        if (std::fabs(g.nodePosition(I)[2]) < 1e-12) base.push_back(I);
    ASSERT_FALSE(base.empty());
    const int bc = s.addVelocityCondition(base, {}, 7u, Eigen::Vector3d::Zero(), 0.0);
    const auto& P = s.points();
    const std::vector<Vec<3>> x0 = P.x;
    const double dt = 0.5 * s.criticalTimeStep();
    for (int n = 0; n < 20; ++n) {
        ASSERT_NO_THROW(s.step(dt, 1)) << "step " << n;
        for (int I : base) ASSERT_EQ(g.velocity[I].norm(), 0.0) << "fixed node " << I << " moves";
    }
    EXPECT_EQ(s.steps(), 20);
    EXPECT_NEAR(s.time(), 20 * dt, 1e-15);
    double zmin = 1e9, maxStress = 0;
    for (std::size_t p = 0; p < P.size(); ++p) {
        ASSERT_TRUE(P.x[p].allFinite() && P.v[p].allFinite() && s.stressOf(p).allFinite()) << "point " << p;
        ASSERT_LT((P.x[p] - x0[p]).norm(), 0.05 * st.h) << "point " << p;
        zmin = std::min(zmin, P.v[p][2]);
        maxStress = std::max(maxStress, s.stressOf(p).norm());
    }
    // Gravity pulls down, the base pushes up: the column is compressed.
    EXPECT_LT(zmin, 0.0);
    EXPECT_GT(maxStress, 0.0);
    EXPECT_GT(s.reaction(bc)[2], 0.0);
    EXPECT_TRUE(std::isfinite(s.kineticEnergy()) && s.kineticEnergy() > 0);
    EXPECT_TRUE(std::isfinite(s.elasticEnergy()) && s.elasticEnergy() > 0);
}

}  // namespace
