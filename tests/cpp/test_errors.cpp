// Error handling of the core: invalid parameters raise emp::ParameterError, a simulation that
// cannot go on raises emp::SimulationError; each message names the quantity and its value.
#include "test_helpers.hpp"

namespace {

using emp::ElasticMaterial;
using emp::GimpKernel;
using emp::LinearKernel;
using emp::ParameterError;
using emp::SimulationError;
using emp::Solver;
using emptest::contains;
using emptest::messageOf;
using emptest::to3;
using emptest::Vec;


#define EXPECT_MESSAGE_HAS(msg, sub) EXPECT_TRUE(contains(msg, sub)) << "message \"" << (msg) << "\" lacks \"" << (sub) << "\""

emp::SolverSettings settings(double h = 0.1, int ppc = 2)
{
    emp::SolverSettings s = emptest::typicalSettings();
    s.h = h;
    s.ppc = ppc;
    return s;
}

TEST(Errors, YoungsModulusMustBePositive)
{
    for (double E : {0.0, -5.0}) {
        const std::string m = messageOf<ParameterError>([&] { ElasticMaterial::make(E, 0.3, 1000, false, 3, emp::lawIndex("spectral")); });
        EXPECT_MESSAGE_HAS(m, "E (Young's modulus");
        EXPECT_MESSAGE_HAS(m, "= " + std::string(E == 0 ? "0" : "-5"));
    }
    Solver<2, GimpKernel> s(settings());
    const std::string m = messageOf<ParameterError>([&] { s.addMaterial(-2.5e9, 0.3, 1000, false, emp::lawIndex("spectral")); });
    EXPECT_MESSAGE_HAS(m, "E (Young's modulus");
    EXPECT_MESSAGE_HAS(m, "-2500000000");
    EXPECT_TRUE(s.materials().empty());
    EXPECT_NO_THROW(ElasticMaterial::make(1e-3, 0.3, 1000, false, 3, emp::lawIndex("spectral")));
}

TEST(Errors, PoissonRatioMustLieBetweenMinusOneAndOneHalf)
{
    for (double nu : {-1.0, -1.5, 0.5, 0.7}) {
        for (int dim : {2, 3}) {
            const std::string m = messageOf<ParameterError>([&] { ElasticMaterial::make(1e9, nu, 1000, dim == 2, dim, emp::lawIndex("spectral")); });
            EXPECT_MESSAGE_HAS(m, "nu (Poisson's ratio)");
            std::ostringstream v;
            v << "= " << nu;
            EXPECT_MESSAGE_HAS(m, v.str());
        }
    }
    const std::string m = messageOf<ParameterError>([&] { ElasticMaterial::make(1e9, std::nan(""), 1000, false, 3, emp::lawIndex("spectral")); });
    EXPECT_MESSAGE_HAS(m, "nu (Poisson's ratio)");
    EXPECT_NO_THROW(ElasticMaterial::make(1e9, -0.99, 1000, false, 3, emp::lawIndex("spectral")));
    EXPECT_NO_THROW(ElasticMaterial::make(1e9, 0.49, 1000, false, 3, emp::lawIndex("spectral")));
}

TEST(Errors, DensityMustBePositive)
{
    for (double rho : {0.0, -1000.0}) {
        Solver<3, GimpKernel> s(settings());
        const std::string m = messageOf<ParameterError>([&] { s.addMaterial(1e9, 0.2, rho, false, emp::lawIndex("spectral")); });
        EXPECT_MESSAGE_HAS(m, "rho (density");
        EXPECT_MESSAGE_HAS(m, rho == 0 ? "= 0" : "= -1000");
    }
}

TEST(Errors, PointsPerCellAndCellSizeMustBeValid)
{
    for (int ppc : {0, -2}) {
        const std::string m = messageOf<ParameterError>([&] { Solver<2, GimpKernel> s(settings(0.1, ppc)); });
        EXPECT_MESSAGE_HAS(m, "ppc");
        EXPECT_MESSAGE_HAS(m, "= " + std::to_string(ppc));
    }
    for (double h : {0.0, -0.1}) {
        const std::string m = messageOf<ParameterError>([&] { Solver<3, LinearKernel> s(settings(h)); });
        EXPECT_MESSAGE_HAS(m, "h (cell size");
        EXPECT_MESSAGE_HAS(m, h == 0 ? "= 0" : "= -0.1");
    }
    const std::string m = messageOf<ParameterError>([&] { Solver<3, LinearKernel> s(settings(std::nan(""))); });
    EXPECT_MESSAGE_HAS(m, "h (cell size");
    EXPECT_NO_THROW((Solver<2, GimpKernel>(settings(0.1, 1))));
}

/// A small 2D block at rest.
template <class Sv> void addSmallBlock(Sv& s)
{
    const int mat = s.addMaterial(1e7, 0.25, 1500, false, emp::lawIndex("spectral"));
    constexpr int D = Sv::dim;
    std::array<int, D> lo, hi;
    lo.fill(0);
    hi.fill(3);
    emptest::addBlock<D>(s, lo, hi, mat);
}

TEST(Errors, TimeStepAboveCriticalIsRejectedBeforeAnythingChanges)
{
    Solver<2, GimpKernel> s(settings());
    addSmallBlock(s);
    const double crit = s.criticalTimeStep();
    ASSERT_TRUE(std::isfinite(crit));
    // Critical step of this scene: h / wave speed (the points are at rest).
    EXPECT_NEAR(crit, 0.1 / s.materials()[0].waveSpeed(), 1e-12 * crit);
    const std::vector<Vec<2>> x0 = s.points().x;
    const double tooLarge = 1.01 * crit;
    const std::string m = messageOf<ParameterError>([&] { s.step(tooLarge, 1); });
    std::ostringstream value;
    value.precision(6);
    value << "dt = " << tooLarge;
    EXPECT_MESSAGE_HAS(m, value.str());
    EXPECT_MESSAGE_HAS(m, "critical time step");
    EXPECT_EQ(s.steps(), 0);
    EXPECT_EQ(s.time(), 0.0);
    EXPECT_EQ(s.points().x, x0);
    for (double dt : {0.0, -1e-5}) {
        const std::string m2 = messageOf<ParameterError>([&] { s.step(dt, 1); });
        EXPECT_MESSAGE_HAS(m2, "dt (time step");
    }
    EXPECT_NO_THROW(s.step(crit, 1));
    EXPECT_EQ(s.steps(), 1);
}

/// A lone fast point next to the grid's edge leaves the grid within a few steps: the error
/// names it, and the point is kept.
template <int D, class K> void checkPointLeavingGrid()
{
    Solver<D, K> s(settings());
    addSmallBlock(s);
    const int mat = 0;
    // A projectile at the high corner of the bounding box, moving away from the block.
    Vec<D> x = Vec<D>::Constant(0.9), v = Vec<D>::Zero();
    v[0] = 500.0;
    const int id = s.addPoint(to3<D>(x), to3<D>(v), std::pow(0.05, D), mat);
    const std::size_t n = s.points().size();
    std::string m;
    int steps = 0;
    try {
        for (steps = 0; steps < 50; ++steps) s.step(0.9 * s.criticalTimeStep(), 2);
    } catch (const SimulationError& e) {
        m = e.what();
    }
    ASSERT_LT(steps, 50) << "the point never left the grid";
    EXPECT_MESSAGE_HAS(m, "point id " + std::to_string(id));
    EXPECT_MESSAGE_HAS(m, "left the grid");
    EXPECT_MESSAGE_HAS(m, "step " + std::to_string(s.steps()));
    EXPECT_EQ(s.points().size(), n);
    EXPECT_TRUE(s.points().x[id].allFinite());
    EXPECT_GT(s.points().x[id][0], x[0]);
    // Stepping on is refused (the point would address nodes outside the grid) and changes nothing.
    const std::int64_t stepsDone = s.steps();
    const std::string again = messageOf<SimulationError>([&] { s.step(0.5 * s.criticalTimeStep(), 2); });
    EXPECT_MESSAGE_HAS(again, "point id " + std::to_string(id));
    EXPECT_EQ(s.steps(), stepsDone);
    // Once the point is back inside, the run can go on.
    s.points().x[id] = x;
    s.points().v[id].setZero();
    EXPECT_NO_THROW(s.step(0.5 * s.criticalTimeStep(), 2));
    EXPECT_EQ(s.steps(), stepsDone + 1);
}

TEST(Errors, PointLeavingTheGrid2D) { checkPointLeavingGrid<2, GimpKernel>(); }
TEST(Errors, PointLeavingTheGrid3D) { checkPointLeavingGrid<3, LinearKernel>(); }

TEST(Errors, PointOutsideAGivenDomain)
{
    Solver<2, GimpKernel> s(settings());
    addSmallBlock(s);
    s.setDomain(Eigen::Vector3d(-0.5, -0.5, 0), Eigen::Vector3d(2, 2, 0));
    s.addPoint(Eigen::Vector3d(3.0, 0.5, 0), Eigen::Vector3d::Zero(), 0.0025, 0);
    const std::string m = messageOf<SimulationError>([&] { s.initialize(); });
    EXPECT_MESSAGE_HAS(m, "point " + std::to_string(s.points().size() - 1));
    EXPECT_MESSAGE_HAS(m, "outside");
}

/// Points 4 cells apart, so that a bad value at one of them reaches no other point.
template <int D, class K> Solver<D, K> isolatedPoints()
{
    Solver<D, K> s(settings());
    const int mat = s.addMaterial(1e7, 0.25, 1500, false, emp::lawIndex("spectral"));
    for (int p = 0; p < 4; ++p) {
        Vec<D> x = Vec<D>::Constant(0.55), v = Vec<D>::Constant(0.1 * (p + 1));
        x[0] += 0.4 * p;
        s.addPoint(to3<D>(x), to3<D>(v), std::pow(0.05, D), mat);
    }
    return s;
}

template <int D, class K> void checkNonFiniteStrain()
{
    auto s = isolatedPoints<D, K>();
    emp::Mat<D> eps = emp::full(s.points().strain[2]);
    eps(0, 0) = std::numeric_limits<double>::quiet_NaN();
    s.points().strain[2] = eps;
    const std::string m = messageOf<SimulationError>([&] { s.step(0.5 * s.criticalTimeStep(), 2); });
    EXPECT_MESSAGE_HAS(m, "non-finite");
    EXPECT_MESSAGE_HAS(m, "step 1");
    EXPECT_MESSAGE_HAS(m, "point id 2");
    EXPECT_EQ(s.points().size(), 4u);
}

/// A non-finite stress that reaches no velocity (every node of the grid held at rest, so the
/// force on them is not used) is still reported: the stress pass checks the stresses.
/// Each point in turn (the four share a run), so that both of a run's sums are checked
/// (Solver::checkStresses: even and odd points).
template <int D, class K> void checkNonFiniteStressAtHeldNodes()
{
    const std::size_t n = isolatedPoints<D, K>().points().size();
    for (std::size_t bad = 0; bad < n; ++bad) {
        auto s = isolatedPoints<D, K>();
        s.initialize();
        for (int I = 0; I < s.grid().numNodes(); ++I)
            s.addVelocityCondition({I}, {}, (1u << D) - 1, Eigen::Vector3d::Zero(), 0.0);
        const double dt = 0.5 * s.criticalTimeStep();
        s.step(dt, 1);
        emp::Mat<D> eps = emp::full(s.points().strain[bad]);
        eps(0, 0) = std::numeric_limits<double>::infinity();
        s.points().strain[bad] = eps;
        const std::string m = messageOf<SimulationError>([&] { s.step(dt, 2); });
        EXPECT_MESSAGE_HAS(m, "non-finite");
        EXPECT_MESSAGE_HAS(m, "step 2");
        EXPECT_MESSAGE_HAS(m, "point id " + std::to_string(bad));
        for (std::size_t p = 0; p < s.points().size(); ++p) EXPECT_TRUE(s.points().v[p].allFinite()) << "point " << p;
    }
}

template <int D, class K> void checkNonFiniteVelocity()
{
    auto s = isolatedPoints<D, K>();
    const double dt = 0.5 * s.criticalTimeStep();
    s.step(dt, 1);
    s.points().v[3][0] = std::numeric_limits<double>::infinity();
    const std::string m = messageOf<SimulationError>([&] { s.step(dt, 2); });
    EXPECT_MESSAGE_HAS(m, "non-finite");
    EXPECT_MESSAGE_HAS(m, "step 2");
    EXPECT_MESSAGE_HAS(m, "point id 3");
}

TEST(Errors, NonFiniteStrainDuringAStep2D) { checkNonFiniteStrain<2, GimpKernel>(); }
TEST(Errors, NonFiniteStrainDuringAStep3D) { checkNonFiniteStrain<3, GimpKernel>(); }
TEST(Errors, NonFiniteStrainDuringAStepLinear) { checkNonFiniteStrain<2, LinearKernel>(); }
TEST(Errors, NonFiniteStressAtHeldNodes2D) { checkNonFiniteStressAtHeldNodes<2, GimpKernel>(); }
TEST(Errors, NonFiniteStressAtHeldNodes3D) { checkNonFiniteStressAtHeldNodes<3, GimpKernel>(); }
TEST(Errors, NonFiniteVelocityDuringAStep2D) { checkNonFiniteVelocity<2, GimpKernel>(); }
TEST(Errors, NonFiniteVelocityDuringAStep3D) { checkNonFiniteVelocity<3, LinearKernel>(); }

TEST(Errors, InvalidPointsAndConditions)
{
    Solver<2, GimpKernel> s(settings());
    const std::string m0 = messageOf<ParameterError>([&] { s.addPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1e-3, 0); });
    EXPECT_MESSAGE_HAS(m0, "material (id)");
    addSmallBlock(s);
    const std::size_t n = s.points().size();
    const std::string m1 = messageOf<ParameterError>([&] { s.addPoint(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), -1.0, 0); });
    EXPECT_MESSAGE_HAS(m1, "volume of point " + std::to_string(n));
    EXPECT_MESSAGE_HAS(m1, "= -1");
    const std::string m2 = messageOf<ParameterError>(
        [&] { s.addPoint(Eigen::Vector3d(std::nan(""), 0, 0), Eigen::Vector3d::Zero(), 1e-3, 0); });
    EXPECT_MESSAGE_HAS(m2, "position of point");
    EXPECT_EQ(s.points().size(), n);
    const std::string m3 = messageOf<ParameterError>([&] { s.addVelocityCondition({-1}, {}, 1, Eigen::Vector3d::Zero(), 0); });
    EXPECT_MESSAGE_HAS(m3, "node index = -1");
    const std::string m4 = messageOf<ParameterError>([&] { s.addVelocityCondition({0}, {}, 4, Eigen::Vector3d::Zero(), 0); });
    EXPECT_MESSAGE_HAS(m4, "components (bit mask) = 4");
}

}  // namespace
