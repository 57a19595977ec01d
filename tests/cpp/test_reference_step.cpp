// The optimised step (pkg/Solver.cpp: binned, coloured, fused, cached stencils, erosion by cell
// lists with a force correction) against the plain reference step (reference_step.hpp) on random
// scenes: every configuration and every registered law, with two materials of different laws, a velocity condition, a
// ramped traction, gravity, and optionally a pre-existing crack and eigenerosion. They must
// agree to round-off after several steps, and erode the same points at the same steps.
#include <memory>
#include <random>

#include "reference_step.hpp"
#include "test_helpers.hpp"

namespace {

template <class C> struct ReferenceStepTest : ::testing::Test {};
TYPED_TEST_SUITE(ReferenceStepTest, emptest::AllSolvers);

/// A random block: points jittered off a lattice, random velocities of a few 1e-3 of the wave
/// speed, a material of law `law` in one half and one of the next registered law in the other, the bottom layer fixed, a traction on the
/// top layer, gravity; optionally an interior crack and an erosion stage.
template <int D, class K>
std::unique_ptr<emp::Solver<D, K>> randomScene(unsigned seed, bool crack, double Gc, int law)
{
    std::mt19937 rng(seed);
    auto st = emptest::typicalSettings(0.01, 2);
    st.gravity = Eigen::Vector3d(0.3, -9.81, 0.5);
    auto s = std::make_unique<emp::Solver<D, K>>(st);
    const int a = s->addMaterial(1e7, 0.25, 1000, D == 2, law);
    const int b = s->addMaterial(2e7, 0.3, 1500, false, (law + 1) % emp::RegisteredLaws::size);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double dx = 0.005, c = s->materials()[a].waveSpeed();
    const int n[3] = {16, 12, D == 3 ? 8 : 1};
    for (int k = 0; k < n[2]; ++k)
        for (int j = 0; j < n[1]; ++j)
            for (int i = 0; i < n[0]; ++i) {
                Eigen::Vector3d x((i + 0.5 + 0.3 * u(rng)) * dx, (j + 0.5 + 0.3 * u(rng)) * dx, 0.0);
                if (D == 3) x[2] = (k + 0.5 + 0.3 * u(rng)) * dx;
                Eigen::Vector3d v(u(rng), u(rng), D == 3 ? u(rng) : 0.0);
                s->addPoint(x, 4e-3 * c * v, std::pow(dx, D), i < n[0] / 2 ? a : b);
            }
    std::vector<int> bottom, top;
    for (int p = 0; p < static_cast<int>(s->points().size()); ++p) {
        if (s->points().x[p][1] < dx) bottom.push_back(p);
        if (s->points().x[p][1] > (n[1] - 1) * dx) top.push_back(p);
    }
    s->addVelocityCondition({}, bottom, (1u << D) - 1, Eigen::Vector3d::Zero(), 0.0);
    s->addTraction(top, Eigen::Vector3d(2e4, 5e4, 0.0), 5 * 0.4 * st.h / c, st.h);
    if (crack) {
        if (D == 2) {
            s->addCrack({Eigen::Vector3d(0.021, 0.031, 0), Eigen::Vector3d(0.052, 0.029, 0)});
        } else {
            s->addCrack({Eigen::Vector3d(0.021, 0.030, 0.011), Eigen::Vector3d(0.052, 0.030, 0.011),
                         Eigen::Vector3d(0.052, 0.033, 0.031), Eigen::Vector3d(0.021, 0.033, 0.031)});
        }
    }
    if (Gc > 0) s->setErosion(std::make_shared<emp::EigenErosion<D>>(emp::ErosionSettings{Gc, 2.0, 1.1 * st.h}));
    s->initialize();
    return s;
}

template <int D, class K> void compare(bool crack, bool erosion, int law);

template <int D, class K> void compare(bool crack, bool erosion)
{
    // Every registered law leads one scene (and follows in the next).
    for (int law = 0; law < emp::RegisteredLaws::size; ++law) compare<D, K>(crack, erosion, law);
}

template <int D, class K> void compare(bool crack, bool erosion, int law)
{
    SCOPED_TRACE(std::string("law ") + emp::lawNames()[law]);
    const int steps = 12;
    // Gc: 0.6 of the largest G_p (Eq 23) that a run without erosion reaches, so that some
    // points erode during the run.
    double Gc = 0;
    if (erosion) {
        auto probe = randomScene<D, K>(7, crack, 1e300, law);
        const double dt = 0.4 * probe->criticalTimeStep();
        std::vector<int> all(probe->points().size());
        for (std::size_t p = 0; p < all.size(); ++p) all[p] = static_cast<int>(p);
        for (int k = 0; k < steps; ++k) {
            probe->step(dt, 1);
            for (double G : probe->erosion()->energyReleaseRateBruteForce(probe->points(), all)) Gc = std::max(Gc, G);
        }
        Gc *= 0.6;
    }
    auto s = randomScene<D, K>(7, crack, Gc, law);
    emptest::ReferenceScene<D, K> ref(*s);
    const double dt = 0.4 * s->criticalTimeStep();
    for (int k = 0; k < steps; ++k) {
        s->step(dt, 2);
        emptest::referenceStep(ref, dt);
        const auto& P = s->points();
        for (std::size_t p = 0; p < P.size(); ++p) {
            ASSERT_EQ(P.damage[p], ref.P.damage[p]) << "point " << p << " step " << k + 1;
            const double vs = 1e-11 * (P.v[p].norm() + 1e-3);
            ASSERT_LT((P.x[p] - ref.P.x[p]).norm(), 1e-13) << "point " << p << " step " << k + 1;
            ASSERT_LT((P.v[p] - ref.P.v[p]).norm(), vs) << "point " << p << " step " << k + 1;
            ASSERT_LT((s->stressOf(p) - ref.stress[p]).norm(), 1e-9 * (ref.stress[p].norm() + 1.0))
                << "point " << p << " step " << k + 1;
            ASSERT_NEAR(P.history[p], ref.P.history[p], 1e-9 * (P.history[p] + 1e-6)) << "point " << p;
        }
        for (std::size_t c = 0; c < s->phantomNodes().numCracks(); ++c)
            for (std::size_t v = 0; v < s->phantomNodes().vertices(c).size(); ++v)
                ASSERT_LT((s->phantomNodes().vertices(c)[v] - ref.cracks.vertices(c)[v]).norm(), 1e-13);
        ASSERT_LT((s->reaction(0) - std::static_pointer_cast<emp::VelocityCondition<D>>(ref.conditions[0])->reaction).norm(),
                  1e-9 * (s->reaction(0).norm() + 1.0));
    }
    if (erosion) {
        EXPECT_GT(s->erosion()->erodedCount(), 0u) << "the scene should erode some points";
        EXPECT_LT(s->erosion()->erodedCount(), s->points().size() / 2);
        EXPECT_NEAR(s->erosion()->dissipatedEnergy(), ref.dissipated, 1e-12 * ref.dissipated);
    }
    if (crack) EXPECT_GT(s->phantomNodes().numTwins(), 0);
}

TYPED_TEST(ReferenceStepTest, ElasticSceneMatchesTheReference) { compare<TypeParam::D, typename TypeParam::K>(false, false); }
TYPED_TEST(ReferenceStepTest, CrackedSceneMatchesTheReference) { compare<TypeParam::D, typename TypeParam::K>(true, false); }
TYPED_TEST(ReferenceStepTest, ErodingSceneMatchesTheReference) { compare<TypeParam::D, typename TypeParam::K>(false, true); }
TYPED_TEST(ReferenceStepTest, CrackedErodingSceneMatchesTheReference) { compare<TypeParam::D, typename TypeParam::K>(true, true); }

}  // namespace
