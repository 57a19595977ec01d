// Grid conditions (GridCondition.hpp) are applied at their named points of the step, in the
// order they were added, and a condition written outside the core plugs in through
// Solver::addCondition without touching the step.
#include <memory>

#include "test_helpers.hpp"

#include "Lanes.hpp"

namespace {

using emp::Vec;

template <class C> struct GridConditionTest : ::testing::Test {};
TYPED_TEST_SUITE(GridConditionTest, emptest::AllSolvers);

/// Records what the grid holds at each hook.
template <int D> struct Spy : emp::GridCondition<D> {
    std::vector<double> velocityTimes, forceTimes;
    std::vector<Vec<D>> momentumAtVelocity, momentumAtForces;
    bool velocityIsMomentumOverMass = true, forceSeen = false;
    void afterNodalVelocity(emp::GridState<D>& s) override
    {
        velocityTimes.push_back(s.time);
        const auto& g = s.grid;
        for (int I = 0; I < g.totalNodes(); ++I)
            if (g.mass[I] > 0)
                velocityIsMomentumOverMass = velocityIsMomentumOverMass &&
                                             (g.velocity[I] - g.momentum[I] / g.mass[I]).norm() <= 1e-14 * g.velocity[I].norm();
        momentumAtVelocity.assign(g.momentum.begin(), g.momentum.end());
    }
    void afterForces(emp::GridState<D>& s) override
    {
        forceTimes.push_back(s.time);
        momentumAtForces.assign(s.grid.momentum.begin(), s.grid.momentum.end());
        for (const auto& f : s.grid.force) forceSeen = forceSeen || f.norm() > 0;
    }
};

/// A zero-velocity condition on one component of the nodes below a plane, written as a user
/// would (not the core's VelocityCondition): a symmetry plane y = const.
template <int D> struct RollerBelow : emp::GridCondition<D> {
    double y;
    explicit RollerBelow(double y_) : y(y_) {}
    template <class F> void forNodes(const emp::GridState<D>& s, F&& f)
    {
        for (int I = 0; I < s.grid.numNodes(); ++I)
            if (s.grid.nodePosition(I)[1] <= y) {
                f(I);
                s.phantom.forEachTwin(I, f);
            }
    }
    void afterNodalVelocity(emp::GridState<D>& s) override
    {
        forNodes(s, [&](int I) {
            s.grid.momentum[I][1] = 0.0;
            s.grid.velocity[I][1] = 0.0;
        });
    }
    void afterForces(emp::GridState<D>& s) override
    {
        forNodes(s, [&](int I) { s.grid.force[I][1] = (0.0 - s.grid.momentum[I][1]) / s.dt; });
    }
};

template <int D, class K> std::unique_ptr<emp::Solver<D, K>> wavyBlock()
{
    auto s = std::make_unique<emp::Solver<D, K>>(emptest::typicalSettings(0.01, 2));
    const int mat = s->addMaterial(1e7, 0.3, 1000, false, emp::lawIndex("spectral"));
    std::array<int, D> lo, hi;
    lo.fill(3);
    hi.fill(8);
    emptest::addBlock<D>(*s, lo, hi, mat, [](const Vec<D>& x) {
        Vec<D> v;
        for (int d = 0; d < D; ++d) v[d] = 0.3 * std::sin(40.0 * x[(d + 1) % D] + d);
        return v;
    });
    s->initialize();
    return s;
}

TYPED_TEST(GridConditionTest, HooksRunAtTheirPointsOfTheStepInOrder)
{
    constexpr int D = TypeParam::D;
    auto s = wavyBlock<D, typename TypeParam::K>();
    auto spy = std::make_shared<Spy<D>>();
    s->addCondition(spy);
    const double dt = 0.5 * s->criticalTimeStep();
    s->setTime(1.0);
    for (int k = 0; k < 3; ++k) s->step(dt, 2);
    ASSERT_EQ(spy->velocityTimes.size(), 3u);
    ASSERT_EQ(spy->forceTimes.size(), 3u);
    for (int k = 0; k < 3; ++k) {
        EXPECT_DOUBLE_EQ(spy->velocityTimes[k], 1.0 + (k - 0.5) * dt);  // t^{n-1/2}
        EXPECT_DOUBLE_EQ(spy->forceTimes[k], 1.0 + (k + 0.5) * dt);     // t^{n+1/2}
    }
    EXPECT_TRUE(spy->velocityIsMomentumOverMass) << "after the nodal velocity, v = P / m (Eq 26)";
    EXPECT_TRUE(spy->forceSeen) << "after the forces, the grid holds them";
    // Between the two hooks only conditions change the momentum (Eq 29 comes after).
    ASSERT_EQ(spy->momentumAtVelocity.size(), spy->momentumAtForces.size());
    for (std::size_t I = 0; I < spy->momentumAtVelocity.size(); ++I)
        EXPECT_EQ(spy->momentumAtVelocity[I], spy->momentumAtForces[I]) << "node " << I;
}

TYPED_TEST(GridConditionTest, ConditionWrittenOutsideTheCoreActsLikeTheBuiltInOne)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    const double y = 0.045;
    auto a = wavyBlock<D, K>(), b = wavyBlock<D, K>();
    std::vector<int> nodes;
    for (int I = 0; I < a->grid().numNodes(); ++I)
        if (a->grid().nodePosition(I)[1] <= y) nodes.push_back(I);
    ASSERT_FALSE(nodes.empty());
    a->addVelocityCondition(nodes, {}, 2u, Eigen::Vector3d::Zero(), 0.0);
    b->addCondition(std::make_shared<RollerBelow<D>>(y));
    const double dt = 0.5 * a->criticalTimeStep();
    for (int k = 0; k < 20; ++k) {
        a->step(dt, 1);
        b->step(dt, 2);
    }
    for (std::size_t p = 0; p < a->points().size(); ++p) {
        EXPECT_EQ(a->points().x[p], b->points().x[p]) << "point " << p;
        EXPECT_EQ(a->stressOf(p), b->stressOf(p)) << "point " << p;
    }
    // The condition does act: without it the block moves differently.
    auto c = wavyBlock<D, K>();
    for (int k = 0; k < 20; ++k) c->step(dt, 1);
    double diff = 0;
    for (std::size_t p = 0; p < a->points().size(); ++p) diff += (a->points().x[p] - c->points().x[p]).norm();
    EXPECT_GT(diff, 0.0);
}

