// The step as a wavefront over the strips (Solver::pipelineLoop) against the step pass by pass:
// bitwise the same positions, velocities, strains, stresses, histories, energies and reactions,
// on one worker and on two, with velocity conditions below the workers' boundary, above it, on
// both sides or none, with gravity and without, with an erosion stage that erodes; the scenes
// it does not serve run pass by pass.
#include "test_helpers.hpp"

#include "Lanes.hpp"

namespace {

using emp::GimpKernel;
using emp::Solver;
using emptest::Vec;

enum class Held { none, base, top, both };

/// A 2D block 18 cells wide and `cells` tall (many strips), random velocities, one material, and
/// the velocity conditions `held` names: the base fixed, the top pulled up. With `y0` >= 0 the
/// random velocities are a fifth as strong, and the block is pulled apart at height y0 (1 m/s
/// up above it, down below it, fading away from it).
Solver<2, GimpKernel> makeBlock(Held held, bool gravity, int cells = 60, double y0 = -1)
{
    emp::SolverSettings st = emptest::typicalSettings(0.05, 2);
    if (gravity) st.gravity = Eigen::Vector3d(0.3, -9.81, 0.0);
    Solver<2, GimpKernel> s(st);
    const int mat = s.addMaterial(1e6, 0.3, 1000, true, emp::lawIndex("spectral"));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    const std::array<int, 2> lo{2, 2}, hi{20, 2 + cells};
    emptest::addBlock<2, GimpKernel>(s, lo, hi, mat, [&](const Vec<2>& x) {
        const Vec<2> v(u(rng), u(rng));
        if (y0 < 0) return v;
        const double pull = (x[1] > y0 ? 1.0 : -1.0) * std::exp(-std::pow((x[1] - y0) / 0.3, 2));
        return Vec<2>(0.2 * v + Vec<2>(0, pull));
    });
    s.initialize();
    const auto& g = s.grid();
    std::vector<int> base, top;
    for (int I = 0; I < g.numNodes(); ++I) {
        const double y = g.nodePosition(I)[1];
        if (y <= lo[1] * st.h + 1e-12) base.push_back(I);
        if (y >= hi[1] * st.h - 1e-12) top.push_back(I);
    }
    if (held == Held::base || held == Held::both) s.addVelocityCondition(base, {}, 3u, Eigen::Vector3d::Zero(), 0.0);
    if (held == Held::top || held == Held::both) s.addVelocityCondition(top, {}, 2u, Eigen::Vector3d(0, 0.2, 0), 0.01);
    return s;
}

template <class T> int differences(const std::vector<T>& a, const std::vector<T>& b)
{
    int n = 0;
    for (std::size_t i = 0; i < a.size(); ++i) n += !(a[i] == b[i]);
    return a.size() == b.size() ? n : -1;
}

void expectSameState(const Solver<2, GimpKernel>& a, const Solver<2, GimpKernel>& b)
{
    const auto &A = a.points(), &B = b.points();
    EXPECT_EQ(differences(A.x, B.x), 0) << "positions";
    EXPECT_EQ(differences(A.v, B.v), 0) << "velocities";
    EXPECT_EQ(differences(A.strain, B.strain), 0) << "strains";
    EXPECT_EQ(differences(A.history, B.history), 0) << "histories";
    EXPECT_EQ(differences(A.energy, B.energy), 0) << "energies";
    EXPECT_EQ(differences(emptest::stressesOf(a), emptest::stressesOf(b)), 0) << "stresses";
    for (std::size_t c = 0; c < a.velocityConditions().size(); ++c) EXPECT_EQ(a.reaction(static_cast<int>(c)), b.reaction(static_cast<int>(c)));
    EXPECT_EQ(a.kineticEnergy(), b.kineticEnergy());
    EXPECT_EQ(a.kineticEnergyAtStep(), b.kineticEnergyAtStep());  // (G2P's sum, strip by strip)
}

/// Steps the block pass by pass and as a wavefront on `threads` threads; expects `workers`.
void compare(Held held, bool gravity, int threads, int workers, int cells = 60)
{
    Solver<2, GimpKernel> passes = makeBlock(held, gravity, cells), wave = makeBlock(held, gravity, cells);
    passes.setPipelined(false);
    const double dt = 0.5 * passes.criticalTimeStep();
    double maxStress = 0;
    for (int n = 0; n < 40; ++n) {
        passes.step(dt, threads);
        wave.step(dt, threads);
    }
    ASSERT_FALSE(passes.lastStepPipelined());
    ASSERT_TRUE(wave.lastStepPipelined());
    EXPECT_EQ(wave.lastStepWorkers(), workers);
    expectSameState(passes, wave);
    // G2P's kinetic energy: summed strip by strip, as the passes' Scheduler::gather does.
    EXPECT_EQ(wave.kineticEnergyAtStep(), passes.kineticEnergyAtStep());
    for (std::size_t p = 0; p < passes.points().size(); ++p) maxStress = std::max(maxStress, passes.stressOf(p).norm());
    EXPECT_GT(maxStress, 1.0);  // (not a trivial scene)
    if (held != Held::none) EXPECT_GT(passes.reaction(0).norm(), 0.0);
}

bool lanes() { return emp::laneIsa() != emp::LaneIsa::baseline; }

TEST(Pipelined, OneWorkerIsBitwiseThePasses)
{
    if (!lanes()) GTEST_SKIP() << "the wavefront runs with AVX2 or AVX-512 lanes";
    compare(Held::both, true, 1, 1);
    compare(Held::none, false, 1, 1);
}

TEST(Pipelined, TwoWorkersAreBitwiseThePasses)
{
    if (!lanes()) GTEST_SKIP() << "the wavefront runs with AVX2 or AVX-512 lanes";
    compare(Held::none, false, 2, 2);
    compare(Held::base, true, 2, 2);  // the lower worker applies the conditions
    compare(Held::top, false, 2, 2);  // the upper one
    compare(Held::both, true, 2, 1);  // conditions on both sides: one worker
    compare(Held::base, false, 2, 1, 8);  // too few strips for two
}

TEST(Pipelined, OneAndTwoWorkersGiveTheSameBits)
{
    if (!lanes()) GTEST_SKIP() << "the wavefront runs with AVX2 or AVX-512 lanes";
    Solver<2, GimpKernel> one = makeBlock(Held::base, true), two = makeBlock(Held::base, true);
    const double dt = 0.5 * one.criticalTimeStep();
    for (int n = 0; n < 40; ++n) {
        one.step(dt, 1);
        two.step(dt, 2);
    }
    EXPECT_EQ(one.lastStepWorkers(), 1);
    EXPECT_EQ(two.lastStepWorkers(), 2);
    expectSameState(one, two);
    EXPECT_EQ(one.kineticEnergyAtStep(), two.kineticEnergyAtStep());  // (the strips' sums, in strip order)
}

/// The block pulled apart at height y0, with an erosion stage (radius kappa, m): sources appear
/// there after a step or more without any. The wavefront (the update held back from a source's
/// reach, the erosion stage after the last stress stage) gives the passes' bits, the same
/// eroded points, candidates and events.
void compareEroding(Held held, int threads, int workers, double y0, double Gc, double kappa, int cells = 60)
{
    const auto make = [&]() {
        Solver<2, GimpKernel> s = makeBlock(held, false, cells, y0);
        s.setErosion(std::make_shared<emp::EigenErosion<2>>(emp::ErosionSettings{Gc, 2.0, kappa}));
        return s;
    };
    Solver<2, GimpKernel> passes = make(), wave = make();
    passes.setPipelined(false);
    const double dt = 0.5 * passes.criticalTimeStep();
    int quiet = 0, searched = 0, eroding = 0;
    for (int n = 0; n < 60; ++n) {
        passes.step(dt, threads);
        wave.step(dt, threads);
        ASSERT_TRUE(wave.lastStepPipelined());
        ASSERT_EQ(wave.lastStepWorkers(), workers);
        const auto &a = *passes.erosion(), &b = *wave.erosion();
        ASSERT_EQ(a.searchedLastStep(), b.searchedLastStep()) << "step " << n;
        ASSERT_EQ(a.lastEroded(), b.lastEroded()) << "step " << n;
        ASSERT_EQ(a.candidatesLastStep(), b.candidatesLastStep()) << "step " << n;
        quiet += !a.searchedLastStep();
        searched += a.searchedLastStep();
        eroding += !a.lastEroded().empty();
    }
    expectSameState(passes, wave);
    EXPECT_EQ(differences(passes.points().damage, wave.points().damage), 0) << "damage";
    EXPECT_EQ(passes.erosion()->dissipatedEnergy(), wave.erosion()->dissipatedEnergy());
    EXPECT_EQ(passes.erosion()->erodedCount(), wave.erosion()->erodedCount());
    EXPECT_GT(quiet, 0) << "steps without a source";
    EXPECT_GT(searched, 0) << "steps with sources";
    EXPECT_GT(eroding, 0) << "steps that erode";
}

TEST(Pipelined, ErosionIsBitwiseThePasses)
{
    if (!lanes()) GTEST_SKIP() << "the wavefront runs with AVX2 or AVX-512 lanes";
    // kappa = 2.2 h: erosion near the first source, or once and none after (the last case)
    compareEroding(Held::none, 1, 1, 1.0, 100.0, 0.11);
    compareEroding(Held::none, 2, 2, 1.6, 100.0, 0.11);
    compareEroding(Held::base, 2, 2, 2.6, 60.0, 0.11);
    // kappa = 4 h: points eroded below (above) the first source strip the sweep meets; with
    // the update held back by fewer rows than a source reaches (E = 0), these fail
    compareEroding(Held::none, 1, 1, 1.0, 200.0, 0.2);
    compareEroding(Held::top, 1, 1, 2.6, 200.0, 0.2);
    compareEroding(Held::none, 2, 2, 1.6, 200.0, 0.2);  // (at the workers' boundary)
    compareEroding(Held::base, 2, 2, 2.6, 200.0, 0.2);  // (in the upper worker's strips)
    compareEroding(Held::top, 2, 2, 0.8, 200.0, 0.2);   // (in the lower worker's)
    // 160 cells, 80 strips, more than a worker's ring holds: once a source is seen, the strips
    // whose ring slot is held write their stencils to the overflow
    compareEroding(Held::none, 1, 1, 1.0, 100.0, 0.11, 160);
    compareEroding(Held::none, 2, 2, 4.6, 100.0, 0.11, 160);  // (the upper worker's early strips)
    compareEroding(Held::none, 2, 2, 3.6, 100.0, 0.11, 160);  // (the lower worker's)
}

TEST(Pipelined, OtherScenesRunPassByPass)
{
    const auto stepped = [](Solver<2, GimpKernel>& s, int threads) {
        s.step(0.5 * s.criticalTimeStep(), threads);
        return s.lastStepPipelined();
    };
    {
        Solver<2, GimpKernel> s = makeBlock(Held::base, false);
        EXPECT_EQ(stepped(s, 1), lanes());
        EXPECT_FALSE(stepped(s, 3)) << "more than two threads";
        s.setPipelined(false);
        EXPECT_FALSE(stepped(s, 1));
    }
    {
        Solver<2, GimpKernel> s = makeBlock(Held::base, false);
        s.setErosion(std::make_shared<emp::EigenErosion<2>>(emp::ErosionSettings{25.0, 2.0, 0.11}));
        EXPECT_EQ(stepped(s, 1), lanes()) << "erosion is served";
    }
    {
        Solver<2, GimpKernel> s = makeBlock(Held::base, false);
        s.addCrack({Eigen::Vector3d(0.3, 0.6, 0), Eigen::Vector3d(0.6, 0.6, 0)});
        EXPECT_FALSE(stepped(s, 1)) << "a crack";
    }
    {
        Solver<2, GimpKernel> s = makeBlock(Held::none, false);
        s.addTraction({0, 1, 2}, Eigen::Vector3d(0, 1e3, 0), 0.0, 0.025);
        EXPECT_FALSE(stepped(s, 1)) << "a traction";
    }
}

TEST(Pipelined, ANonFiniteVelocityStopsTheStepWithItsMessage)
{
    if (!lanes()) GTEST_SKIP() << "the wavefront runs with AVX2 or AVX-512 lanes";
    for (const int threads : {1, 2}) {
        Solver<2, GimpKernel> s = makeBlock(Held::none, false);
        const double dt = 0.5 * s.criticalTimeStep();
        s.step(dt, threads);
        ASSERT_TRUE(s.lastStepPipelined());
        s.points().v[17] = Vec<2>(std::numeric_limits<double>::quiet_NaN(), 0.0);
        try {
            s.step(dt, threads);
            ADD_FAILURE() << "no error on " << threads << " threads";
        } catch (const emp::SimulationError& e) {
            EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos) << e.what();
        }
    }
}

}  // namespace
