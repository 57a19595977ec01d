// Pre-existing cracks by phantom nodes (paper Section 3.3.1, pkg/PhantomNodes.*): the crossing
// rule (2D segments and polylines, 3D planar polygons, the tips, points on the crack), the marked
// nodes against an independent computation of the cut cells, twin numbering, several cracks, and
// through the Solver: no twins without cracks, momentum conservation, faces that separate with
// no stress, and cracks that move with a translating body.
#include <algorithm>
#include <set>
#include <utility>

#include "test_helpers.hpp"

namespace {

using emp::GimpKernel;
using emp::Grid;
using emp::LinearKernel;
using emp::PhantomNodes;
using emp::Solver;
using emptest::to3;
using emptest::Vec;

Vec<2> v2(double x, double y) { return Vec<2>(x, y); }
Vec<3> v3(double x, double y, double z) { return Vec<3>(x, y, z); }

template <int D> Grid<D> makeGrid(const Vec<D>& origin, double h, const std::array<int, D>& n)
{
    Grid<D> g;
    g.resize(origin, h, n);
    return g;
}

/// Lattice index (i, j[, k]) of a regular node.
template <int D> std::array<int, D> nodeIndex(const Grid<D>& g, int I)
{
    std::array<int, D> ijk;
    for (int d = D - 1; d >= 0; --d) {
        ijk[d] = I / g.stride[d];
        I -= ijk[d] * g.stride[d];
    }
    return ijk;
}

template <int D> int nodeAt(const Grid<D>& g, const std::array<int, D>& ijk)
{
    int I = 0;
    for (int d = 0; d < D; ++d) I += ijk[d] * g.stride[d];
    return I;
}

/// Independent: corners of the given cells and of `rings` cells around each, clipped to the grid.
template <int D>
std::set<int> dilatedCorners(const Grid<D>& g, const std::set<std::array<int, D>>& cells, int rings)
{
    std::set<int> nodes;
    for (const auto& c : cells) {
        std::array<int, D> lo, hi;
        for (int d = 0; d < D; ++d) {
            lo[d] = std::max(0, c[d] - rings);
            hi[d] = std::min(g.n[d], c[d] + 2 + rings);
        }
        emptest::forBox<D>(lo, hi, [&](const std::array<int, D>& i) { nodes.insert(nodeAt<D>(g, i)); });
    }
    return nodes;
}

/// Independent: the cells (in cell units, origin 0, h 1) that the segment a-b meets, by clipping
/// the segment to each cell's closed box (Liang-Barsky).
std::set<std::array<int, 2>> cellsMetBySegment(const Vec<2>& a, const Vec<2>& b, int nx, int ny)
{
    std::set<std::array<int, 2>> cells;
    for (int i = 0; i < nx - 1; ++i)
        for (int j = 0; j < ny - 1; ++j) {
            double t0 = 0, t1 = 1;
            const double lo[2] = {double(i), double(j)}, hi[2] = {double(i + 1), double(j + 1)};
            bool ok = true;
            for (int d = 0; d < 2 && ok; ++d) {
                const double dd = b[d] - a[d];
                if (dd == 0) {
                    ok = a[d] >= lo[d] && a[d] <= hi[d];
                    continue;
                }
                double ta = (lo[d] - a[d]) / dd, tb = (hi[d] - a[d]) / dd;
                if (ta > tb) std::swap(ta, tb);
                t0 = std::max(t0, ta);
                t1 = std::min(t1, tb);
                ok = t0 <= t1;
            }
            if (ok) cells.insert({i, j});
        }
    return cells;
}

/// Independent segment-segment intersection (generic positions: no ties).
bool segmentsIntersect(const Vec<2>& p, const Vec<2>& q, const Vec<2>& a, const Vec<2>& b)
{
    // p + s (q - p) = a + t (b - a)
    Eigen::Matrix2d m;
    m.col(0) = q - p;
    m.col(1) = a - b;
    if (std::fabs(m.determinant()) < 1e-14) return false;
    const Eigen::Vector2d st = m.partialPivLu().solve(a - p);
    return st[0] > 0 && st[0] < 1 && st[1] > 0 && st[1] < 1;
}

/// Independent segment-triangle intersection (Moller-Trumbore, generic positions).
bool segmentHitsTriangle(const Vec<3>& p, const Vec<3>& q, const Vec<3>& a, const Vec<3>& b, const Vec<3>& c)
{
    Eigen::Matrix3d m;
    m.col(0) = p - q;
    m.col(1) = b - a;
    m.col(2) = c - a;
    if (std::fabs(m.determinant()) < 1e-14) return false;
    const Eigen::Vector3d tuv = m.partialPivLu().solve(p - a);
    return tuv[0] > 0 && tuv[0] < 1 && tuv[1] > 0 && tuv[2] > 0 && tuv[1] + tuv[2] < 1;
}

// ------------------------------------------------------------------------------------------
// Crossing rule, 2D
// ------------------------------------------------------------------------------------------

TEST(PhantomCrossing2D, SegmentAgainstASegmentCrack)
{
    PhantomNodes<2> ph;
    ASSERT_EQ(ph.addCrack({v2(0, 0), v2(2, 0)}), 0);
    EXPECT_TRUE(ph.crosses(0, v2(1, -1), v2(1, 1)));
    EXPECT_TRUE(ph.crosses(0, v2(1, 1), v2(1, -1)));
    EXPECT_TRUE(ph.crosses(0, v2(0.5, -0.1), v2(1.7, 0.3)));
    EXPECT_TRUE(ph.crosses(0, v2(1.99, -1e-3), v2(1.99, 1e-3)));  // just behind the tip
    EXPECT_FALSE(ph.crosses(0, v2(1, 0.1), v2(1, 1)));             // both above
    EXPECT_FALSE(ph.crosses(0, v2(1, -1), v2(1, -0.1)));           // both below
    EXPECT_FALSE(ph.crosses(0, v2(1, -1), v2(1, -1e-9)));          // stops short of the crack
    EXPECT_FALSE(ph.crosses(0, v2(-1, 0.5), v2(3, 0.5)));          // parallel
    EXPECT_FALSE(ph.crosses(0, v2(-1, 0), v2(-0.5, 0)));           // on the line, off the crack
}

TEST(PhantomCrossing2D, SegmentPassingBeyondATipDoesNotCross)
{
    PhantomNodes<2> ph;
    ph.addCrack({v2(0, 0), v2(2, 0)});
    EXPECT_FALSE(ph.crosses(0, v2(2.01, -1), v2(2.01, 1)));
    EXPECT_FALSE(ph.crosses(0, v2(-0.01, -1), v2(-0.01, 1)));
    // Its line crosses the crack's line beyond the tip (at x = 2.5).
    EXPECT_FALSE(ph.crosses(0, v2(1.5, -0.1), v2(3, 0.05)));
    // The same segment, steeper, crosses at x = 1.6: behind the tip.
    EXPECT_TRUE(ph.crosses(0, v2(1.5, -0.1), v2(1.9, 0.3)));
    // Through a tip exactly: no crossing, at either end of the crack.
    EXPECT_FALSE(ph.crosses(0, v2(2, -1), v2(2, 1)));
    EXPECT_FALSE(ph.crosses(0, v2(0, -1), v2(0, 1)));
    EXPECT_FALSE(ph.crosses(0, v2(1, -1), v2(3, 1)));
    EXPECT_FALSE(ph.crosses(0, v2(-1, -1), v2(1, 1)));
}

TEST(PhantomCrossing2D, PointOnTheCrackIsOnThePositiveSide)
{
    // Positive side: left of the crack direction.
    PhantomNodes<2> ph;
    ph.addCrack({v2(0, 0), v2(2, 0)});  // left = +y
    ph.addCrack({v2(2, 0), v2(0, 0)});  // the same line reversed: left = -y
    const Vec<2> on(1.0, 0.0), up(1.2, 0.8), down(0.7, -0.9);
    EXPECT_FALSE(ph.crosses(0, on, up));
    EXPECT_FALSE(ph.crosses(0, up, on));
    EXPECT_TRUE(ph.crosses(0, on, down));
    EXPECT_TRUE(ph.crosses(0, down, on));
    EXPECT_TRUE(ph.crosses(1, on, up));
    EXPECT_TRUE(ph.crosses(1, up, on));
    EXPECT_FALSE(ph.crosses(1, on, down));
    EXPECT_FALSE(ph.crosses(1, down, on));
    // Both ends on the crack: same side, no crossing.
    EXPECT_FALSE(ph.crosses(0, v2(0.3, 0), v2(1.7, 0)));
    // Inclined crack: a point on it, exactly representable (slope 1/2 on a dyadic lattice).
    PhantomNodes<2> q;
    q.addCrack({v2(0, 0), v2(4, 2)});  // left is the side of (-1, 2)
    const Vec<2> onIncl(2.0, 1.0);
    EXPECT_FALSE(q.crosses(0, onIncl, onIncl + v2(-0.3, 0.6)));
    EXPECT_TRUE(q.crosses(0, onIncl, onIncl + v2(0.3, -0.6)));
}

TEST(PhantomCrossing2D, PolylineCountsCrossingsByParity)
{
    PhantomNodes<2> ph;
    ph.addCrack({v2(0, 0), v2(1, 1), v2(2, 0)});          // V
    ph.addCrack({v2(0, 0), v2(1, 1), v2(2, 0), v2(3, 1)});  // W without its last stroke
    ph.addCrack({v2(0, 0), v2(1, 0), v2(2, 0)});          // straight, with an interior vertex
    EXPECT_TRUE(ph.crosses(0, v2(-1, 0.5), v2(1, 0.5)));    // one stroke
    EXPECT_FALSE(ph.crosses(0, v2(-1, 0.5), v2(3, 0.5)));   // both strokes
    EXPECT_FALSE(ph.crosses(0, v2(0.6, 0.5), v2(1.4, 0.5)));  // inside the V, no stroke
    EXPECT_TRUE(ph.crosses(1, v2(-1, 0.5), v2(4, 0.5)));    // three strokes
    EXPECT_FALSE(ph.crosses(1, v2(-1, 0.5), v2(2.4, 0.5)));  // two strokes
    // Through an interior vertex, transversally: one crossing, counted once.
    EXPECT_TRUE(ph.crosses(2, v2(1, -1), v2(1, 1)));
    EXPECT_TRUE(ph.crosses(2, v2(0.5, -1), v2(1.5, 1)));
}

TEST(PhantomCrossing2D, AgreesWithIndependentIntersectionCount)
{
    const std::vector<Vec<2>> poly = {v2(0.13, 0.21), v2(1.37, 0.93), v2(2.11, 0.17), v2(3.05, 1.41)};
    PhantomNodes<2> ph;
    ph.addCrack(poly);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> ux(-0.5, 3.5), uy(-0.5, 2.0);
    int crossings = 0;
    for (int n = 0; n < 20000; ++n) {
        const Vec<2> p(ux(rng), uy(rng)), q(ux(rng), uy(rng));
        int count = 0;
        for (std::size_t i = 0; i + 1 < poly.size(); ++i) count += segmentsIntersect(p, q, poly[i], poly[i + 1]);
        const bool expect = count % 2 == 1;
        ASSERT_EQ(ph.crosses(0, p, q), expect) << "p " << p.transpose() << ", q " << q.transpose();
        ASSERT_EQ(ph.crosses(0, q, p), expect);
        crossings += expect;
    }
    EXPECT_GT(crossings, 1000);  // the sample exercised both answers
}

// ------------------------------------------------------------------------------------------
// Crossing rule, 3D
// ------------------------------------------------------------------------------------------

TEST(PhantomCrossing3D, SquareCrackInsideAndOutside)
{
    PhantomNodes<3> ph;
    // Counter-clockwise seen from +z: Newell normal +z.
    ph.addCrack({v3(0, 0, 0.5), v3(1, 0, 0.5), v3(1, 1, 0.5), v3(0, 1, 0.5)});
    EXPECT_TRUE(ph.crosses(0, v3(0.5, 0.5, 0), v3(0.5, 0.5, 1)));
    EXPECT_TRUE(ph.crosses(0, v3(0.5, 0.5, 1), v3(0.5, 0.5, 0)));
    EXPECT_TRUE(ph.crosses(0, v3(0.2, 0.3, 0), v3(0.7, 0.9, 1)));   // meets the plane at (0.45, 0.6)
    EXPECT_TRUE(ph.crosses(0, v3(0.98, 0.02, 0.4), v3(0.99, 0.01, 0.6)));
    EXPECT_FALSE(ph.crosses(0, v3(1.5, 0.5, 0), v3(1.5, 0.5, 1)));   // beside the crack
    EXPECT_FALSE(ph.crosses(0, v3(0.5, -0.2, 0), v3(0.5, -0.2, 1)));
    EXPECT_FALSE(ph.crosses(0, v3(0.8, 0.5, 0), v3(1.6, 0.5, 1)));   // meets the plane at x = 1.2
    EXPECT_FALSE(ph.crosses(0, v3(0.5, 0.5, 0), v3(0.5, 0.5, 0.49)));  // stops short
    EXPECT_FALSE(ph.crosses(0, v3(0.1, 0.2, 0.7), v3(0.9, 0.8, 0.9)));  // both above
    // A point on the crack counts as on the side of the normal (+z).
    EXPECT_FALSE(ph.crosses(0, v3(0.5, 0.5, 0.5), v3(0.4, 0.6, 1)));
    EXPECT_TRUE(ph.crosses(0, v3(0.5, 0.5, 0.5), v3(0.4, 0.6, 0)));
    // Reversed orientation: normal -z, so the on-plane point is below.
    PhantomNodes<3> r;
    r.addCrack({v3(0, 1, 0.5), v3(1, 1, 0.5), v3(1, 0, 0.5), v3(0, 0, 0.5)});
    EXPECT_TRUE(r.crosses(0, v3(0.5, 0.5, 0.5), v3(0.4, 0.6, 1)));
    EXPECT_FALSE(r.crosses(0, v3(0.5, 0.5, 0.5), v3(0.4, 0.6, 0)));
}

TEST(PhantomCrossing3D, InclinedPolygonAgreesWithIndependentTriangleTest)
{
    // A convex quadrilateral in the plane z = 0.3 x + 0.2 y + 0.4 (split into two triangles for
    // the independent test), and a triangle in a steep plane (dominant axis x).
    auto z = [](double x, double y) { return 0.3 * x + 0.2 * y + 0.4; };
    const std::vector<Vec<3>> quad = {v3(0.1, 0.2, z(0.1, 0.2)), v3(1.7, 0.1, z(1.7, 0.1)),
                                      v3(1.9, 1.3, z(1.9, 1.3)), v3(0.3, 1.6, z(0.3, 1.6))};
    const std::vector<Vec<3>> tri = {v3(1.0, 0.1, 0.2), v3(1.3, 1.8, 0.4), v3(0.8, 0.9, 1.9)};
    PhantomNodes<3> ph;
    ph.addCrack(quad);
    ph.addCrack(tri);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-0.3, 2.2);
    int hits[2] = {0, 0};
    for (int n = 0; n < 20000; ++n) {
        const Vec<3> p(u(rng), u(rng), u(rng)), q(u(rng), u(rng), u(rng));
        const bool e0 = segmentHitsTriangle(p, q, quad[0], quad[1], quad[2]) ||
                        segmentHitsTriangle(p, q, quad[0], quad[2], quad[3]);
        const bool e1 = segmentHitsTriangle(p, q, tri[0], tri[1], tri[2]);
        ASSERT_EQ(ph.crosses(0, p, q), e0) << "p " << p.transpose() << ", q " << q.transpose();
        ASSERT_EQ(ph.crosses(1, p, q), e1) << "p " << p.transpose() << ", q " << q.transpose();
        ASSERT_EQ(ph.crosses(0, q, p), e0);
        hits[0] += e0;
        hits[1] += e1;
    }
    EXPECT_GT(hits[0], 500);
    EXPECT_GT(hits[1], 200);
}

