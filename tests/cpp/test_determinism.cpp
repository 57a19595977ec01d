// Results must not depend on the number of OpenMP threads: the same scene stepped with 1 and
// with 2 threads (and 3 for uGIMP) gives bitwise identical positions, velocities, strains and stresses,
// without and with the scheduler's columns.
#include "test_helpers.hpp"

#include "Lanes.hpp"

namespace {

using emp::GimpKernel;
using emp::LinearKernel;
using emp::Solver;
using emptest::Mat;
using emptest::to3;
using emptest::Vec;

/// A block, tall along the last axis (so that the colouring uses many strips), with random
/// velocities, gravity, a fixed base and a prescribed velocity on top: stresses of both signs.
template <int D, class K>
Solver<D, K> makeScene(int columnCells = 0, emp::Transfer transfer = emp::Transfer::unset,
                       emp::StressUpdate update = emp::StressUpdate::unset)
{
    emp::SolverSettings st = emptest::typicalSettings();
    st.columnCells = columnCells;
    if (transfer != emp::Transfer::unset) st.transfer = transfer;
    if (update != emp::StressUpdate::unset) st.stressUpdate = update;
    st.h = 0.05;
    st.ppc = 2;
    st.gravity = Eigen::Vector3d(0.3, -9.81, 0.0);
    if (D == 3) st.gravity = Eigen::Vector3d(0.3, 0.2, -9.81);
    Solver<D, K> s(st);
    const int mat = s.addMaterial(1e6, 0.3, 1000, D == 2, emp::lawIndex("spectral"));
    const int soft = s.addMaterial(3e5, 0.1, 800, D == 2, emp::lawIndex("spectral"));
    std::array<int, D> lo, hi;
    lo.fill(2);
    hi.fill(D == 2 ? 14 : 6);
    hi[D - 1] = D == 2 ? 40 : 26;
    std::mt19937 rng(99);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    const std::vector<int> ids = emptest::addBlock<D>(s, lo, hi, mat, [&](const Vec<D>&) {
        Vec<D> v;
        for (int d = 0; d < D; ++d) v[d] = u(rng);
        return v;
    });
    // A second material in part of the block.
    for (std::size_t k = 0; k < ids.size(); k += 3) s.points().material[ids[k]] = soft;
    s.initialize();
    const auto& g = s.grid();
    std::vector<int> base, top;
    for (int I = 0; I < g.numNodes(); ++I) {
        const double z = g.nodePosition(I)[D - 1];
        if (z <= lo[D - 1] * st.h + 1e-12) base.push_back(I);
        if (z >= hi[D - 1] * st.h - 1e-12) top.push_back(I);
    }
    s.addVelocityCondition(base, {}, (1u << D) - 1, Eigen::Vector3d::Zero(), 0.0);
    Eigen::Vector3d vtop = Eigen::Vector3d::Zero();
    vtop[D - 1] = 0.2;
    s.addVelocityCondition(top, {}, 1u << (D - 1), vtop, 0.01);
    return s;
}

template <class T> const T& components(const T& t) { return t; }
inline emp::Mat<2> components(const emp::Sym2& t) { return t.mat(); }

template <class T> int countDifferences(const std::vector<T>& a, const std::vector<T>& b, const char* what)
{
    EXPECT_EQ(a.size(), b.size());
    int diff = 0;
    for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
        const auto ca = components(a[i]), cb = components(b[i]);
        const double* pa = ca.data();
        const double* pb = cb.data();
        for (int k = 0; k < ca.size(); ++k)
            if (!(pa[k] == pb[k])) {
                if (diff == 0) {
                    EXPECT_EQ(pa[k], pb[k]) << what << " of point " << i << ", component " << k;
                }
                ++diff;
            }
    }
    return diff;
}

