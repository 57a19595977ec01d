// A distributed run (pkg/Distribution.hpp) against the same scene on one process. Run by ctest
// as mpiexec -n 1, 2 and 3: every rank steps the whole scene alone (the reference) and its part
// of the distributed scene, then compares its points with the reference's of the same id,
// bitwise, and the diagnostics (sums over the ranks) to round-off.
#include <gtest/gtest.h>
#include <mpi.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <sstream>

#include "../cpp/test_helpers.hpp"
#include "MpiTransport.hpp"

namespace {

using emp::Vec;
using emptest::to3;

std::shared_ptr<emp::MpiTransport> transport()
{
    static auto t = std::make_shared<emp::MpiTransport>();
    return t;
}

template <class T> bool sameBits(const T& a, const T& b) { return std::memcmp(&a, &b, sizeof(T)) == 0; }

/// Builds the scene into a solver (the same on every rank and for both runs).
template <int D, class K> using Build = std::function<void(emp::Solver<D, K>&)>;

struct Outcome {
    int compared = 0, differing = 0;
    long points = 0;  ///< points over all ranks
    bool migrated = false;
};

/// Runs `steps` steps of the scene on one process and distributed; compares every point.
template <int D, class K>
Outcome compare(const emp::SolverSettings& settings, const Build<D, K>& build, int steps, double dtFraction,
                int threads = 1, int rankColumns = 1)
{
    emp::Solver<D, K> one(settings), dist(settings);
    build(one);
    build(dist);
    dist.distribute(transport(), rankColumns);
    const double dt = dtFraction * one.criticalTimeStep();
    Outcome o;
    std::size_t firstCount = 0;
    for (int n = 0; n < steps; ++n) {
        one.step(dt, threads);
        dist.step(dt, threads);
        if (n == 0) firstCount = dist.points().size();
        o.migrated = o.migrated || dist.points().size() != firstCount;
    }
    const auto& P = dist.points();
    const auto& R = one.points();
    for (std::size_t p = 0; p < P.size(); ++p) {
        const int q = P.globalId[p];
        const bool same = sameBits(P.x[p], R.x[q]) && sameBits(P.v[p], R.v[q]) && sameBits(dist.stressOf(p), one.stressOf(q)) &&
                          sameBits(P.strainOf(p), R.strainOf(q)) && sameBits(P.damage[p], R.damage[q]) &&
                          sameBits(P.history[p], R.history[q]);
        ++o.compared;
        o.differing += !same;
        if (!same && o.differing <= 3)
            ADD_FAILURE() << "rank " << transport()->rank() << ": point " << q << " differs: x " << P.x[p].transpose()
                          << " vs " << R.x[q].transpose() << ", v " << P.v[p].transpose() << " vs " << R.v[q].transpose();
    }
    double counts[2] = {static_cast<double>(P.size()), o.migrated ? 1.0 : 0.0};
    transport()->sum(counts, 2);
    o.points = static_cast<long>(counts[0]);
    o.migrated = counts[1] > 0;
    EXPECT_EQ(o.points, static_cast<long>(R.size()));
    // Diagnostics: sums over the ranks, in another order than one process's.
    const double tol = 1e-12;
    EXPECT_NEAR(dist.kineticEnergy(), one.kineticEnergy(), tol * one.kineticEnergy());
    EXPECT_NEAR(dist.elasticEnergy(), one.elasticEnergy(), tol * std::abs(one.elasticEnergy()) + 1e-300);
    EXPECT_NEAR(dist.externalWork(), one.externalWork(), tol * std::abs(one.externalWork()) + 1e-300);
    EXPECT_NEAR(dist.kineticEnergyAtStep(), one.kineticEnergyAtStep(), tol * std::abs(one.kineticEnergyAtStep()));
    EXPECT_LE((dist.linearMomentum() - one.linearMomentum()).norm(), 1e-10 * (1 + one.linearMomentum().norm()));
    for (std::size_t c = 0; c < one.velocityConditions().size(); ++c)
        EXPECT_LE((dist.reaction(static_cast<int>(c)) - one.reaction(static_cast<int>(c))).norm(),
                  1e-10 * one.reaction(static_cast<int>(c)).norm() + 1e-300);
    EXPECT_TRUE(sameBits(dist.criticalTimeStep(), one.criticalTimeStep()));
    if (one.erosion()) {
        EXPECT_EQ(dist.erosion()->erodedCount(), one.erosion()->erodedCount());
        EXPECT_TRUE(sameBits(dist.erosion()->dissipatedEnergy(), one.erosion()->dissipatedEnergy()));
        const auto& a = dist.erosion()->events();
        const auto& b = one.erosion()->events();
        for (std::size_t e = 0; e < std::min(a.size(), b.size()); ++e) {
            EXPECT_EQ(a[e].point, b[e].point);
            EXPECT_EQ(a[e].step, b[e].step);
        }
    }
    return o;
}

/// A plate (cells along y more than the ranks need) loaded by tractions on its top and bottom
/// rows, its left edge on rollers, with erosion: a crack runs from a notch.
template <class K> void crackedPlate(emp::Solver<2, K>& s, bool erosion, bool phantom = false, double crackEnd = 1.0 / 3)
{
    const double h = s.settings().h;
    const int glass = s.addMaterial(72e9, 0.22, 2440, true, emp::lawIndex("spectral"));
    const int nx = 24, ny = 24;
    s.setDomain(Eigen::Vector3d(-3 * h, -3 * h, 0), Eigen::Vector3d((nx + 3) * h, (ny + 3) * h, 0));
    std::vector<int> top, bottom;
    const double dx = h / s.settings().ppc;
    for (int j = 0; j < ny * s.settings().ppc; ++j)
        for (int i = 0; i < nx * s.settings().ppc; ++i) {
            const Vec<2> x((i + 0.5) * dx, (j + 0.5) * dx);
            // a notch from the left edge to a third of the plate, one cell high, at mid-height
            if (!phantom && x[0] < nx * h / 3 && std::abs(x[1] - ny * h / 2) < 0.5 * h) continue;
            const int id = s.addPoint(to3<2>(x), Eigen::Vector3d::Zero(), dx * dx * h, glass);
            if (x[1] > (ny - 1) * h) top.push_back(id);
            if (x[1] < h) bottom.push_back(id);
        }
    s.addTraction(top, Eigen::Vector3d(0, 12e6, 0), 0, h);
    s.addTraction(bottom, Eigen::Vector3d(0, -12e6, 0), 0, h);
    std::vector<int> left;
    s.initialize();
    for (int I = 0; I < s.grid().numNodes(); ++I)
        if (s.grid().nodePosition(I)[0] <= 0) left.push_back(I);
    s.addVelocityCondition(left, {}, 1u, Eigen::Vector3d::Zero(), 0);
    if (erosion) s.setErosion(std::make_shared<emp::EigenErosion<2>>(emp::ErosionSettings{30.0, 2.0, 1.1 * h}));
    // or a sharp pre-crack by phantom nodes there, slightly off the points' rows
    if (phantom)
        s.addCrack({Eigen::Vector3d(-h, 0.5 * ny * h + 0.1 * h, 0), Eigen::Vector3d(nx * h * crackEnd, 0.5 * ny * h + 0.1 * h, 0)});
}

TEST(Distribution, CrackedPlateErodesBitwiseAsOnOneProcess)
{
    const auto settings = emptest::typicalSettings(1e-3);
    const auto o = compare<2, emp::GimpKernel>(settings, [](auto& s) { crackedPlate(s, true); }, 400, 0.5);
    EXPECT_EQ(o.differing, 0);
    EXPECT_GT(o.compared, 0);
    // The scene must crack, or the erosion exchange goes untested.
    emp::Solver<2, emp::GimpKernel> one(settings);
    crackedPlate(one, true);
    const double dt = 0.5 * one.criticalTimeStep();
    for (int n = 0; n < 400; ++n) one.step(dt, 1);
    EXPECT_GT(one.erosion()->erodedCount(), 20u);
}

TEST(Distribution, CrackedPlateOnTwoThreadsPerRank)
{
    const auto o = compare<2, emp::GimpKernel>(emptest::typicalSettings(1e-3), [](auto& s) { crackedPlate(s, true); },
                                               150, 0.5, 2);
    EXPECT_EQ(o.differing, 0);
}

TEST(Distribution, FlyingBlockMigratesWithApicAndCorotationalUpdate)
{
    // A spinning, flying block under gravity: its points cross every rank boundary.
    for (const auto& [transfer, update] : {std::pair{emp::Transfer::apic, emp::StressUpdate::corotational},
                                           std::pair{emp::Transfer::flip, emp::StressUpdate::smallStrain}}) {
        auto settings = emptest::typicalSettings(0.01);
        settings.transfer = transfer;
        settings.stressUpdate = update;
        settings.gravity = Eigen::Vector3d(0, -9.81, 0);
        const auto build = [](emp::Solver<2, emp::GimpKernel>& s) {
            const int m = s.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
            s.setDomain(Eigen::Vector3d(-0.05, -0.05, 0), Eigen::Vector3d(0.25, 0.6, 0));
            emptest::addBlock<2, emp::GimpKernel>(s, {2, 2}, {12, 10}, m, [](const Vec<2>& x) {
                return Vec<2>(-2.0 * (x[1] - 0.06), 8.0 + 2.0 * (x[0] - 0.07));
            });
        };
        const auto o = compare<2, emp::GimpKernel>(settings, build, 300, 0.5);
        EXPECT_EQ(o.differing, 0);
        if (transport()->size() > 1) EXPECT_TRUE(o.migrated);
    }
}

TEST(Distribution, RebalancesAFlyingBlockBitwiseAsOnOneProcess)
{
    // A block flies up through the ranks' strips: without rebalancing the last rank ends with
    // every point. Checked every 5 steps at a tolerance of 1.05, the ranges follow it, points
    // move between any two ranks, and every point stays bitwise the one-process point.
    auto settings = emptest::typicalSettings(0.01);
    settings.gravity = Eigen::Vector3d(0, -9.81, 0);
    const auto build = [](emp::Solver<2, emp::GimpKernel>& s) {
        const int m = s.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
        s.setDomain(Eigen::Vector3d(-0.05, -0.05, 0), Eigen::Vector3d(0.25, 0.6, 0));
        emptest::addBlock<2, emp::GimpKernel>(s, {2, 2}, {12, 10}, m, [](const Vec<2>&) { return Vec<2>(0.5, 8.0); });
        s.setRebalance(1.05, 5);
    };
    const auto o = compare<2, emp::GimpKernel>(settings, build, 300, 0.5);
    EXPECT_EQ(o.differing, 0);
    // The same scene distributed alone, to read its balance.
    emp::Solver<2, emp::GimpKernel> dist(settings);
    build(dist);
    dist.distribute(transport());
    const double dt = 0.5 * dist.criticalTimeStep();
    double most = 0;
    for (int n = 0; n < 300; ++n) {
        dist.step(dt, 1);
        double counts[2] = {static_cast<double>(dist.points().size()), 0};
        transport()->max(counts, 1);
        most = counts[0];
    }
    if (transport()->size() > 1) {
        EXPECT_GT(dist.rebalances(), 2);
        const double mean = static_cast<double>(o.points) / transport()->size();
        EXPECT_LE(most, 1.6 * mean) << "largest rank " << most << " points, mean " << mean;
        EXPECT_LE(dist.distribution()->imbalance(), 1.6);
    }
    EXPECT_THROW(dist.setRebalance(0.9, 5), emp::ParameterError);
    EXPECT_THROW(dist.setRebalance(1.2, -1), emp::ParameterError);
}

TEST(Distribution, Block3dUnderGravityOnSupports)
{
    auto settings = emptest::typicalSettings(0.01);
    settings.gravity = Eigen::Vector3d(0, 0, -9.81);
    const auto build = [](emp::Solver<3, emp::GimpKernel>& s) {
        const int m = s.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
        s.setDomain(Eigen::Vector3d(-0.03, -0.03, -0.03), Eigen::Vector3d(0.09, 0.09, 0.2));
        emptest::addBlock<3, emp::GimpKernel>(s, {0, 0, 0}, {6, 6, 16}, m);
        std::vector<int> base;
        s.initialize();
        for (int I = 0; I < s.grid().numNodes(); ++I)
            if (s.grid().nodePosition(I)[2] <= 0) base.push_back(I);
        s.addVelocityCondition(base, {}, 7u, Eigen::Vector3d::Zero(), 0);
    };
    const auto o = compare<3, emp::GimpKernel>(settings, build, 60, 0.5);
    EXPECT_EQ(o.differing, 0);
}

TEST(Distribution, LinearShapeFunction)
{
    const auto o = compare<2, emp::LinearKernel>(emptest::typicalSettings(1e-3), [](auto& s) { crackedPlate(s, true); },
                                                 200, 0.5);
    EXPECT_EQ(o.differing, 0);
}

TEST(Distribution, PhantomCrackAcrossRanksGrowsBitwiseAsOnOneProcess)
{
    // The pre-crack lies at mid-height, where two ranks meet: its twins are in the shared planes.
    for (int shape = 0; shape < 2; ++shape) {
        const auto settings = emptest::typicalSettings(1e-3);
        const auto o = shape == 0 ? compare<2, emp::GimpKernel>(settings, [](auto& s) { crackedPlate(s, true, true); }, 300, 0.5)
                                  : compare<2, emp::LinearKernel>(settings, [](auto& s) { crackedPlate(s, true, true); }, 300, 0.5);
        EXPECT_EQ(o.differing, 0);
    }
    emp::Solver<2, emp::GimpKernel> one(emptest::typicalSettings(1e-3));
    crackedPlate(one, true, true);
    const double dt = 0.5 * one.criticalTimeStep();
    for (int n = 0; n < 300; ++n) one.step(dt, 1);
    EXPECT_GT(one.erosion()->erodedCount(), 20u);  // the crack grows from the phantom crack's tip
}

void saveAndResume(int columnCells, int rankColumns)
{
    // The phantom-cracked plate with erosion: saved by every rank after 150 steps, loaded,
    // distributed again and stepped 150 more, it must be bitwise the run that did not stop.
    using Sv = emp::Solver<2, emp::GimpKernel>;
    auto settings = emptest::typicalSettings(1e-3);
    settings.columnCells = columnCells;
    Sv a(settings);
    crackedPlate(a, true, true);
    a.distribute(transport(), rankColumns);
    const double dt = 0.5 * a.criticalTimeStep();
    for (int n = 0; n < 150; ++n) a.step(dt, 1);
    std::stringstream archive;
    a.saveState(archive);
    for (int n = 0; n < 150; ++n) a.step(dt, 1);
    auto b = Sv::loadState(archive);
    EXPECT_TRUE(b->distributedPart());
    EXPECT_THROW(b->step(dt, 1), emp::ParameterError);  // a rank's part alone does not step
    if (rankColumns > 1) {  // (another number of rank columns is refused)
        std::stringstream again(archive.str());
        auto c = Sv::loadState(again);
        EXPECT_THROW(c->distribute(transport(), rankColumns + 1), emp::ParameterError);
    }
    b->distribute(transport());  // (with the archive's columns of ranks)
    EXPECT_EQ(b->distribution()->rankColumns(), rankColumns);
    for (int n = 0; n < 150; ++n) b->step(dt, 1);
    ASSERT_EQ(a.points().size(), b->points().size());
    int differing = 0;
    for (std::size_t p = 0; p < a.points().size(); ++p)
        differing += !(sameBits(a.points().x[p], b->points().x[p]) && sameBits(a.points().v[p], b->points().v[p]) &&
                       sameBits(a.stressOf(p), b->stressOf(p)) &&
                       a.points().globalId[p] == b->points().globalId[p] && sameBits(a.points().damage[p], b->points().damage[p]));
    EXPECT_EQ(differing, 0);
    EXPECT_EQ(a.erosion()->erodedCount(), b->erosion()->erodedCount());
    EXPECT_GT(a.erosion()->erodedCount(), 0u);
    EXPECT_TRUE(sameBits(a.externalWork(), b->externalWork()));
}

TEST(Distribution, EachRankSavesItsPartAndTheSameRanksResumeBitwise) { saveAndResume(0, 1); }

/// A plate pulled apart by conditions on its top and bottom rows of points, with a band of
/// points across mid-height (where ranks meet) held in x: the nodes nearest to one rank's
/// points may lie in the planes it shares.
void pulledPlate(emp::Solver<2, emp::GimpKernel>& s)
{
    const double h = s.settings().h;
    const int glass = s.addMaterial(72e9, 0.22, 2440, true, emp::lawIndex("spectral"));
    s.setDomain(Eigen::Vector3d(-3 * h, -3 * h, 0), Eigen::Vector3d(27 * h, 27 * h, 0));
    std::vector<int> top, bottom, band;
    const double dx = h / s.settings().ppc;
    for (int j = 0; j < 48; ++j)
        for (int i = 0; i < 48; ++i) {
            const Vec<2> x((i + 0.5) * dx, (j + 0.5) * dx);
            const int id = s.addPoint(to3<2>(x), Eigen::Vector3d::Zero(), dx * dx * h, glass);
            if (j == 47) top.push_back(id);
            if (j == 0) bottom.push_back(id);
            if (std::abs(x[1] - 12 * h) < 3 * h && i % 5 == 0) band.push_back(id);
        }
    s.addVelocityCondition({}, top, 3u, Eigen::Vector3d(0, 2.0, 0), 1e-6);
    s.addVelocityCondition({}, bottom, 3u, Eigen::Vector3d(0, -2.0, 0), 1e-6);
    s.addVelocityCondition({}, band, 1u, Eigen::Vector3d::Zero(), 0);
    s.setErosion(std::make_shared<emp::EigenErosion<2>>(emp::ErosionSettings{30.0, 2.0, 1.1 * h}));
}

TEST(Distribution, VelocityConditionsOnPointsAcrossRanks)
{
    const auto o = compare<2, emp::GimpKernel>(emptest::typicalSettings(1e-3), pulledPlate, 300, 0.5);
    EXPECT_EQ(o.differing, 0);
}

// A decomposition in two directions (ScatterChain.hpp): the ranks in a grid of rows along the
// last axis and columns along the first. Against one process with the same columnCells.

/// Two rows of two ranks on 4 ranks; else one row, every rank a column of its own.
int rankColumns() { return transport()->size() == 4 ? 2 : transport()->size(); }

/// A soft block over the cells [lo, hi) moving with v(x), in the domain from (-0.05, -0.05) to
/// `top`; with `baseY`, its nodes at y <= baseY held in y.
template <class K>
void softBlock(emp::Solver<2, K>& s, const Eigen::Vector3d& top, std::array<int, 2> lo, std::array<int, 2> hi,
               const std::function<Vec<2>(const Vec<2>&)>& v, double baseY = -1)
{
    const int m = s.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
    s.setDomain(Eigen::Vector3d(-0.05, -0.05, 0), top);
    emptest::addBlock<2, K>(s, lo, hi, m, v);
    if (baseY < 0) return;
    std::vector<int> base;
    s.initialize();
    for (int I = 0; I < s.grid().numNodes(); ++I)
        if (s.grid().nodePosition(I)[1] <= baseY) base.push_back(I);
    s.addVelocityCondition(base, {}, 2u, Eigen::Vector3d::Zero(), 0);
}

TEST(DistributionBlocks, AFlyingSpinningBlockCrossesRowsAndColumnsBitwise)
{
    for (const auto& [transfer, update] : {std::pair{emp::Transfer::apic, emp::StressUpdate::corotational},
                                           std::pair{emp::Transfer::flip, emp::StressUpdate::smallStrain}}) {
        auto settings = emptest::typicalSettings(0.01);
        settings.transfer = transfer;
        settings.stressUpdate = update;
        settings.gravity = Eigen::Vector3d(0, -9.81, 0);
        settings.columnCells = 2;
        const auto build = [](emp::Solver<2, emp::GimpKernel>& s) {
            softBlock<emp::GimpKernel>(s, Eigen::Vector3d(0.3, 0.6, 0), {2, 2}, {12, 10}, [](const Vec<2>& x) {
                return Vec<2>(1.2 - 2.0 * (x[1] - 0.06), 8.0 + 2.0 * (x[0] - 0.07));
            });
        };
        const auto o = compare<2, emp::GimpKernel>(settings, build, 300, 0.5, 1, rankColumns());
        EXPECT_EQ(o.differing, 0);
        // (The block leaves the ranks behind it without points: this scene does not rebalance.)
        EXPECT_EQ(o.points, 320);
        if (transport()->size() > 1) EXPECT_TRUE(o.migrated);
    }
}

TEST(DistributionBlocks, A3dBlockOnSupportsWithTwoThreadsPerRank)
{
    auto settings = emptest::typicalSettings(0.01);
    settings.gravity = Eigen::Vector3d(0, 0, -9.81);
    settings.columnCells = 2;
    const auto build = [](emp::Solver<3, emp::GimpKernel>& s) {
        const int m = s.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
        s.setDomain(Eigen::Vector3d(-0.03, -0.03, -0.03), Eigen::Vector3d(0.15, 0.09, 0.2));
        std::mt19937 rng(4);
        std::uniform_real_distribution<double> u(-0.3, 0.3);
        emptest::addBlock<3, emp::GimpKernel>(s, {0, 0, 0}, {12, 6, 16}, m,
                                              [&](const Vec<3>&) { return Vec<3>(u(rng), u(rng), u(rng)); });
        std::vector<int> base;
        s.initialize();
        for (int I = 0; I < s.grid().numNodes(); ++I)
            if (s.grid().nodePosition(I)[2] <= 0) base.push_back(I);
        s.addVelocityCondition(base, {}, 7u, Eigen::Vector3d::Zero(), 0);
    };
    const auto o = compare<3, emp::GimpKernel>(settings, build, 60, 0.5, 2, rankColumns());
    EXPECT_EQ(o.differing, 0);
}

TEST(DistributionBlocks, LinearShapesInColumnsOfOneCell)
{
    auto settings = emptest::typicalSettings(0.01);
    settings.gravity = Eigen::Vector3d(0.5, -9.81, 0);
    settings.columnCells = 1;
    const auto build = [](emp::Solver<2, emp::LinearKernel>& s) {
        std::mt19937 rng(8);
        std::uniform_real_distribution<double> u(-0.5, 0.5);
        softBlock<emp::LinearKernel>(s, Eigen::Vector3d(0.25, 0.3, 0), {1, 1}, {18, 20},
                                     [&](const Vec<2>&) { return Vec<2>(u(rng), u(rng)); }, 0.01);
    };
    const auto o = compare<2, emp::LinearKernel>(settings, build, 200, 0.5, 1, rankColumns());
    EXPECT_EQ(o.differing, 0);
}

TEST(DistributionBlocks, ACrackedPlateErodesBitwiseInBlocks)
{
    // Eigenerosion across rows and columns of ranks (ghost points from the eight neighbours),
    // the eroded points' force corrections and the tractions on nodes several ranks write.
    auto settings = emptest::typicalSettings(1e-3);
    settings.columnCells = 2;
    const auto o = compare<2, emp::GimpKernel>(settings, [](auto& s) { crackedPlate(s, true); }, 400, 0.5, 1,
                                               rankColumns());
    EXPECT_EQ(o.differing, 0);
    emp::Solver<2, emp::GimpKernel> one(settings);
    crackedPlate(one, true);
    const double dt = 0.5 * one.criticalTimeStep();
    for (int n = 0; n < 400; ++n) one.step(dt, 1);
    EXPECT_GT(one.erosion()->erodedCount(), 20u);
}

TEST(DistributionBlocks, APhantomCrackAcrossRowsAndColumnsGrowsBitwise)
{
    // The pre-crack runs from the left edge to two thirds of the plate at mid-height, across
    // the boundaries of the columns of ranks (and on 2 x 2 ranks where the rows meet): the
    // twins of the nodes there are written by the points of both columns, and travel with
    // their nodes in the passes.
    for (int shape = 0; shape < 2; ++shape) {
        auto settings = emptest::typicalSettings(1e-3);
        settings.columnCells = 2;
        const auto build = [](auto& s) { crackedPlate(s, true, true, 2.0 / 3); };
        const auto o = shape == 0 ? compare<2, emp::GimpKernel>(settings, build, 300, 0.5, 1, rankColumns())
                                  : compare<2, emp::LinearKernel>(settings, build, 300, 0.5, 1, rankColumns());
        EXPECT_EQ(o.differing, 0);
    }
}

TEST(DistributionBlocks, VelocityConditionsOnPointsInBlocks)
{
    auto settings = emptest::typicalSettings(1e-3);
    settings.columnCells = 2;
    const auto o = compare<2, emp::GimpKernel>(settings, pulledPlate, 300, 0.5, 1, rankColumns());
    EXPECT_EQ(o.differing, 0);
}

TEST(DistributionBlocks, RebalancesABlockFlyingAcrossRowsAndColumns)
{
    // A block flies up and to the right through the rows and the columns of ranks: without
    // rebalancing the rank at the far corner ends with every point. Checked every 5 steps at
    // 1.05, the rows and the columns follow it, and every point stays bitwise.
    auto settings = emptest::typicalSettings(0.01);
    settings.gravity = Eigen::Vector3d(0, -9.81, 0);
    settings.columnCells = 2;
    const auto build = [](emp::Solver<2, emp::GimpKernel>& s) {
        softBlock<emp::GimpKernel>(s, Eigen::Vector3d(0.45, 0.6, 0), {2, 2}, {12, 10}, [](const Vec<2>&) { return Vec<2>(2.5, 8.0); });
        s.setRebalance(1.05, 5);
    };
    const auto o = compare<2, emp::GimpKernel>(settings, build, 300, 0.5, 1, rankColumns());
    EXPECT_EQ(o.differing, 0);
    emp::Solver<2, emp::GimpKernel> dist(settings);
    build(dist);
    dist.distribute(transport(), rankColumns());
    const double dt = 0.5 * dist.criticalTimeStep();
    double most = 0;
    for (int n = 0; n < 300; ++n) {
        dist.step(dt, 1);
        most = static_cast<double>(dist.points().size());
        transport()->max(&most, 1);
    }
    if (transport()->size() > 1) {
        EXPECT_GT(dist.rebalances(), 2);
        const double mean = 320.0 / transport()->size();
        EXPECT_LE(most, 1.6 * mean) << "largest rank " << most << " points, mean " << mean;
    }
}

TEST(DistributionBlocks, RefuseWhatTheyDoNotHave)
{
    if (transport()->size() == 1) GTEST_SKIP() << "one rank: one column";
    auto settings = emptest::typicalSettings(1e-3);
    settings.columnCells = 2;
    {  // columns of ranks without the scheduler's columns, or not dividing the ranks
        emp::Solver<2, emp::GimpKernel> s(emptest::typicalSettings(1e-3));
        crackedPlate(s, false);
        EXPECT_THROW(s.distribute(transport(), 2), emp::ParameterError);
        emp::Solver<2, emp::GimpKernel> t(settings);
        t.addMaterial(72e9, 0.22, 2440, true, emp::lawIndex("spectral"));
        t.addPoint(Eigen::Vector3d(0.01, 0.01, 0), Eigen::Vector3d::Zero(), 1e-9, 0);
        EXPECT_THROW(t.distribute(transport(), transport()->size() + 1), emp::ParameterError);
    }
}

TEST(Distribution, RefusesWhatItDoesNotHave)
{
    emp::Solver<2, emp::GimpKernel> s(emptest::typicalSettings(1e-3));
    crackedPlate(s, false);
    s.setCrackContact(true, 0.0);
    EXPECT_THROW(s.distribute(transport()), emp::ParameterError);
    emp::Solver<2, emp::GimpKernel> d(emptest::typicalSettings(1e-3));
    crackedPlate(d, true);
    d.distribute(transport());
    d.step(0.5 * d.criticalTimeStep(), 1);
    EXPECT_THROW(d.addCrack({Eigen::Vector3d(0, 0.012, 0), Eigen::Vector3d(0.01, 0.012, 0)}), emp::ParameterError);
    d.setCrackContact(true, 0.0);
    EXPECT_THROW(d.step(0.5 * d.criticalTimeStep(), 1), emp::ParameterError);
}

void distributedAtSetUp(int columnCells, int rankColumns)
{
    // Three batches of points with uneven volumes (so that the mean mass depends on the order of
    // its sum) and speeds, and no domain: the grid follows the points' box. Each rank adds only
    // its share of every batch (distributeSetup, holdPoints); no rank ever holds them all.
    auto settings = emptest::typicalSettings(0.01);
    settings.columnCells = columnCells;
    settings.massCutoff = 0.3;  // (large: a node near the cut-off would show a different one)
    settings.gravity = Eigen::Vector3d(0, -9.81, 0);
    const auto batch = [](int b, int i) {
        const double x = 0.003 + 0.005 * (i % 13), y = 0.003 + 0.005 * (i / 13) + 0.07 * b;
        const double vol = 2.5e-5 * (1 + 0.37 * std::sin(1.7 * i + b)), vy = 3 * std::cos(0.3 * i + b);
        return std::make_tuple(Eigen::Vector3d(x, y, 0), Eigen::Vector3d(0.5, vy, 0), vol);
    };
    const int sizes[3] = {13 * 14, 13 * 9 + 5, 13 * 12};
    emp::Solver<2, emp::GimpKernel> one(settings), held(settings);
    const int m1 = one.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
    held.distributeSetup(transport(), rankColumns);
    const int m2 = held.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
    const int rank = transport()->rank(), ranks = transport()->size();
    std::size_t most = 0;
    for (int b = 0; b < 3; ++b) {
        const int n = sizes[b], lo = n * rank / ranks, hi = n * (rank + 1) / ranks;
        for (int i = 0; i < n; ++i) {
            const auto [x, v, vol] = batch(b, i);
            one.addPoint(x, v, vol, m1);
        }
        held.holdPoints(lo, hi - lo, n);
        for (int i = lo; i < hi; ++i) {
            const auto [x, v, vol] = batch(b, i);
            EXPECT_EQ(held.addPoint(x, v, vol, m2), held.numGlobalPoints() - n + i);
        }
        most = std::max(most, held.points().size());
        EXPECT_THROW(held.addPoint(std::get<0>(batch(b, 0)), Eigen::Vector3d::Zero(), 1e-5, m2), emp::ParameterError);
    }
    EXPECT_EQ(held.numGlobalPoints(), sizes[0] + sizes[1] + sizes[2]);
    if (ranks > 1) EXPECT_LT(most, one.points().size());
    EXPECT_TRUE(sameBits(held.criticalTimeStep(), one.criticalTimeStep()));
    one.initialize();
    held.initialize();
    EXPECT_TRUE(sameBits(held.grid().origin, one.grid().origin));
    EXPECT_EQ(held.grid().n, one.grid().n);
    EXPECT_TRUE(sameBits(held.massCutoffAbsolute(), one.massCutoffAbsolute()))
        << held.massCutoffAbsolute() << " vs " << one.massCutoffAbsolute();
    const double dt = 0.5 * one.criticalTimeStep();
    std::stringstream archive;  // this rank's part after 30 steps, with the reference positions
    for (int n = 0; n < 60; ++n) {
        if (n == 30) held.saveState(archive);
        one.step(dt, 1);
        held.step(dt, 1);
    }
    auto resumed = emp::Solver<2, emp::GimpKernel>::loadState(archive);
    resumed->distribute(transport());
    EXPECT_EQ(resumed->numGlobalPoints(), held.numGlobalPoints());
    for (int n = 30; n < 60; ++n) resumed->step(dt, 1);
    ASSERT_EQ(resumed->points().size(), held.points().size());
    for (std::size_t p = 0; p < held.points().size(); ++p)
        EXPECT_TRUE(sameBits(resumed->points().x[p], held.points().x[p]) &&
                    sameBits(resumed->points().reference[p], held.points().reference[p]) &&
                    resumed->points().globalId[p] == held.points().globalId[p])
            << "point " << held.points().globalId[p];
    const auto& P = held.points();
    const auto& R = one.points();
    const auto added = [&](int q) {  // where point q was added (its reference position)
        int b = 0;
        for (; q >= sizes[b]; ++b) q -= sizes[b];
        return Vec<2>(std::get<0>(batch(b, q)).head<2>());
    };
    int differing = 0;
    for (std::size_t p = 0; p < P.size(); ++p) {
        const int q = P.globalId[p];
        differing += !(sameBits(P.x[p], R.x[q]) && sameBits(P.v[p], R.v[q]) && sameBits(held.stressOf(p), one.stressOf(q)) &&
                       sameBits(P.reference[p], added(q)));
    }
    EXPECT_EQ(differing, 0);
    double count = static_cast<double>(P.size());
    transport()->sum(&count, 1);
    EXPECT_EQ(count, static_cast<double>(R.size()));
    // Distributed at set-up, the scene cannot be saved before its first step (no rank holds it).
    emp::Solver<2, emp::GimpKernel> fresh(settings);
    fresh.distributeSetup(transport());
    std::ostringstream os;
    EXPECT_THROW(fresh.saveState(os), emp::SimulationError);
    EXPECT_THROW(one.distributeSetup(transport()), emp::ParameterError);
}

TEST(Distribution, PointsDistributedAtSetUpGiveTheOneProcessGridCutOffAndSteps) { distributedAtSetUp(0, 1); }

TEST(DistributionBlocks, EachRankSavesItsPartAndTheSameRanksResumeBitwise) { saveAndResume(2, rankColumns()); }

TEST(DistributionBlocks, PointsDistributedAtSetUpGiveTheOneProcessResults) { distributedAtSetUp(2, rankColumns()); }

/// Pages of the array that are in memory (mincore), and all its pages.
template <class A> std::pair<long, long> residentPages(const A& a)
{
    const long page = sysconf(_SC_PAGESIZE);
    const auto start = reinterpret_cast<std::uintptr_t>(a.data());
    const std::size_t bytes = a.size() * sizeof(a[0]);
    EXPECT_EQ(start % page, 0u) << "not from mmap";
    std::vector<unsigned char> in((bytes + page - 1) / page);
    EXPECT_EQ(mincore(reinterpret_cast<void*>(start), bytes, in.data()), 0);
    long n = 0;
    for (unsigned char c : in) n += c & 1;
    return {n, static_cast<long>(in.size())};
}

TEST(Distribution, ARankGridTakesMemoryOnlyInItsPlanes)
{
    // A grid of 201 x 801 nodes (its mass array 1.3 MB: from mmap), full of points: each rank
    // writes only its planes, and only those pages of its nodal arrays are in memory.
    auto settings = emptest::typicalSettings(0.01, 1);
    settings.gravity = Eigen::Vector3d(0, -9.81, 0);
    emp::Solver<2, emp::GimpKernel> s(settings);
    const int m = s.addMaterial(1e6, 0.3, 1000, false, emp::lawIndex("spectral"));
    s.setDomain(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2.0, 8.0, 0));
    emptest::addBlock<2, emp::GimpKernel>(s, {2, 2}, {198, 798}, m);
    s.distribute(transport());
    for (int n = 0; n < 2; ++n) s.step(0.5 * s.criticalTimeStep(), 1);
    const auto& g = s.grid();
    const long page = sysconf(_SC_PAGESIZE);
    const auto* d = s.distribution();
    const long window = static_cast<long>(d->planeHi() - d->planeLo()) * g.stride[1];  // nodes
    for (const auto& [resident, all] : {residentPages(g.mass), residentPages(g.invMass)}) {
        const long expected = (window * 8 + page - 1) / page + 2;  // (+ a page at each end)
        EXPECT_LE(resident, expected) << "rank " << d->rank() << ": " << resident << " of " << all << " pages";
        if (d->size() == 1) EXPECT_EQ(resident, all);
        if (d->size() > 1) EXPECT_LT(resident, 0.8 * all);
    }
    const auto [resident, all] = residentPages(g.momentum);
    EXPECT_LE(resident, (window * 16 + page - 1) / page + 2) << resident << " of " << all;
}

}  // namespace

int main(int argc, char** argv)
{
    ::testing::InitGoogleTest(&argc, argv);
    transport();  // MPI up before the tests
    // Every rank runs every test (they communicate) and prints its results.
    const int failed = RUN_ALL_TESTS();
    int any = failed;
    MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return any;
}