/// RollerBelow naming its nodes (GridCondition::nodeRange), as a condition that reads and writes
/// only nodes it knows before the step can.
template <int D> struct NamedRollerBelow : RollerBelow<D> {
    int lo = INT_MAX, hi = -1;
    NamedRollerBelow(double y, const emp::Grid<D>& g) : RollerBelow<D>(y)
    {
        for (int I = 0; I < g.numNodes(); ++I)
            if (g.nodePosition(I)[1] <= y) lo = std::min(lo, I), hi = std::max(hi, I);
    }
    bool nodeRange(int& l, int& h) const override
    {
        l = lo, h = hi;
        return true;
    }
};

TEST(GridConditionRange, ANamedNodeRangeRunsAsAWavefront)
{
    // The step as a wavefront (Solver::pipelineLoop) serves a condition that names its nodes and
    // runs pass by pass with one that does not; the same results, bitwise.
    using K = emp::GimpKernel;
    const double y = 0.045;
    auto a = wavyBlock<2, K>(), b = wavyBlock<2, K>();
    a->addCondition(std::make_shared<RollerBelow<2>>(y));
    b->addCondition(std::make_shared<NamedRollerBelow<2>>(y, b->grid()));
    ASSERT_LE(static_cast<const NamedRollerBelow<2>&>(*b->conditions().back()).lo,
              static_cast<const NamedRollerBelow<2>&>(*b->conditions().back()).hi);
    const double dt = 0.5 * a->criticalTimeStep();
    for (int k = 0; k < 20; ++k) {
        a->step(dt, 1);
        b->step(dt, 1);
    }
    EXPECT_FALSE(a->lastStepPipelined());
    EXPECT_EQ(b->lastStepPipelined(), emp::laneIsa() != emp::LaneIsa::baseline);
    for (std::size_t p = 0; p < a->points().size(); ++p) {
        EXPECT_EQ(a->points().x[p], b->points().x[p]) << "point " << p;
        EXPECT_EQ(a->stressOf(p), b->stressOf(p)) << "point " << p;
    }
}

TYPED_TEST(GridConditionTest, NullConditionIsRefused)
{
    auto s = wavyBlock<TypeParam::D, typename TypeParam::K>();
    EXPECT_THROW(s->addCondition(nullptr), emp::ParameterError);
}


/// Asks the support for the points of every window of cell rows along the last axis, in the
/// step (PointSupport::pointsInRows), and compares with a search of every point.
template <int D, int S> struct RowsProbe : emp::GridCondition<D> {
    int windows = 0, missing = 0, unsorted = 0, far = 0, named = 0, points = 0;
    void afterForces(emp::GridState<D>& s) override
    {
        const auto& g = s.grid;
        const auto& P = s.points;
        std::vector<int> ids;
        std::vector<int> row(P.size());
        for (std::size_t p = 0; p < P.size(); ++p)
            row[p] = static_cast<int>(std::floor((P.x[p][D - 1] - g.origin[D - 1]) * g.invh));
        points = static_cast<int>(P.size());
        for (int lo = -1; lo < g.n[D - 1]; ++lo)
            for (int width = 0; width < 4; ++width) {
                const int hi = lo + width;
                s.support->pointsInRows(lo, hi, ids);
                ++windows;
                named += static_cast<int>(ids.size());
                for (std::size_t k = 1; k < ids.size(); ++k) unsorted += ids[k - 1] >= ids[k];
                std::vector<char> seen(P.size(), 0);
                for (const int p : ids) {
                    seen[p] = 1;
                    // Only the strips (2 cells) that can hold those rows: a point of a row
                    // further than a strip and the support from the window is not named.
                    far += row[p] < lo - S || row[p] > hi + S - 1;
                }
                for (std::size_t p = 0; p < P.size(); ++p) missing += row[p] >= lo && row[p] <= hi && !seen[p];
            }
    }
};

TYPED_TEST(GridConditionTest, PointsInRowsNamesEveryPointOfTheRowsInIdOrderAndFewOthers)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    auto s = wavyBlock<D, K>();
    auto probe = std::make_shared<RowsProbe<D, K::S>>();
    s->addCondition(probe);
    const double dt = 0.5 * s->criticalTimeStep();
    for (int k = 0; k < 3; ++k) s->step(dt, 2);
    EXPECT_GT(probe->windows, 30);
    EXPECT_EQ(probe->missing, 0);
    EXPECT_EQ(probe->unsorted, 0);
    EXPECT_EQ(probe->far, 0);
    // Far fewer than every point for every window: the strips, not a scan of all points.
    EXPECT_LT(probe->named, probe->windows * probe->points / 2);
}

}  // namespace