TEST(PhantomCrossing, BadCracksAreRefused)
{
    PhantomNodes<2> p2;
    EXPECT_THROW(p2.addCrack({v2(0, 0)}), emp::ParameterError);
    EXPECT_THROW(p2.addCrack({v2(0, 0), v2(0, 0)}), emp::ParameterError);
    PhantomNodes<3> p3;
    EXPECT_THROW(p3.addCrack({v3(0, 0, 0), v3(1, 0, 0)}), emp::ParameterError);
    EXPECT_THROW(p3.addCrack({v3(0, 0, 0), v3(1, 0, 0), v3(2, 0, 0)}), emp::ParameterError);  // no area
    EXPECT_THROW(p3.addCrack({v3(0, 0, 0), v3(1, 0, 0), v3(1, 1, 0), v3(0, 1, 0.1)}), emp::ParameterError);
    EXPECT_TRUE(p2.empty());
    EXPECT_TRUE(p3.empty());
}

// ------------------------------------------------------------------------------------------
// Marked nodes and twins
// ------------------------------------------------------------------------------------------

TEST(PhantomMarking, HorizontalCrackMarksCutCellsPlusRings)
{
    // Grid with origin (-1, -0.5) and h = 0.25; crack at y = 5.4 cells from x = 1.3 to 7.6 cells.
    const double h = 0.25;
    const Vec<2> o(-1.0, -0.5);
    const Grid<2> g = makeGrid<2>(o, h, {14, 12});
    auto at = [&](double i, double j) { return Vec<2>(o + h * v2(i, j)); };
    for (int rings = 0; rings <= 2; ++rings) {
        PhantomNodes<2> ph;
        ph.addCrack({at(1.3, 5.4), at(7.6, 5.4)});
        const int twins = ph.update(g, rings);
        std::set<std::array<int, 2>> cut;
        for (int i = 1; i <= 7; ++i) cut.insert({i, 5});
        const std::set<int> expect = dilatedCorners<2>(g, cut, rings);
        const std::vector<int>& marked = ph.markedNodes();
        EXPECT_EQ(std::set<int>(marked.begin(), marked.end()), expect) << "rings " << rings;
        EXPECT_TRUE(std::is_sorted(marked.begin(), marked.end()));
        EXPECT_EQ(twins, static_cast<int>(expect.size()));
        EXPECT_EQ(ph.numTwins(), twins);
        // Explicitly: nothing beyond the tip cell's ring, nothing above or below the rings.
        for (int I = 0; I < g.numNodes(); ++I) {
            const auto ij = nodeIndex<2>(g, I);
            if (ij[0] > 8 + rings || ij[0] < 1 - rings || ij[1] > 6 + rings || ij[1] < 5 - rings)
                EXPECT_FALSE(ph.marked(I)) << "node " << ij[0] << "," << ij[1] << ", rings " << rings;
        }
    }
}