template <int D, class K> void checkThreadIndependence(bool alsoThreeThreads, int columnCells = 0)
{
    Solver<D, K> a = makeScene<D, K>(columnCells), b = makeScene<D, K>(columnCells), c = makeScene<D, K>(columnCells);
    ASSERT_GE(a.grid().n[D - 1], 30);  // many colouring strips
    const auto sa = emptest::recordStresses(a), sb = emptest::recordStresses(b), sc = emptest::recordStresses(c);
    const double dt = 0.5 * a.criticalTimeStep();
    for (int n = 0; n < 50; ++n) {
        a.step(dt, 1);
        b.step(dt, 2);
        if (alsoThreeThreads) c.step(dt, 3);
    }
    const auto &A = a.points(), &B = b.points(), &C = c.points();
    EXPECT_EQ(countDifferences(A.x, B.x, "position"), 0);
    EXPECT_EQ(countDifferences(A.v, B.v, "velocity"), 0);
    EXPECT_EQ(countDifferences(A.strain, B.strain, "strain"), 0);
    EXPECT_EQ(countDifferences(*sa, *sb, "stress"), 0);
    EXPECT_EQ(countDifferences(emptest::stressesOf(a), emptest::stressesOf(b), "stressOf"), 0);
    if (alsoThreeThreads) {
        EXPECT_EQ(countDifferences(A.x, C.x, "position (3 threads)"), 0);
        EXPECT_EQ(countDifferences(*sa, *sc, "stress (3 threads)"), 0);
    }
    EXPECT_EQ(a.reaction(0), b.reaction(0));
    EXPECT_EQ(a.kineticEnergy(), b.kineticEnergy());
    // The scene is not trivial: there are stresses and the points moved.
    double maxStress = 0;
    for (const auto& s : *sa) maxStress = std::max(maxStress, s.norm());
    EXPECT_GT(maxStress, 1.0);
    EXPECT_GT(a.reaction(0).norm(), 0.0);
}

TEST(Determinism, ThreadCountDoesNotChangeResults2DGimp) { checkThreadIndependence<2, GimpKernel>(true); }
TEST(Determinism, ThreadCountDoesNotChangeResults2DLinear) { checkThreadIndependence<2, LinearKernel>(false); }
TEST(Determinism, ThreadCountDoesNotChangeResults3DGimp) { checkThreadIndependence<3, GimpKernel>(true); }
TEST(Determinism, ThreadCountDoesNotChangeResults3DLinear) { checkThreadIndependence<3, LinearKernel>(false); }

// With the scheduler's columns (Scheduler.hpp: tiles in four colours) the results are as
// independent of the thread count, with the narrowest columns each shape allows and wider ones.
TEST(Determinism, ThreadCountDoesNotChangeResultsWithColumns2DGimp) { checkThreadIndependence<2, GimpKernel>(true, 2); }
TEST(Determinism, ThreadCountDoesNotChangeResultsWithColumns2DLinear) { checkThreadIndependence<2, LinearKernel>(true, 1); }
TEST(Determinism, ThreadCountDoesNotChangeResultsWithColumns3DGimp) { checkThreadIndependence<3, GimpKernel>(true, 3); }

/// Columns change only the order of the sums at the nodes where two columns meet: the results
/// move at round-off, and they do move (the tiles' order is in effect).
template <int D, class K> void checkColumnsMoveResultsAtRoundOff(int columnCells)
{
    Solver<D, K> a = makeScene<D, K>(), b = makeScene<D, K>(columnCells);
    ASSERT_GT((a.grid().n[0] - K::S) / columnCells + 1, 3);  // several columns
    const double dt = 0.5 * a.criticalTimeStep();
    for (int n = 0; n < 50; ++n) {
        a.step(dt, 2);
        b.step(dt, 2);
    }
    double dx = 0, ds = 0, smax = 0;
    int differ = 0;
    for (std::size_t p = 0; p < a.points().size(); ++p) {
        dx = std::max(dx, (a.points().x[p] - b.points().x[p]).norm());
        ds = std::max(ds, (a.stressOf(p) - b.stressOf(p)).norm());
        smax = std::max(smax, a.stressOf(p).norm());
        differ += a.stressOf(p) != b.stressOf(p);
    }
    EXPECT_GT(differ, 0) << "columns of " << columnCells << " cells changed no sum";
    EXPECT_LT(dx, 1e-13) << "m";
    EXPECT_LT(ds, 1e-9 * smax) << "Pa, against stresses up to " << smax;
}