TEST(PhantomMarking, InclinedPolylineMarksTheCellsItMeets)
{
    const Grid<2> g = makeGrid<2>(Vec<2>::Zero(), 1.0, {16, 14});
    const std::vector<Vec<2>> poly = {v2(-2.3, 1.7), v2(6.4, 6.1), v2(9.45, 3.35), v2(13.2, 11.7)};
    for (int rings : {0, 1}) {
        PhantomNodes<2> ph;
        ph.addCrack(poly);
        ph.update(g, rings);
        std::set<std::array<int, 2>> cut;
        for (std::size_t s = 0; s + 1 < poly.size(); ++s)
            for (const auto& c : cellsMetBySegment(poly[s], poly[s + 1], g.n[0], g.n[1])) cut.insert(c);
        const std::set<int> expect = dilatedCorners<2>(g, cut, rings);
        const auto& marked = ph.markedNodes();
        EXPECT_EQ(std::set<int>(marked.begin(), marked.end()), expect) << "rings " << rings;
    }
}

TEST(PhantomCrossing3D, CrossingFollowsTheVerticesWhenTheyMoveAndAfterUpdate)
{
    // update() keeps each polygon's plane for the step's P2G; moving the vertices (as
    // CrackTransport does, through the non-const vertices()) must not leave crosses() on the old
    // plane, before or after the next update().
    const Grid<3> g = makeGrid<3>(v3(0, 0, 0), 1.0, {10, 10, 10});
    PhantomNodes<3> ph;
    ph.addCrack({v3(1.6, 2.6, 3.3), v3(4.4, 2.6, 3.3), v3(4.4, 5.4, 3.3), v3(1.6, 5.4, 3.3)});
    const auto crossesAt = [&](double z) { return ph.crosses(0, v3(3, 4, z - 0.2), v3(3, 4, z + 0.2)); };
    EXPECT_TRUE(crossesAt(3.3));
    ph.update(g, 1);
    EXPECT_TRUE(crossesAt(3.3));
    EXPECT_FALSE(crossesAt(4.3));
    for (auto& x : ph.vertices(0)) x[2] += 1.0;  // the crack moves up by one cell
    EXPECT_FALSE(crossesAt(3.3));
    EXPECT_TRUE(crossesAt(4.3));
    ph.update(g, 1);
    EXPECT_FALSE(crossesAt(3.3));
    EXPECT_TRUE(crossesAt(4.3));
    for (auto& x : ph.vertices(0)) std::swap(x[0], x[1]);  // mirrored: the normal turns over
    ph.update(g, 1);
    EXPECT_TRUE(ph.crosses(0, v3(4, 3, 4.3), v3(4, 3, 4.5)));  // from on the crack, now below it
}

TEST(PhantomMarking, RectangleIn3DMarksCutCellsPlusRings)
{
    const Grid<3> g = makeGrid<3>(v3(0, 0, 0), 1.0, {10, 10, 10});
    PhantomNodes<3> ph;
    ph.addCrack({v3(1.6, 2.6, 3.3), v3(4.4, 2.6, 3.3), v3(4.4, 5.4, 3.3), v3(1.6, 5.4, 3.3)});
    ph.update(g, 1);
    std::set<std::array<int, 3>> cut;
    for (int i = 1; i <= 4; ++i)
        for (int j = 2; j <= 5; ++j) cut.insert({i, j, 3});
    const std::set<int> expect = dilatedCorners<3>(g, cut, 1);
    const auto& marked = ph.markedNodes();
    EXPECT_EQ(std::set<int>(marked.begin(), marked.end()), expect);
    EXPECT_EQ(ph.numTwins(), static_cast<int>(expect.size()));
}

TEST(PhantomMarking, InclinedPolygonIn3DMarksAtLeastTheCellsItMeets)
{
    // Cells met, from a dense sample of the triangle: the marked set must contain their
    // corners (plus the ring) and stay within one more ring of them.
    const Grid<3> g = makeGrid<3>(v3(0, 0, 0), 1.0, {12, 12, 12});
    const Vec<3> a(1.3, 2.2, 2.7), b(8.6, 3.1, 5.9), c(3.4, 9.2, 4.3);
    PhantomNodes<3> ph;
    ph.addCrack({a, b, c});
    ph.update(g, 1);
    std::set<std::array<int, 3>> met;
    const int n = 400;
    for (int i = 0; i <= n; ++i)
        for (int j = 0; i + j <= n; ++j) {
            const Vec<3> x = a + (double(i) / n) * (b - a) + (double(j) / n) * (c - a);
            met.insert({int(std::floor(x[0])), int(std::floor(x[1])), int(std::floor(x[2]))});
        }
    // Marking is conservative in 3D (cells of a column the plane crosses, columns within half a
    // cell diagonal of the polygon): extra cells lie within two cells of those met.
    const std::set<int> inner = dilatedCorners<3>(g, met, 1), outer = dilatedCorners<3>(g, met, 3);
    const std::set<int> marked(ph.markedNodes().begin(), ph.markedNodes().end());
    for (int I : inner) EXPECT_TRUE(marked.count(I)) << "node " << I << " not marked";
    for (int I : marked) EXPECT_TRUE(outer.count(I)) << "node " << I << " marked far from the crack";
}

TEST(PhantomMarking, TwinsAreNumberedAfterRegularNodesDeterministically)
{
    const Grid<2> g = makeGrid<2>(Vec<2>::Zero(), 1.0, {14, 12});
    const int nn = g.numNodes();
    const std::vector<Vec<2>> crack = {v2(1.3, 5.4), v2(7.6, 5.4)};
    PhantomNodes<2> a, b;
    a.addCrack(crack);
    b.addCrack(crack);
    const int na = a.update(g, 1);
    ASSERT_EQ(na, b.update(g, 1));
    // Twin of the k-th marked node (ascending index) is nn + k.
    const std::vector<int> marked = a.markedNodes();
    for (std::size_t k = 0; k < marked.size(); ++k) {
        std::vector<int> ta, tb;
        a.forEachTwin(marked[k], [&](int t) { ta.push_back(t); });
        b.forEachTwin(marked[k], [&](int t) { tb.push_back(t); });
        ASSERT_EQ(ta.size(), 1u);
        EXPECT_EQ(ta[0], nn + static_cast<int>(k));
        EXPECT_EQ(ta, tb);
    }
    // Unmarked nodes have no twin.
    for (int I = 0; I < nn; ++I)
        if (!a.marked(I)) a.forEachTwin(I, [&](int) { ADD_FAILURE() << "unmarked node " << I << " has a twin"; });
    // Moving the crack away and back gives the same numbering (no stale marks).
    a.vertices(0)[0] += v2(3.0, -2.0);
    a.vertices(0)[1] += v2(3.0, -2.0);
    a.update(g, 1);
    EXPECT_NE(a.markedNodes(), marked);
    a.vertices(0) = crack;
    EXPECT_EQ(a.update(g, 1), na);
    EXPECT_EQ(a.markedNodes(), marked);
    for (std::size_t k = 0; k < marked.size(); ++k)
        a.forEachTwin(marked[k], [&](int t) { EXPECT_EQ(t, nn + static_cast<int>(k)); });
}

TEST(PhantomMarking, SeveralCracksGetSeparateTwins)
{
    const Grid<2> g = makeGrid<2>(Vec<2>::Zero(), 1.0, {14, 12});
    const int nn = g.numNodes();
    PhantomNodes<2> ph, onlyA, onlyB;
    const std::vector<Vec<2>> A = {v2(1.3, 3.4), v2(6.6, 3.4)}, B = {v2(2.2, 4.6), v2(9.7, 4.6)};
    ph.addCrack(A);
    ph.addCrack(B);
    onlyA.addCrack(A);
    onlyB.addCrack(B);
    const int na = onlyA.update(g, 1), nb = onlyB.update(g, 1);
    ASSERT_EQ(ph.update(g, 1), na + nb);
    std::set<int> all;
    int shared = 0;
    for (int I = 0; I < nn; ++I) {
        std::vector<int> t;
        ph.forEachTwin(I, [&](int x) { t.push_back(x); });
        const std::size_t expect = std::size_t(onlyA.marked(I)) + std::size_t(onlyB.marked(I));
        ASSERT_EQ(t.size(), expect) << "node " << I;
        EXPECT_EQ(ph.marked(I), expect > 0);
        shared += expect == 2;
        for (int x : t) {
            EXPECT_GE(x, nn);
            EXPECT_LT(x, nn + na + nb);
            EXPECT_TRUE(all.insert(x).second) << "twin " << x << " given twice";
        }
        if (expect == 2) EXPECT_LT(t[0], nn + na);  // crack 0's twins first
    }
    EXPECT_GT(shared, 0);  // the two cracks' marked regions overlap
    EXPECT_EQ(static_cast<int>(all.size()), na + nb);
    // A point between the cracks uses crack A's twin below and crack B's twin above.
    const Vec<2> p(4.1, 4.0);
    const int below = nodeAt<2>(g, {4, 3}), above = nodeAt<2>(g, {4, 5}), level = nodeAt<2>(g, {4, 4});
    int twinA = -1, twinB = -1;
    std::vector<int> tb, ta;
    ph.forEachTwin(below, [&](int t) { tb.push_back(t); });
    ph.forEachTwin(above, [&](int t) { ta.push_back(t); });
    ASSERT_EQ(tb.size(), 2u);
    ASSERT_EQ(ta.size(), 2u);
    twinA = tb[0];  // crack 0's twin of the node below
    twinB = ta[1];  // crack 1's twin of the node above
    EXPECT_EQ(ph.map(p, below, g.nodePosition(below)), twinA);
    EXPECT_EQ(ph.map(p, above, g.nodePosition(above)), twinB);
    EXPECT_EQ(ph.map(p, level, g.nodePosition(level)), level);
}