TEST(Determinism, ColumnsMoveResultsAtRoundOff2DGimp) { checkColumnsMoveResultsAtRoundOff<2, GimpKernel>(2); }
TEST(Determinism, ColumnsMoveResultsAtRoundOff3DLinear) { checkColumnsMoveResultsAtRoundOff<3, LinearKernel>(1); }

}  // namespace

// The lane loops (pkg/Lanes.hpp: the 2D law and co-rotational update, the 3D co-rotational
// algebra) give the same bits in every vector width the processor runs: the scene above stepped
// with the baseline's loops and with AVX2's and AVX-512's.
namespace {
template <int D, class K> void checkLaneWidthIndependence(emp::Transfer t, emp::StressUpdate u)
{
    const emp::LaneIsa widest = emp::processorLaneIsa(), before = emp::laneIsa();
    if (widest == emp::LaneIsa::baseline) GTEST_SKIP() << "this processor has neither AVX2 nor AVX-512";
    std::vector<emp::LaneIsa> widths{emp::LaneIsa::baseline, emp::LaneIsa::avx2};
    if (widest == emp::LaneIsa::avx512) widths.push_back(emp::LaneIsa::avx512);
    std::vector<Solver<D, K>> runs;
    std::vector<std::shared_ptr<std::vector<Mat<D>>>> recorded;  // (the stress pass's, in each width)
    runs.reserve(widths.size());
    for (emp::LaneIsa w : widths) {
        ASSERT_EQ(emp::setLaneIsa(w), w);
        runs.push_back(makeScene<D, K>(0, t, u));
        recorded.push_back(emptest::recordStresses(runs.back()));
        const double dt = 0.5 * runs.back().criticalTimeStep();
        for (int n = 0; n < 40; ++n) runs.back().step(dt, 1);
    }
    emp::setLaneIsa(before);
    const auto& A = runs[0].points();
    for (std::size_t k = 1; k < runs.size(); ++k) {
        SCOPED_TRACE(emp::name(widths[k]));
        const auto& B = runs[k].points();
        EXPECT_EQ(countDifferences(A.x, B.x, "position"), 0);
        EXPECT_EQ(countDifferences(A.v, B.v, "velocity"), 0);
        EXPECT_EQ(countDifferences(A.strain, B.strain, "strain"), 0);
        EXPECT_EQ(countDifferences(*recorded[0], *recorded[k], "stress"), 0);
        EXPECT_EQ(A.history, B.history);
        if (u == emp::StressUpdate::corotational)
            EXPECT_EQ(countDifferences(A.deformationGradient, B.deformationGradient, "deformation gradient"), 0);
    }
    double maxStress = 0;
    for (const auto& s : *recorded[0]) maxStress = std::max(maxStress, s.norm());
    EXPECT_GT(maxStress, 1.0);
}
}  // namespace

TEST(Determinism, LaneWidthDoesNotChangeResults2DSmallStrain)
{
    checkLaneWidthIndependence<2, GimpKernel>(emp::Transfer::flip, emp::StressUpdate::smallStrain);
}
TEST(Determinism, LaneWidthDoesNotChangeResults2DCorotational)
{
    checkLaneWidthIndependence<2, GimpKernel>(emp::Transfer::apic, emp::StressUpdate::corotational);
}
TEST(Determinism, LaneWidthDoesNotChangeResults3DCorotational)
{
    checkLaneWidthIndependence<3, GimpKernel>(emp::Transfer::flip, emp::StressUpdate::corotational);
}