TEST(PhantomMarking, NodesAheadOfTheTipStayShared)
{
    // Crack tip in the middle of a cell at (7.6, 5.4). A point and a node both ahead of the tip
    // are never separated, and a point ahead of the tip by more than the uGIMP reach (1.5 cells)
    // uses only regular nodes.
    const Grid<2> g = makeGrid<2>(Vec<2>::Zero(), 1.0, {16, 12});
    PhantomNodes<2> ph;
    ph.addCrack({v2(-0.7, 5.4), v2(7.6, 5.4)});
    ph.update(g, 1);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> ux(7.6, 12.0), uy(3.0, 8.0);
    for (int n = 0; n < 2000; ++n) {
        const Vec<2> x(ux(rng), uy(rng));
        const int base[2] = {GimpKernel::base(x[0]), GimpKernel::base(x[1])};
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 3; ++i) {
                const int I = nodeAt<2>(g, {base[0] + i, base[1] + j});
                if (!ph.marked(I)) continue;
                const Vec<2> xI = g.nodePosition(I);
                if (xI[0] > 7.6 || x[0] >= 7.6 + 1.5)
                    ASSERT_EQ(ph.map(x, I, xI), I) << "point " << x.transpose() << ", node " << xI.transpose();
            }
    }
}

/// Points on either face of a crack map every marked node on the other side to its twin, and
/// the nodes on their own side to themselves (generic 30 degree crack in 2D, tilted polygon in 3D).
TEST(PhantomMarking, FacesMapToTheTwinsOfTheOtherSide2D)
{
    const Grid<2> g = makeGrid<2>(Vec<2>::Zero(), 1.0, {20, 16});
    const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
    const Vec<2> a(2.13, 3.07), t(c, s), nrm(-s, c);  // direction and left normal
    const double len = 12.0;
    PhantomNodes<2> ph;
    ph.addCrack({a, Vec<2>(a + len * t)});
    ph.update(g, 1);
    int twinsUsed = 0;
    for (double along = 2.5; along <= len - 2.5; along += 0.37)
        for (double off : {-0.61, -0.23, -0.04, 0.04, 0.23, 0.61}) {
            const Vec<2> x = a + along * t + off * nrm;
            const int base[2] = {GimpKernel::base(x[0]), GimpKernel::base(x[1])};
            for (int j = 0; j < 3; ++j)
                for (int i = 0; i < 3; ++i) {
                    const int I = nodeAt<2>(g, {base[0] + i, base[1] + j});
                    const Vec<2> xI = g.nodePosition(I);
                    const bool otherSide = ((xI - a).dot(nrm) >= 0) != (off > 0);
                    if (!ph.marked(I)) {
                        ASSERT_FALSE(otherSide) << "node " << xI.transpose() << " across the crack is not marked";
                        continue;
                    }
                    int twin = -1;
                    ph.forEachTwin(I, [&](int tw) { twin = tw; });
                    ASSERT_EQ(ph.map(x, I, xI), otherSide ? twin : I)
                        << "point " << x.transpose() << ", node " << xI.transpose();
                    twinsUsed += otherSide;
                }
        }
    EXPECT_GT(twinsUsed, 100);
}

/// The stencil's mapping (Stencil::mapAcrossCracks: node positions from its lattice coordinates,
/// the points whose support box no crack comes near skipped by PhantomNodes::clearOf, and a remap
/// slot only when a twin replaces a node) is the plain rule node by node: each marked node I of
/// the support maps to ph.map(x, I, Grid::nodePosition(I)), the others stay. Points on a grid
/// whose spacing and origin are not round numbers, around a polyline crack, some exactly on its
/// vertices and segments.
/// With `memo`, the points in turn share one Stencil::SupportMemo (as P2G's runs do); memoHits
/// counts the points whose support the memo already held.
template <int D, class K>
void expectStencilMappingIsThePlainRule(const Grid<D>& g, const PhantomNodes<D>& ph, const std::vector<Vec<D>>& xs,
                                        int& twinsUsed, int& markedButRegular, bool memo = false, int* memoHits = nullptr)
{
    using St = emp::Stencil<D, K>;
    Grid<D> gm = g;
    gm.remap.assign(St::NS, -7);
    typename St::SupportMemo m;
    for (const Vec<D>& x : xs) {
        St st;
        st.compute(x, gm, emp::HalfWidth(0.25));
        if (memoHits) *memoHits += memo && m.first == st.first;
        st.mapAcrossCracks(x, gm, ph, 0, memo ? &m : nullptr);
        bool changed = false, marked = false;
        int base[D];
        for (int d = 0; d < D; ++d) base[d] = st.baseOf(gm, d);
        for (int k = 0; k < St::NS; ++k) {
            const int I = st.regularNode(gm, k);
            const int expected = ph.marked(I) ? ph.map(x, I, gm.nodePosition(I)) : I;
            const int got = st.regular() ? I : gm.remap[st.remap + k];
            ASSERT_EQ(got, expected) << "point " << x.transpose() << ", support node " << k;
            changed = changed || expected != I;
            marked = marked || ph.marked(I);
            for (int d = 0; d < D; ++d)  // the position from the lattice coordinates, bit for bit
                ASSERT_EQ(st.nodePosition(gm, base, k)[d], gm.nodePosition(I)[d]);
        }
        ASSERT_EQ(st.regular(), !changed) << "point " << x.transpose() << ": a remap slot only when a twin is used";
        twinsUsed += changed;
        markedButRegular += marked && !changed;
    }
}

TEST(PhantomMarking, StencilMappingIsThePlainRule2D)
{
    const double h = 0.0137;
    const Vec<2> origin(-0.0371, 0.0213);
    const Grid<2> g = makeGrid<2>(origin, h, {40, 32});
    PhantomNodes<2> ph;
    const std::vector<Vec<2>> crack = {origin + h * v2(3.3, 15.1), origin + h * v2(14.0, 17.2), origin + h * v2(22.5, 12.4),
                                       origin + h * v2(30.2, 16.0)};
    ph.addCrack(crack);
    ph.addCrack({origin + h * v2(9.7, 4.2), origin + h * v2(9.7, 11.6)});  // a second, vertical
    // A third through a column of nodes (x = origin + 16 h, nodePosition's number: nodes exactly
    // on it), across the first, so that nodes near the two have a twin of each (the first crack
    // that maps a node decides); a fourth, a polyline along a row of nodes.
    ph.addCrack({origin + h * v2(16.0, 9.0), origin + h * v2(16.0, 21.0)});
    ph.addCrack({origin + h * v2(4.0, 24.0), origin + h * v2(8.0, 24.0), origin + h * v2(12.0, 26.0)});
    ph.update(g, GimpKernel::crackRings);
    std::vector<Vec<2>> xs;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> ux(2.0, 37.0), uy(2.0, 29.0);
    for (int i = 0; i < 6000; ++i) xs.push_back(origin + h * v2(ux(rng), uy(rng)));
    for (std::size_t c = 0; c < ph.numCracks(); ++c) {
        const auto& v = ph.vertices(static_cast<int>(c));
        for (std::size_t i = 0; i + 1 < v.size(); ++i)
            for (double t : {0.0, 0.25, 0.5, 1.0}) xs.push_back(v[i] + t * (v[i + 1] - v[i]));  // on the crack
    }
    for (int j = 8; j < 27; ++j)  // on nodes
        for (int i = 3; i < 14; ++i) xs.push_back(g.nodePosition(i + j * g.stride[1]));
    int twins = 0, regular = 0;
    expectStencilMappingIsThePlainRule<2, GimpKernel>(g, ph, xs, twins, regular);
    EXPECT_GT(twins, 300);
    EXPECT_GT(regular, 300);  // near the cracks, yet no segment to a node crosses one
    {
        // The points in the order of their base nodes (P2G's runs: often several of one support
        // after another), a memo of the support's findings carried from point to point.
        std::vector<std::pair<int, int>> byBase;
        for (std::size_t i = 0; i < xs.size(); ++i) {
            emp::Stencil<2, GimpKernel> st;
            st.compute(xs[i], g, emp::HalfWidth(0.25));
            byBase.emplace_back(st.first, static_cast<int>(i));
        }
        std::sort(byBase.begin(), byBase.end());
        std::vector<Vec<2>> sorted;
        for (const auto& b : byBase) sorted.push_back(xs[b.second]);
        int memoTwins = 0, memoRegular = 0, hits = 0;
        expectStencilMappingIsThePlainRule<2, GimpKernel>(g, ph, sorted, memoTwins, memoRegular, true, &hits);
        EXPECT_EQ(memoTwins, twins);
        EXPECT_EQ(memoRegular, regular);
        EXPECT_GT(hits, 3000);
    }
    {
        // The cracks' geometry stale (moved vertices not yet update()d: clearOf from the
        // vertices, not from update()'s segment records): the same mapping.
        PhantomNodes<2> stale = ph;
        for (std::size_t c = 0; c < stale.numCracks(); ++c) stale.vertices(static_cast<int>(c));
        int staleTwins = 0, staleRegular = 0;
        expectStencilMappingIsThePlainRule<2, GimpKernel>(g, stale, xs, staleTwins, staleRegular);
        EXPECT_EQ(staleTwins, twins);
        EXPECT_EQ(staleRegular, regular);
    }
    int linearTwins = 0, linearRegular = 0;
    PhantomNodes<2> ph1;
    ph1.addCrack(crack);
    ph1.update(g, LinearKernel::crackRings);
    expectStencilMappingIsThePlainRule<2, LinearKernel>(g, ph1, xs, linearTwins, linearRegular);
    EXPECT_GT(linearTwins, 100);
}

TEST(PhantomMarking, StencilMappingIsThePlainRule3D)
{
    const double h = 0.021;
    const Vec<3> origin(0.013, -0.029, 0.0071);
    const Grid<3> g = makeGrid<3>(origin, h, {16, 16, 16});
    PhantomNodes<3> ph;
    ph.addCrack({origin + h * v3(2.5, 2.5, 7.3), origin + h * v3(9.5, 2.5, 8.1), origin + h * v3(9.5, 13.5, 8.1),
                 origin + h * v3(2.5, 13.5, 7.3)});
    ph.update(g, GimpKernel::crackRings);
    std::vector<Vec<3>> xs;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(2.0, 13.0);
    for (int i = 0; i < 4000; ++i) xs.push_back(origin + h * v3(u(rng), u(rng), u(rng)));
    int twins = 0, regular = 0;
    expectStencilMappingIsThePlainRule<3, GimpKernel>(g, ph, xs, twins, regular);
    EXPECT_GT(twins, 200);
    EXPECT_GT(regular, 100);
}

TEST(PhantomMarking, FacesMapToTheTwinsOfTheOtherSide3D)
{
    const Grid<3> g = makeGrid<3>(v3(0, 0, 0), 1.0, {14, 14, 14});
    // Square of side 8 in a plane tilted 30 degrees about x, centred at (6.1, 6.3, 6.2).
    const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
    const Vec<3> ctr(6.1, 6.3, 6.2), e1(1, 0, 0), e2(0, c, s), nrm = e1.cross(e2);
    std::vector<Vec<3>> sq;
    for (auto [u, w] : {std::pair{-4, -4}, {4, -4}, {4, 4}, {-4, 4}}) sq.push_back(ctr + u * e1 + w * e2);
    PhantomNodes<3> ph;
    ph.addCrack(sq);  // counter-clockwise about nrm: Newell normal along nrm
    ph.update(g, 1);
    int twinsUsed = 0;
    for (double u = -1.3; u <= 1.3; u += 0.37)
        for (double w = -1.3; w <= 1.3; w += 0.41)
            for (double off : {-0.47, -0.05, 0.05, 0.47}) {
                const Vec<3> x = ctr + u * e1 + w * e2 + off * nrm;
                int base[3];
                for (int d = 0; d < 3; ++d) base[d] = GimpKernel::base(x[d]);
                for (int k = 0; k < 3; ++k)
                    for (int j = 0; j < 3; ++j)
                        for (int i = 0; i < 3; ++i) {
                            const int I = nodeAt<3>(g, {base[0] + i, base[1] + j, base[2] + k});
                            const Vec<3> xI = g.nodePosition(I);
                            const bool otherSide = ((xI - ctr).dot(nrm) >= 0) != (off > 0);
                            if (!ph.marked(I)) {
                                ASSERT_FALSE(otherSide) << "node " << xI.transpose() << " not marked";
                                continue;
                            }
                            int twin = -1;
                            ph.forEachTwin(I, [&](int tw) { twin = tw; });
                            ASSERT_EQ(ph.map(x, I, xI), otherSide ? twin : I)
                                << "point " << x.transpose() << ", node " << xI.transpose();
                            twinsUsed += otherSide;
                        }
            }
    EXPECT_GT(twinsUsed, 100);
}

// ------------------------------------------------------------------------------------------
// Through the Solver
// ------------------------------------------------------------------------------------------

using emptest::Config;
template <class C> struct PhantomSolverTest : ::testing::Test {};
using Configs = emptest::AllSolvers;
TYPED_TEST_SUITE(PhantomSolverTest, Configs);

constexpr double kE = 1e6, kNu = 0.3, kRho = 1000, kH = 0.1;

/// A crack across the block [lo, hi) cells at x = xc cells, reaching `out` cells beyond the block
/// (2D: segment along y; 3D: rectangle in the plane x = xc). With `tipAt` < hi[1], an edge crack
/// from below to y = tipAt cells.
template <int D> std::vector<Eigen::Vector3d> crackAcross(double xc, const std::array<int, D>& lo,
                                                          const std::array<int, D>& hi, double out,
                                                          double tipAt = 1e300)
{
    const double y0 = (lo[1] - out) * kH, y1 = std::min(hi[1] + out, tipAt) * kH;
    if constexpr (D == 2) {
        return {Eigen::Vector3d(xc * kH, y0, 0), Eigen::Vector3d(xc * kH, y1, 0)};
    } else {
        const double z0 = (lo[2] - out) * kH, z1 = (hi[2] + out) * kH;
        return {Eigen::Vector3d(xc * kH, y0, z0), Eigen::Vector3d(xc * kH, y1, z0),
                Eigen::Vector3d(xc * kH, y1, z1), Eigen::Vector3d(xc * kH, y0, z1)};
    }
}

TYPED_TEST(PhantomSolverTest, NoCracksNoTwins)
{
    constexpr int D = TypeParam::D;
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    typename TypeParam::S s(st);
    const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
    std::array<int, D> lo, hi;
    lo.fill(2);
    hi.fill(5);
    emptest::addBlock<D>(s, lo, hi, mat, [](const Vec<D>& x) { return Vec<D>(0.1 * x); });
    for (int n = 0; n < 3; ++n) s.step(0.5 * s.criticalTimeStep(), 1);
    EXPECT_TRUE(s.phantomNodes().empty());
    EXPECT_EQ(s.phantomNodes().numCracks(), 0u);
    EXPECT_EQ(s.phantomNodes().numTwins(), 0);
    EXPECT_TRUE(s.phantomNodes().markedNodes().empty());
    EXPECT_EQ(s.grid().totalNodes(), s.grid().numNodes());
}

TYPED_TEST(PhantomSolverTest, MomentumConservedWithCracks)
{
    // A free block with an edge crack and an interior crack, random velocities, no cut-off.
    constexpr int D = TypeParam::D;
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    st.ppc = 2;
    st.massCutoff = 0;
    typename TypeParam::S s(st);
    const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
    std::array<int, D> lo, hi;
    lo.fill(2);
    hi.fill(D == 2 ? 12 : 7);
    std::mt19937 rng(23 + D);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    emptest::addBlock<D>(s, lo, hi, mat, [&](const Vec<D>&) {
        Vec<D> v;
        for (int d = 0; d < D; ++d) v[d] = u(rng);
        return v;
    });
    s.addCrack(crackAcross<D>(lo[0] + 2.37, lo, hi, 0.6, hi[1] - 2.55));  // edge crack
    if constexpr (D == 2)
        s.addCrack({Eigen::Vector3d(0.63, 0.51, 0), Eigen::Vector3d(0.91, 0.77, 0), Eigen::Vector3d(1.05, 0.62, 0)});
    else
        s.addCrack({Eigen::Vector3d(0.43, 0.31, 0.52), Eigen::Vector3d(0.61, 0.33, 0.47),
                    Eigen::Vector3d(0.58, 0.57, 0.55)});
    const auto& P = s.points();
    const double totalMass = emptest::sum(P.masses());
    const Vec<D> p0 = emptest::totalMomentum<D>(P);
    double scale = 0;
    for (std::size_t p = 0; p < P.size(); ++p) scale += P.mass(p) * P.v[p].norm();
    for (int n = 0; n < 20; ++n) {
        s.step(0.4 * s.criticalTimeStep(), 2);
        ASSERT_GT(s.phantomNodes().numTwins(), 0);
        EXPECT_NEAR(emptest::sum(s.grid().mass), totalMass, 1e-13 * totalMass) << "step " << n;
        const Vec<D> p1 = emptest::totalMomentum<D>(P);
        EXPECT_LT((p1 - p0).norm(), 1e-12 * scale) << "step " << n << ": " << p0.transpose() << " -> "
                                                   << p1.transpose();
    }
    // Twins did carry mass.
    double twinMass = 0;
    for (int I = s.grid().numNodes(); I < s.grid().totalNodes(); ++I) twinMass += s.grid().mass[I];
    EXPECT_GT(twinMass, 0.01 * totalMass);
}

TYPED_TEST(PhantomSolverTest, FacesSeparateWithoutStress)
{
    // Two halves of a block moving apart at +-v: with a crack between them both halves translate
    // rigidly (no stress, velocities kept); without it the block stretches. The block is also
    // shifted off the grid-aligned lattice and the crack put at several places between the two
    // middle columns of points, so that some points reach nodes across the crack two cells away
    // (they must be marked: uGIMP needs the extra ring of cells).
    constexpr int D = TypeParam::D;
    std::array<int, D> lo, hi;
    lo.fill(2);
    hi.fill(D == 2 ? 10 : 6);
    hi[0] = D == 2 ? 16 : 10;
    const double v0 = 0.5;
    double uncut = 0;
    int config = 0;
    for (double shift : {0.0, 0.12, 0.37})
        for (double f : {0.5, 0.15, 0.85})
            for (int cracked = (config == 0 ? 0 : 1); cracked < 2; ++cracked, ++config) {
                SCOPED_TRACE("shift " + std::to_string(shift) + " cells, crack at " + std::to_string(f) +
                             " of the gap between columns, cracked " + std::to_string(cracked));
                // Middle columns of points at mid -+ 0.25 cells (ppc 2), shifted.
                const double xc = (0.5 * (lo[0] + hi[0]) - 0.25 + shift + 0.5 * f) * kH;
                emp::SolverSettings st = emptest::typicalSettings();
                st.h = kH;
                typename TypeParam::S s(st);
                const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
                emptest::addBlock<D>(s, lo, hi, mat);
                auto& P = s.points();
                for (std::size_t p = 0; p < P.size(); ++p) {
                    for (int d = 0; d < D; ++d) P.x[p][d] += (d == 0 ? shift : 0.7 * shift) * kH;
                    P.v[p][0] = P.x[p][0] < xc ? -v0 : v0;
                }
                if (cracked) s.addCrack(crackAcross<D>(xc / kH, lo, hi, 1.7));
                const std::vector<Vec<D>> x0 = P.x;
                double t = 0;
                for (int n = 0; n < 30; ++n) {
                    const double dt = 0.5 * s.criticalTimeStep();
                    s.step(dt, 1);
                    t += dt;
                }
                double worst = 0;
                for (std::size_t p = 0; p < P.size(); ++p) worst = std::max(worst, s.stressOf(p).norm());
                if (!cracked) {
                    uncut = worst;
                    EXPECT_GT(uncut, 0.05 * kE * v0 * 0.01);  // stretched
                    continue;
                }
                EXPECT_LT(worst, 1e-9 * uncut) << "cut: " << worst << " Pa, uncut: " << uncut << " Pa";
                for (std::size_t p = 0; p < P.size(); ++p) {
                    const double sign = x0[p][0] < xc ? -1.0 : 1.0;
                    ASSERT_NEAR(P.v[p][0], sign * v0, 1e-9 * v0) << "point " << p;
                    ASSERT_NEAR(P.x[p][0] - x0[p][0], sign * v0 * t, 1e-9 * v0 * t) << "point " << p;
                }
                // The crack stays between the faces.
                double leftFace = -1e300, rightFace = 1e300;
                for (std::size_t p = 0; p < P.size(); ++p) {
                    if (x0[p][0] < xc)
                        leftFace = std::max(leftFace, P.x[p][0]);
                    else
                        rightFace = std::min(rightFace, P.x[p][0]);
                }
                for (const auto& v : s.phantomNodes().vertices(0)) {
                    EXPECT_GT(v[0], leftFace);
                    EXPECT_LT(v[0], rightFace);
                }
            }
}

TYPED_TEST(PhantomSolverTest, CrackTranslatesWithTheBody)
{
    // A block with an edge crack (outer vertices 0.6 cell outside the block) and an interior
    // crack moves 4 cells diagonally: the cracks move by exactly v t, no stress appears.
    constexpr int D = TypeParam::D;
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    typename TypeParam::S s(st);
    const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
    std::array<int, D> lo, hi;
    lo.fill(4);
    hi.fill(D == 2 ? 12 : 8);
    Vec<D> v0;
    for (int d = 0; d < D; ++d) v0[d] = 0.7 - 0.3 * d;
    emptest::addBlock<D>(s, lo, hi, mat, [&](const Vec<D>&) { return v0; });
    std::array<int, D> dlo, dhi;
    for (int d = 0; d < D; ++d) {
        dlo[d] = 0;
        dhi[d] = hi[d] + 8;
    }
    Eigen::Vector3d lo3 = Eigen::Vector3d::Zero(), hi3 = Eigen::Vector3d::Zero();
    for (int d = 0; d < D; ++d) hi3[d] = dhi[d] * kH;
    if (D == 2) hi3[2] = 1;
    s.setDomain(lo3, hi3);
    s.addCrack(crackAcross<D>(lo[0] + 1.37, lo, hi, 0.6, hi[1] - 2.55));
    s.addCrack(crackAcross<D>(lo[0] + 2.61, lo, hi, D == 2 ? -1.4 : -1.1));  // interior
    std::vector<std::vector<Vec<D>>> v0s = {s.phantomNodes().vertices(0), s.phantomNodes().vertices(1)};
    double t = 0;
    const double dt = 0.5 * s.criticalTimeStep();
    const int steps = static_cast<int>(std::ceil(4 * kH / (v0.norm() * dt)));
    for (int n = 0; n < steps; ++n) {
        s.step(dt, 1);
        t += dt;
    }
    ASSERT_GT(v0.norm() * t, 4 * kH);
    for (int c = 0; c < 2; ++c)
        for (std::size_t k = 0; k < v0s[c].size(); ++k)
            EXPECT_LT((s.phantomNodes().vertices(c)[k] - v0s[c][k] - v0 * t).norm(), 1e-9 * kH)
                << "crack " << c << ", vertex " << k;
    double worst = 0;
    for (const auto& sg : emptest::stressesOf(s)) worst = std::max(worst, sg.norm());
    EXPECT_LT(worst, 1e-9 * kE * v0.norm() * dt / kH);
}

TYPED_TEST(PhantomSolverTest, CrackReachingFarOutsideTheBodyTranslatesWithIt)
{
    // A through crack and an edge crack whose outer vertices lie 2.5 cells outside the block, out
    // of reach of any material (no mass in their stencil), and a through crack whose ends lie 500
    // cells beyond the grid: they must still move with the body, or the crack turns and cuts the
    // body elsewhere.
    constexpr int D = TypeParam::D;
    emp::SolverSettings st = emptest::typicalSettings();
    st.h = kH;
    typename TypeParam::S s(st);
    const int mat = s.addMaterial(kE, kNu, kRho, false, emp::lawIndex("spectral"));
    std::array<int, D> lo, hi;
    lo.fill(4);
    hi.fill(D == 2 ? 12 : 8);
    Vec<D> v0;
    for (int d = 0; d < D; ++d) v0[d] = 0.7 - 0.3 * d;
    emptest::addBlock<D>(s, lo, hi, mat, [&](const Vec<D>&) { return v0; });
    Eigen::Vector3d lo3 = Eigen::Vector3d::Zero(), hi3 = Eigen::Vector3d::Ones();
    for (int d = 0; d < D; ++d) hi3[d] = (hi[d] + 8) * kH;
    s.setDomain(lo3, hi3);
    s.addCrack(crackAcross<D>(lo[0] + 1.37, lo, hi, 2.5));                 // through
    s.addCrack(crackAcross<D>(lo[0] + 2.61, lo, hi, 2.5, hi[1] - 2.55));  // edge
    s.addCrack(crackAcross<D>(lo[0] + 3.4, lo, hi, 500.0));              // ends far beyond the grid
    const std::vector<std::vector<Vec<D>>> start = {s.phantomNodes().vertices(0), s.phantomNodes().vertices(1),
                                                    s.phantomNodes().vertices(2)};
    double t = 0;
    const double dt = 0.5 * s.criticalTimeStep();
    const int steps = static_cast<int>(std::ceil(4 * kH / (v0.norm() * dt)));
    for (int n = 0; n < steps; ++n) {
        s.step(dt, 1);
        t += dt;
    }
    for (int c = 0; c < 3; ++c)
        for (std::size_t k = 0; k < start[c].size(); ++k)
            EXPECT_LT((s.phantomNodes().vertices(c)[k] - start[c][k] - v0 * t).norm(), 1e-9 * kH * (c == 2 ? 500 : 1))
                << "crack " << c << ", vertex " << k << " at " << s.phantomNodes().vertices(c)[k].transpose()
                << ", expected " << (start[c][k] + v0 * t).transpose();
    double worst = 0;
    for (const auto& sg : emptest::stressesOf(s)) worst = std::max(worst, sg.norm());
    EXPECT_LT(worst, 1e-9 * kE * v0.norm() * dt / kH);
}

}  // namespace
