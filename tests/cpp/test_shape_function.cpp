// Properties of the 1D kernels (ShapeFunction.hpp) and of their 2D/3D tensor products
// (paper Eqs 15-16): partition of unity, zero gradient sum, linear reproduction, continuity
// across cell faces, the closed form of Eq 16 for lp = 1/4, the convolution form for any lp and
// consistency of the derivatives with finite differences.
#include <map>

#include "Stencil.hpp"
#include "test_helpers.hpp"

namespace {

using emp::GimpKernel;
using emp::LinearKernel;
using emptest::forBox;
using emptest::Mat;
using emptest::Vec;

/// uGIMP half-widths (cell units) for ppc = 1, 2, 3, 4: lp = 1/(2 ppc).
const std::vector<double> kHalfWidths = {0.5, 0.25, 1.0 / 6.0, 0.125};

/// Weights and gradients (cell units) of every node of the support of a point at xi (cell units),
/// keyed by the node's global integer index, from the tensor product N = prod_d s(xi_d - j_d).
template <int D> using WeightMap = std::map<std::array<int, D>, std::pair<double, Vec<D>>>;

template <int D, class K> WeightMap<D> weights(const Vec<D>& xi, double lp)
{
    constexpr int S = K::S;
    int base[D];
    double w[D][S], dw[D][S];
    for (int d = 0; d < D; ++d) base[d] = K::eval(xi[d], lp, w[d], dw[d]);
    WeightMap<D> out;
    std::array<int, D> lo{}, hi{};
    hi.fill(S);
    forBox<D>(lo, hi, [&](const std::array<int, D>& k) {
        std::array<int, D> node;
        double N = 1;
        Vec<D> grad;
        for (int d = 0; d < D; ++d) {
            node[d] = base[d] + k[d];
            N *= w[d][k[d]];
            grad[d] = dw[d][k[d]];
            for (int e = 0; e < D; ++e)
                if (e != d) grad[d] *= w[e][k[e]];
        }
        out[node] = {N, grad};
    });
    return out;
}

/// Largest difference of weights and of gradients between two maps (absent nodes count as 0).
template <int D> std::pair<double, double> maxDifference(const WeightMap<D>& a, const WeightMap<D>& b)
{
    double dN = 0, dG = 0;
    auto visit = [&](const WeightMap<D>& p, const WeightMap<D>& q) {
        for (const auto& [node, wg] : p) {
            const auto it = q.find(node);
            const double N2 = it == q.end() ? 0.0 : it->second.first;
            const Vec<D> g2 = it == q.end() ? Vec<D>::Zero() : it->second.second;
            dN = std::max(dN, std::fabs(wg.first - N2));
            dG = std::max(dG, (wg.second - g2).cwiseAbs().maxCoeff());
        }
    };
    visit(a, b);
    visit(b, a);
    return {dN, dG};
}

/// Offsets inside a cell where something happens: cell faces (0), the switch of the GIMP base
/// node (0.5) and the breakpoints of the piecewise GIMP function (+-lp, +-(1-lp)).
std::vector<double> specialOffsets(double lp) { return {0.0, 0.5, lp, 1.0 - lp, -lp, lp - 1.0, 1.0}; }

/// Random points in [2, 12)^D plus points whose coordinates sit exactly on nodes, cell faces,
/// half cells and the kernel breakpoints.
template <int D> std::vector<Vec<D>> samplePoints(double lp, std::mt19937& rng, int nRandom)
{
    std::uniform_real_distribution<double> u(2.0, 12.0);
    std::uniform_int_distribution<int> cell(3, 10);
    const std::vector<double> off = specialOffsets(lp);
    std::uniform_int_distribution<int> pick(0, static_cast<int>(off.size()) - 1);
    std::uniform_int_distribution<int> coin(0, 1);
    std::vector<Vec<D>> pts;
    for (int i = 0; i < nRandom; ++i) {
        Vec<D> x;
        for (int d = 0; d < D; ++d) x[d] = u(rng);
        pts.push_back(x);
    }
    for (int i = 0; i < nRandom; ++i) {
        Vec<D> x;
        for (int d = 0; d < D; ++d) x[d] = coin(rng) ? cell(rng) + off[pick(rng)] : u(rng);
        pts.push_back(x);
    }
    Vec<D> node = Vec<D>::Constant(5.0);
    pts.push_back(node);
    return pts;
}

// Independent closed forms used as references.

/// Paper Eq 16 (uGIMP, half-width 1/4), written from the paper.
double paperEq16(double xi)
{
    xi = std::fabs(xi);
    if (xi <= 0.25) return (7.0 - 16.0 * xi * xi) / 8.0;
    if (xi <= 0.75) return 1.0 - xi;
    if (xi <= 1.25) return (5.0 - 4.0 * xi) * (5.0 - 4.0 * xi) / 16.0;
    return 0.0;
}

double hat(double r) { return std::max(0.0, 1.0 - std::fabs(r)); }

/// Antiderivative of the hat function.
double hatIntegral(double t)
{
    if (t <= -1) return 0.0;
    if (t <= 0) return 0.5 * (t + 1) * (t + 1);
    if (t <= 1) return 1.0 - 0.5 * (1 - t) * (1 - t);
    return 1.0;
}

/// uGIMP as the convolution of the hat with a box of half-width lp (its definition).
double gimpByConvolution(double r, double lp) { return (hatIntegral(r + lp) - hatIntegral(r - lp)) / (2 * lp); }
double gimpDerivativeByConvolution(double r, double lp) { return (hat(r + lp) - hat(r - lp)) / (2 * lp); }

template <class K> struct KernelTest : ::testing::Test {};
using Kernels = ::testing::Types<LinearKernel, GimpKernel>;
TYPED_TEST_SUITE(KernelTest, Kernels);

template <int D, class K> void checkPartitionOfUnity(std::uint32_t seed)
{
    std::mt19937 rng(seed);
    for (double lp : kHalfWidths) {
        for (const Vec<D>& x : samplePoints<D>(lp, rng, 400)) {
            const WeightMap<D> w = weights<D, K>(x, lp);
            double sumN = 0;
            Vec<D> sumG = Vec<D>::Zero(), sumNxv = Vec<D>::Zero();
            Mat<D> sumGx = Mat<D>::Zero();
            for (const auto& [node, wg] : w) {
                EXPECT_GE(wg.first, 0.0);
                Vec<D> xn;
                for (int d = 0; d < D; ++d) xn[d] = node[d];
                sumN += wg.first;
                sumG += wg.second;
                sumNxv += wg.first * xn;
                sumGx += xn * wg.second.transpose();
            }
            ASSERT_NEAR(sumN, 1.0, 1e-14) << "lp = " << lp << ", x = " << x.transpose();
            ASSERT_LT(sumG.cwiseAbs().maxCoeff(), 1e-13) << "lp = " << lp << ", x = " << x.transpose();
            // Linear reproduction: sum N_I x_I = x and sum x_I grad N_I^T = identity.
            ASSERT_LT((sumNxv - x).cwiseAbs().maxCoeff(), 1e-12) << "lp = " << lp << ", x = " << x.transpose();
            ASSERT_LT((sumGx - Mat<D>::Identity()).cwiseAbs().maxCoeff(), 1e-12)
                << "lp = " << lp << ", x = " << x.transpose();
        }
    }
}

TYPED_TEST(KernelTest, PartitionOfUnityAndLinearReproduction1D) { checkPartitionOfUnity<1, TypeParam>(11); }
TYPED_TEST(KernelTest, PartitionOfUnityAndLinearReproduction2D) { checkPartitionOfUnity<2, TypeParam>(12); }
TYPED_TEST(KernelTest, PartitionOfUnityAndLinearReproduction3D) { checkPartitionOfUnity<3, TypeParam>(13); }

/// Weights (both kernels) are C0 across cell faces, GIMP breakpoints and base switches; GIMP
/// gradients are C0 too. Returns the largest gradient jump seen at cell faces.
template <int D, class K> double checkContinuity(std::uint32_t seed)
{
    constexpr bool gimp = std::is_same_v<K, GimpKernel>;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(3.0, 10.0);
    std::uniform_int_distribution<int> cell(3, 10);
    const double eps = 1e-10;
    double maxFaceGradJump = 0;
    for (double lp : kHalfWidths) {
        const std::vector<double> off = specialOffsets(lp);
        for (int trial = 0; trial < 60; ++trial)
            for (double o : off)
                for (int d = 0; d < D; ++d) {
                    Vec<D> x;
                    for (int e = 0; e < D; ++e) x[e] = u(rng);
                    x[d] = cell(rng) + o;
                    Vec<D> xm = x, xp = x;
                    xm[d] -= eps;
                    xp[d] += eps;
                    const auto [dN, dG] = maxDifference<D>(weights<D, K>(xm, lp), weights<D, K>(xp, lp));
                    // |dN/dxi| <= 1 and, for GIMP, |d2N/dxi2| <= 1/lp (cell units).
                    EXPECT_LE(dN, 2 * eps * 1.0001 + 1e-14)
                        << "weights jump at x = " << x.transpose() << " (direction " << d << ", lp = " << lp << ")";
                    if (gimp) {
                        EXPECT_LE(dG, 2 * eps / lp * 1.0001 + 1e-12)
                            << "gradients jump at x = " << x.transpose() << " (direction " << d << ", lp = " << lp << ")";
                    }
                    if (o == 0.0 || o == 1.0) maxFaceGradJump = std::max(maxFaceGradJump, dG);
                }
    }
    return maxFaceGradJump;
}

TEST(ShapeFunction, GimpWeightsAndGradientsContinuousAcrossCellFaces1D) { checkContinuity<1, GimpKernel>(21); }
TEST(ShapeFunction, GimpWeightsAndGradientsContinuousAcrossCellFaces2D) { checkContinuity<2, GimpKernel>(22); }
TEST(ShapeFunction, GimpWeightsAndGradientsContinuousAcrossCellFaces3D) { checkContinuity<3, GimpKernel>(23); }

TEST(ShapeFunction, LinearWeightsContinuousAcrossCellFaces)
{
    checkContinuity<1, LinearKernel>(31);
    checkContinuity<2, LinearKernel>(32);
    // The gradient of the linear kernel does jump at cell faces (by 1 in 1D): this shows the
    // jump detector used for GIMP above does see a discontinuity when there is one.
    EXPECT_GT((checkContinuity<3, LinearKernel>(33)), 0.1);
}

TEST(ShapeFunction, GimpMatchesPaperEq16ForQuarterHalfWidth)
{
    std::mt19937 rng(41);
    std::uniform_real_distribution<double> u(-1.6, 1.6);
    std::vector<double> rs = {0.0, 0.25, -0.25, 0.75, -0.75, 1.0, -1.0, 1.25, -1.25, 1.5, -1.5, 0.5, -0.5};
    for (int i = 0; i < 2000; ++i) rs.push_back(u(rng));
    const double t = 1e-7;
    for (double r : rs) {
        double ds = 0;
        const double s = GimpKernel::s(r, 0.25, ds);
        EXPECT_NEAR(s, paperEq16(r), 1e-14) << "r = " << r;
        const double fd = (paperEq16(r + t) - paperEq16(r - t)) / (2 * t);
        // The paper's s is piecewise quadratic and C1: central differences are exact up to
        // round-off except within t of a breakpoint, where the error is below t |jump of s''|.
        EXPECT_NEAR(ds, fd, 4 * t / 0.25 + 1e-8) << "r = " << r;
    }
    // The same through eval, i.e. with the stencil's node selection, at positions in cell units.
    std::uniform_real_distribution<double> ux(2.0, 9.0);
    for (int i = 0; i < 2000; ++i) {
        const double xi = i < 8 ? 3.0 + 0.25 * i : ux(rng);
        double w[3], dw[3];
        const int b = GimpKernel::eval(xi, 0.25, w, dw);
        for (int j = b - 3; j < b + 6; ++j) {
            const double expected = paperEq16(xi - j);
            const double got = (j >= b && j < b + 3) ? w[j - b] : 0.0;
            EXPECT_NEAR(got, expected, 1e-14) << "xi = " << xi << ", node " << j;
        }
    }
}

TEST(ShapeFunction, GimpIsTheConvolutionOfHatAndBoxForEveryPpc)
{
    std::mt19937 rng(51);
    std::uniform_real_distribution<double> u(-1.7, 1.7);
    for (double lp : kHalfWidths)
        for (int i = 0; i < 3000; ++i) {
            double r = u(rng);
            if (i < 7) r = specialOffsets(lp)[i];
            double ds = 0;
            const double s = GimpKernel::s(r, lp, ds);
            EXPECT_NEAR(s, gimpByConvolution(r, lp), 1e-14) << "r = " << r << ", lp = " << lp;
            EXPECT_NEAR(ds, gimpDerivativeByConvolution(r, lp), 1e-13) << "r = " << r << ", lp = " << lp;
        }
    // The same through eval (the stencil's weights of its three nodes), at positions in cell units.
    std::uniform_real_distribution<double> ux(2.0, 9.0);
    for (double lp : kHalfWidths)
        for (int i = 0; i < 5000; ++i) {
            const double xi = i < 7 ? 4.0 + specialOffsets(lp)[i] : ux(rng);
            double w[3], dw[3];
            const int b = GimpKernel::eval(xi, lp, w, dw);
            for (int k = 0; k < 3; ++k) {
                const double r = xi - (b + k);
                EXPECT_NEAR(w[k], gimpByConvolution(r, lp), 1e-14) << "xi = " << xi << ", node " << b + k << ", lp = " << lp;
                EXPECT_NEAR(dw[k], gimpDerivativeByConvolution(r, lp), 1e-13)
                    << "xi = " << xi << ", node " << b + k << ", lp = " << lp;
            }
        }
}

TEST(ShapeFunction, LinearKernelIsTheHat)
{
    std::mt19937 rng(52);
    std::uniform_real_distribution<double> u(2.0, 9.0);
    for (int i = 0; i < 2000; ++i) {
        const double xi = i < 5 ? 3.0 + 0.5 * i : u(rng);
        double w[2], dw[2];
        const int b = LinearKernel::eval(xi, 0.25, w, dw);
        EXPECT_EQ(b, LinearKernel::base(xi));
        for (int j = b - 2; j < b + 4; ++j) {
            const double got = (j >= b && j < b + 2) ? w[j - b] : 0.0;
            EXPECT_NEAR(got, hat(xi - j), 1e-14) << "xi = " << xi << ", node " << j;
        }
    }
}

/// floorToInt, the kernels' base node, is std::floor for grid coordinates: on integers, half
/// integers (uGIMP's xi + 1/2), their neighbours one ulp away, signed zeros, negatives and
/// random values up to the int range.
TEST(ShapeFunction, FloorToIntIsFloor)
{
    std::mt19937 rng(71);
    std::uniform_real_distribution<double> u(-1e5, 1e5);
    std::vector<double> ys = {0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2147483647.0, -2147483648.0, 2147483646.5, -2147483647.5};
    for (int i = -40; i <= 40; ++i)
        for (double y : {0.5 * i, 0.25 * i + 1e-12}) {
            ys.push_back(y);
            ys.push_back(std::nextafter(y, -1e300));
            ys.push_back(std::nextafter(y, 1e300));
        }
    for (int i = 0; i < 200000; ++i) ys.push_back(i % 2 ? u(rng) : std::ldexp(u(rng), -(i % 40)));
    for (double y : ys) ASSERT_EQ(emp::floorToInt(y), static_cast<int>(std::floor(y))) << "y = " << y;
}

TEST(ShapeFunction, GimpStencilCoversTheWholeSupport)
{
    std::mt19937 rng(53);
    std::uniform_real_distribution<double> u(2.0, 9.0);
    for (double lp : kHalfWidths)
        for (int i = 0; i < 2000; ++i) {
            double xi = u(rng);
            if (i < 7) xi = 4.0 + specialOffsets(lp)[i];
            double w[3], dw[3];
            const int b = GimpKernel::eval(xi, lp, w, dw);
            EXPECT_EQ(b, GimpKernel::base(xi));
            for (int j = b - 3; j < b + 6; ++j) {
                if (j >= b && j < b + 3) continue;
                double ds = 0;
                EXPECT_EQ(GimpKernel::s(xi - j, lp, ds), 0.0) << "xi = " << xi << ", node " << j << ", lp = " << lp;
                EXPECT_EQ(ds, 0.0);
            }
        }
}

/// Gradients of the D-dimensional shape functions against central differences of the weights.
template <int D, class K> void checkGradientByFiniteDifference(std::uint32_t seed)
{
    constexpr bool gimp = std::is_same_v<K, GimpKernel>;
    std::mt19937 rng(seed);
    const double t = 1e-6;
    for (double lp : kHalfWidths)
        for (const Vec<D>& x : samplePoints<D>(lp, rng, 150)) {
            const WeightMap<D> w = weights<D, K>(x, lp);
            for (int d = 0; d < D; ++d) {
                // The linear kernel has a kink at each node: stay away from it.
                if (!gimp && std::fabs(x[d] - std::round(x[d])) < 2 * t) continue;
                Vec<D> xm = x, xp = x;
                xm[d] -= t;
                xp[d] += t;
                const WeightMap<D> wm = weights<D, K>(xm, lp), wp = weights<D, K>(xp, lp);
                for (const auto& [node, wg] : w) {
                    const auto im = wm.find(node), ip = wp.find(node);
                    const double Nm = im == wm.end() ? 0.0 : im->second.first;
                    const double Np = ip == wp.end() ? 0.0 : ip->second.first;
                    const double fd = (Np - Nm) / (2 * t);
                    EXPECT_NEAR(wg.second[d], fd, (gimp ? 2 * t / lp : 0.0) + 1e-8)
                        << "x = " << x.transpose() << ", direction " << d << ", lp = " << lp;
                }
            }
        }
}

TYPED_TEST(KernelTest, GradientMatchesFiniteDifference1D) { checkGradientByFiniteDifference<1, TypeParam>(61); }
TYPED_TEST(KernelTest, GradientMatchesFiniteDifference2D) { checkGradientByFiniteDifference<2, TypeParam>(62); }
TYPED_TEST(KernelTest, GradientMatchesFiniteDifference3D) { checkGradientByFiniteDifference<3, TypeParam>(63); }

}  // namespace

/// The factored sums of the stress pass (Stencil::gradientOf, Stencil::forEachProjected) and of
/// APIC's transfers (forEachAffine, affineSums) against their plain forms through forEach and
/// forEachWithOffset: sum v_I grad N_I^T, M grad N_I node by node, a + M (x_I - x_p) node by
/// node, sum N_I v_I and sum N_I v_I (x_I - x_p)^T, to round-off, on the regular lattice and on
/// a support remapped to other node indices (twins); and the offsets in cells (cellOffsets)
/// against the metric ones.
template <class C> struct StencilSumsTest : ::testing::Test {};
TYPED_TEST_SUITE(StencilSumsTest, emptest::AllSolvers);

TYPED_TEST(StencilSumsTest, FactoredSumsAreThePlainSumsToRoundOff)
{
    constexpr int D = TypeParam::D;
    using K = typename TypeParam::K;
    using St = emp::Stencil<D, K>;
    std::mt19937 rng(67);
    std::uniform_real_distribution<double> u(-1, 1), ux(3.0, 6.0);
    emp::Grid<D> g;
    std::array<int, D> n;
    n.fill(12);
    g.resize(Vec<D>::Constant(-0.3), 0.7, n);
    g.setTwins(St::NS);
    for (auto& v : g.velocity)
        for (int d = 0; d < D; ++d) v[d] = u(rng);
    g.remap.resize(St::NS);
    for (int k = 0; k < St::NS; ++k) g.remap[k] = g.numNodes() + (k * 7) % St::NS;  // a permutation of the twins
    for (int i = 0; i < 400; ++i) {
        Vec<D> x;
        for (int d = 0; d < D; ++d) x[d] = g.origin[d] + ux(rng) * g.h;
        if (i < 3) x = g.origin + (3.0 + 0.5 * i) * g.h * Vec<D>::Ones();  // on nodes and cell middles
        St st;
        st.compute(x, g, 0.25);
        if (i % 2) st.remap = 0;
        Mat<D> M;
        for (int r = 0; r < D; ++r)
            for (int c = 0; c < D; ++c) M(r, c) = u(rng);
        Mat<D> plain = Mat<D>::Zero();
        std::vector<Vec<D>> plainM;
        st.forEach(g, [&](int I, double, const Vec<D>& grad) {
            plain.noalias() += g.velocity[I] * grad.transpose();
            plainM.push_back(M * grad);
        });
        const Mat<D> L = st.gradientOf(g, [&](int I) { return g.velocity[I]; });
        EXPECT_LT((L - plain).cwiseAbs().maxCoeff(), 1e-14 * g.invh) << "x = " << x.transpose();
        std::size_t k = 0;
        st.forEachProjected(g, M, [&](int, double, const Vec<D>& mg) {
            EXPECT_LT((mg - plainM[k]).cwiseAbs().maxCoeff(), 1e-14 * g.invh) << "x = " << x.transpose() << ", node " << k;
            ++k;
        });
        EXPECT_EQ(k, plainM.size());
        // APIC's sums (forEachAffine, affineSums) against the plain forms through
        // forEachWithOffset: a + M dx node by node, sum N v and sum N v dx^T.
        double o[D][St::S];
        st.offsets(x, g, o);
        // The offsets in cells (APIC's transfers) are the metric ones over h, and the moment
        // diagonal from them is the metric one over h^2, to round-off.
        double uc[D][St::S];
        st.cellOffsets(x, g, uc);
        for (int d = 0; d < D; ++d)
            for (int j = 0; j < St::S; ++j)
                EXPECT_NEAR(uc[d][j] * g.h, o[d][j], 1e-12 * g.h) << "x = " << x.transpose() << ", d " << d << ", node " << j;
        EXPECT_LT((st.momentDiagonal(uc) * (g.h * g.h) - st.momentDiagonal(o)).cwiseAbs().maxCoeff(), 1e-13 * g.h * g.h)
            << "x = " << x.transpose();
        const Vec<D> a0 = Vec<D>::Constant(u(rng));
        std::vector<Vec<D>> plainAffine;
        Vec<D> plainSum = Vec<D>::Zero();
        Mat<D> plainB = Mat<D>::Zero();
        st.forEachWithOffset(g, o, [&](int I, double N, const Vec<D>&, const Vec<D>& dx) {
            plainAffine.push_back(a0 + M * dx);
            plainSum += N * g.velocity[I];
            plainB.noalias() += (N * g.velocity[I]) * dx.transpose();
        });
        k = 0;
        st.forEachAffine(g, o, a0, M, [&](int, double, const Vec<D>& m) {
            EXPECT_LT((m - plainAffine[k]).cwiseAbs().maxCoeff(), 1e-14) << "x = " << x.transpose() << ", node " << k;
            ++k;
        });
        EXPECT_EQ(k, plainAffine.size());
        Vec<D> sum;
        Mat<D> B;
        st.affineSums(g, o, [&](int I) { return g.velocity[I]; }, sum, B);
        EXPECT_LT((sum - plainSum).cwiseAbs().maxCoeff(), 1e-14) << "x = " << x.transpose();
        EXPECT_LT((B - plainB).cwiseAbs().maxCoeff(), 1e-14 * g.h) << "x = " << x.transpose();
        // Same nodes and weights in the same order as forEach.
        std::vector<std::pair<int, double>> a, b, c;
        st.forEach(g, [&](int I, double N, const Vec<D>&) { a.emplace_back(I, N); });
        st.forEachProjected(g, M, [&](int I, double N, const Vec<D>&) { b.emplace_back(I, N); });
        st.forEachAffine(g, o, a0, M, [&](int I, double N, const Vec<D>&) { c.emplace_back(I, N); });
        EXPECT_EQ(a, b);
        EXPECT_EQ(a, c);
    }
}

// Stencil::computeRun (P2G's stencils of a run of points, one point per lane, GimpKernel::evalLane)
// gives bitwise compute()'s stencils, in every lane width the processor runs: random positions,
// points of undeformed uGIMP lattices for ppc 1 to 5 (on the boundaries between the kernel's
// pieces) and positions on nodes and cell faces, runs of every length up to 32.
template <int D> void checkComputeRun()
{
    using St = emp::Stencil<D, GimpKernel>;
    constexpr int R = 32;
    emp::Grid<D> g;
    std::array<int, D> n;
    n.fill(16);
    g.resize(Vec<D>::Constant(-0.3), 0.7, n);
    std::mt19937 rng(71);
    std::uniform_real_distribution<double> u(3.0, 12.0);
    const emp::LaneIsa before = emp::laneIsa();
    int compared = 0, nearCount = 0, runsNear = 0, runsClear = 0;
    for (int ppc = 1; ppc <= 5; ++ppc) {
        const emp::HalfWidth half(0.5 / ppc);
        std::vector<Vec<D>> x;
        for (int i = 0; i < 300; ++i) {
            Vec<D> p;
            for (int d = 0; d < D; ++d) {
                const int kind = (i + d) % 3;
                const double c = 4.0 + (i % 7);
                const double cells = kind == 0 ? u(rng) : kind == 1 ? c + (0.5 + (i % ppc)) / ppc : c + 0.5 * (i % 2);
                p[d] = g.origin[d] + cells * g.h;
            }
            x.push_back(p);
        }
        for (emp::LaneIsa w : {emp::LaneIsa::baseline, emp::LaneIsa::avx2, emp::LaneIsa::avx512}) {
            if (emp::setLaneIsa(w) != w) continue;
            for (std::size_t begin = 0; begin < x.size();) {
                const int len = 1 + static_cast<int>((begin * 13) % R);
                const int m = std::min<int>(len, static_cast<int>(x.size() - begin));
                std::vector<St> run(m), one(m), withFrames(m);
                // (the frames' offsets written where a run points them: Solver::offset_)
                // (the boxed run also stores its r's where rOut points: Solver::offset_ in 2D)
                std::vector<double> offsets(D * R), offsetsBoxed(D * R), rBoxed(D * R, -1.0);
                typename St::template AffineRun<R> frames, framesBoxed;
                for (int d = 0; d < D; ++d)
                    frames.b[d] = &offsets[d * R], framesBoxed.b[d] = &offsetsBoxed[d * R], framesBoxed.rOut[d] = &rBoxed[d * R];
                const auto xOf = [&](int i) -> const Vec<D>& { return x[begin + i]; };
                St::template computeRun<R>(m, xOf, g, half, run.data());
                St::template computeRun<R>(m, xOf, g, half, withFrames.data(), frames);
                // With a box of marked nodes (P2G near a crack): the same stencils, and each
                // point flagged exactly where overlaps() finds its support touching the box, and
                // `any` set exactly when one is.
                int lo[D], hi[D], near[R], nearFramed[R];
                for (int d = 0; d < D; ++d) lo[d] = 5 + d + static_cast<int>(begin % 2), hi[d] = lo[d] + static_cast<int>(begin % 4);
                typename St::Box box{lo, hi, near, -1}, boxFramed{lo, hi, nearFramed, -1};
                std::vector<St> boxed(m), boxedFramed(m);
                St::template computeRun<R>(m, xOf, g, half, boxed.data(), &box);
                St::template computeRun<R>(m, xOf, g, half, boxedFramed.data(), framesBoxed, &boxFramed);
                bool anyOverlaps = false;
                for (int i = 0; i < m; ++i) anyOverlaps = anyOverlaps || St::overlaps(x[begin + i], g, lo, hi);
                ASSERT_EQ(box.any != 0, anyOverlaps) << emp::name(w);
                ASSERT_EQ(boxFramed.any != 0, anyOverlaps) << emp::name(w);
                (anyOverlaps ? runsNear : runsClear) += 1;
                for (int i = 0; i < m; ++i) {
                    one[i].compute(x[begin + i], g, half);
                    ASSERT_EQ(std::memcmp(&withFrames[i], &run[i], sizeof run[i]), 0);
                    ASSERT_EQ(std::memcmp(&boxed[i], &run[i], sizeof run[i]), 0);
                    ASSERT_EQ(std::memcmp(&boxedFramed[i], &run[i], sizeof run[i]), 0);
                    const typename St::AffineFrame fr = frames.frame(i), frBoxed = framesBoxed.frame(i);
                    ASSERT_EQ(std::memcmp(&frBoxed, &fr, sizeof fr), 0);
                    for (int d = 0; d < D; ++d) ASSERT_EQ(std::memcmp(&rBoxed[d * R + i], &fr.r[d], sizeof fr.r[d]), 0);
                    const bool overlaps = St::overlaps(x[begin + i], g, lo, hi);
                    if (anyOverlaps) {  // (the flags are written only then)
                        ASSERT_EQ(near[i] != 0, overlaps) << emp::name(w) << ", x = " << x[begin + i].transpose();
                        ASSERT_EQ(nearFramed[i] != 0, overlaps) << emp::name(w);
                    }
                    nearCount += overlaps;
                    // APIC's frame: from the lanes, per point, and from the plain offsets and
                    // moment diagonal (cellOffsets, momentDiagonal), bitwise.
                    const typename St::AffineFrame f = one[i].affineFrame(x[begin + i], g);
                    ASSERT_EQ(std::memcmp(&fr, &f, sizeof f), 0) << emp::name(w);
                    // (the offsets kept for G2P: the frame's)
                    for (int d = 0; d < D; ++d) ASSERT_EQ(std::memcmp(&offsets[d * R + i], &f.b[d], sizeof f.b[d]), 0) << emp::name(w);
                    double uo[D][St::S];
                    one[i].cellOffsets(x[begin + i], g, uo);
                    const Vec<D> du = one[i].momentDiagonal(uo);
                    for (int d = 0; d < D; ++d) {
                        for (int k = 0; k < St::S; ++k) ASSERT_EQ(f.b[d] + k, uo[d][k]);
                        ASSERT_GT(du[d], 0);
                        ASSERT_EQ(f.r[d], 1.0 / (g.h * du[d])) << "d " << d;
                    }
                    ASSERT_EQ(run[i].first, one[i].first) << emp::name(w);
                    // The lattice coordinates of the base node: from the stored index (baseOf),
                    // from the position as the passes find them again (baseAt), and the kernel's.
                    for (int d = 0; d < D; ++d) {
                        const double xi = (x[begin + i][d] - g.origin[d]) * g.invh;
                        double we[3], dwe[3];
                        const int b = emp::GimpKernel::eval(xi, half.lp, we, dwe);
                        ASSERT_EQ(one[i].baseOf(g, d), b) << "d " << d << ", x = " << x[begin + i].transpose();
                        ASSERT_EQ(St::baseAt(x[begin + i], g, d), b) << "d " << d;
                    }
                    ASSERT_EQ(run[i].remap, one[i].remap);
                    ASSERT_EQ(std::memcmp(run[i].w, one[i].w, sizeof one[i].w), 0)
                        << emp::name(w) << ", ppc " << ppc << ", x = " << x[begin + i].transpose();
                    ASSERT_EQ(std::memcmp(run[i].dw, one[i].dw, sizeof one[i].dw), 0)
                        << emp::name(w) << ", ppc " << ppc << ", x = " << x[begin + i].transpose();
                    ++compared;
                }
                begin += m;
            }
        }
    }
    emp::setLaneIsa(before);
    EXPECT_GE(compared, 5 * 300);
    // (both answers occur: the boxes cover part of the points)
    EXPECT_GT(nearCount, compared / 20);
    EXPECT_LT(nearCount, compared - compared / 20);
    EXPECT_GT(runsNear, 0);
    EXPECT_GT(runsClear, 0);
}
TEST(ShapeFunction, ComputeRunIsBitwiseCompute2D) { checkComputeRun<2>(); }
TEST(ShapeFunction, ComputeRunIsBitwiseCompute3D) { checkComputeRun<3>(); }

// The row forms of a regular support (Stencil::forEachRow, forEachRowProjected, forEachRowAffine;
// 3D: scatterRowsOf, scatterRowsAffineOf too: the solver's P2G and stress passes on the regular
// lattice) update every node bitwise as the node
// forms do (forEach, forEachProjected, forEachAffine, the plain versions kept for the phantom
// twins), with the solver's updates, in every lane width the processor runs (the passes call them
// inside withLaneIsa, so that the rows' loops use that width).
template <int D, class K> void checkRowForms()
{
    using St = emp::Stencil<D, K>;
    constexpr int S = St::S;
    emp::Grid<D> g;
    std::array<int, D> n;
    n.fill(12);
    g.resize(Vec<D>::Constant(-0.3), 0.7, n);
    const int nodes = g.numNodes();
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(3.0, 8.0), r(-1.0, 1.0);
    std::vector<double> mass0(nodes);
    std::vector<Vec<D>> field0(nodes);
    for (int I = 0; I < nodes; ++I) {
        mass0[I] = r(rng);
        field0[I] = Vec<D>::Random();
    }
    const emp::LaneIsa before = emp::laneIsa();
    int compared = 0;
    for (emp::LaneIsa w : {emp::LaneIsa::baseline, emp::LaneIsa::avx2, emp::LaneIsa::avx512}) {
        if (emp::setLaneIsa(w) != w) continue;
        for (int trial = 0; trial < 200; ++trial) {
            Vec<D> x, fb, a0;
            for (int d = 0; d < D; ++d) x[d] = g.origin[d] + u(rng) * g.h, fb[d] = r(rng), a0[d] = r(rng);
            Mat<D> M = Mat<D>::Random() * std::pow(10.0, 6 * r(rng));
            const double mp = 1 + r(rng);
            // APIC's C_u = B diag(s) (Stencil::scaleAffine) against its scalar form, with
            // directions that get 0 (s <= 0, or NaN; their column may hold anything).
            double sc[D];
            for (int d = 0; d < D; ++d) sc[d] = 0.2 + u(rng);
            if (trial % 5 == 1) sc[trial % D] = 0;
            if (trial % 7 == 2) sc[(trial + 1) % D] = -1;
            if (trial % 11 == 3) {
                sc[D - 1] = std::numeric_limits<double>::quiet_NaN();
                M(0, D - 1) = std::numeric_limits<double>::infinity();
            }
            Mat<D> Cu = M, Cref;
            for (int d = 0; d < D; ++d) Cref.col(d) = sc[d] > 0 ? Vec<D>(M.col(d) * sc[d]) : Vec<D>::Zero();
            typename emp::Lane3::V c[3];
            emp::withLaneIsa([&]() EMP_LAMBDA_INLINE { St::scaleAffine(Cu, sc, c); });
            ASSERT_EQ(std::memcmp(Cu.data(), Cref.data(), sizeof Cu), 0) << emp::name(w) << "\n" << Cu << "\n" << Cref;
            if (trial % 11 == 3) M(0, D - 1) = 0.5;  // (the forms below on finite numbers)
            St st;
            st.compute(x, g, emp::HalfWidth(0.25));
            ASSERT_TRUE(st.regular());
            double o[D][S];
            st.cellOffsets(x, g, o);
            // node forms
            std::vector<double> mass = mass0;
            std::vector<Vec<D>> mom = field0, aff = field0, force = field0, grav = field0;
            st.forEach(g, [&](int I, double N, const Vec<D>&) {
                mass[I] += N * mp;
                mom[I] += N * a0;
            });
            st.forEachProjected(g, M, [&](int I, double N, const Vec<D>& t) {
                force[I] -= t;
                grav[I] += N * fb - t;
            });
            st.forEachAffine(g, o, a0, Mat<D>(mp * M), [&](int I, double N, const Vec<D>& m) { aff[I] += N * m; });
            // row forms, in the lanes' width
            std::vector<double> mass2 = mass0;
            std::vector<Vec<D>> mom2 = field0, aff2 = field0, force2 = field0, grav2 = field0;
            emp::withLaneIsa([&]() EMP_LAMBDA_INLINE {
                st.forEachRow(g, [&](int I0, const double* N) EMP_LAMBDA_INLINE {
                    for (int i = 0; i < S; ++i) mass2[I0 + i] += N[i] * mp;
                    double* q = mom2[I0].data();
                    for (int e = 0; e < S * D; ++e) q[e] += N[e / D] * a0[e % D];
                });
                st.forEachRowProjected(g, M, [&](int I0, const double* N, const double* t) EMP_LAMBDA_INLINE {
                    double *f = force2[I0].data(), *h = grav2[I0].data();
                    for (int e = 0; e < S * D; ++e) {
                        f[e] -= t[e];
                        h[e] += N[e / D] * fb[e % D] - t[e];
                    }
                });
                // (3D: the force of APIC with the co-rotational update, Solver::particleToGrid)
                st.forEachRowAffine(g, o, a0, mp, M, [&](int I0, const double*, const double* Nt) EMP_LAMBDA_INLINE {
                    double* q = aff2[I0].data();
                    for (int e = 0; e < S * D; ++e) q[e] += Nt[e];
                });
            });
            if constexpr (D == 3) {
                // 3D's P2G adds mass and momentum into one 4-lane vector per node (Grid::massMomentum):
                // FLIP's (scatterRowsOf) and APIC's (scatterRowsAffineOf) sums, from the same start.
                constexpr int W = emp::Grid<D>::sumsWidth;
                std::vector<double, emp::ZeroPages<double>> flip(static_cast<std::size_t>(nodes) * W), apic;
                for (int I = 0; I < nodes; ++I) {
                    flip[I * W] = mass0[I];
                    for (int d = 0; d < D; ++d) flip[I * W + 1 + d] = field0[I][d];
                }
                apic = flip;
                const double a[D + 1] = {mp, a0[0], a0[1], a0[2]};
                emp::withLaneIsa([&]() EMP_LAMBDA_INLINE {
                    st.scatterRowsOf(g, a, [&](int I) { return &flip[static_cast<std::size_t>(I) * W]; });
                    typename emp::Lane3::V cols[3];
                    Mat<D> Mu = M;
                    const double one[D] = {1.0, 1.0, 1.0};  // (C_u = M)
                    St::scaleAffine(Mu, one, cols);
                    st.scatterRowsAffineOf(g, o, a0, mp, cols, [&](int I) { return &apic[static_cast<std::size_t>(I) * W]; });
                });
                for (int I = 0; I < nodes; ++I) {
                    for (const auto* sums : {&flip, &apic}) ASSERT_EQ(std::memcmp(&(*sums)[I * W], &mass[I], sizeof(double)), 0) << emp::name(w);
                    ASSERT_EQ(std::memcmp(&flip[I * W + 1], mom[I].data(), sizeof(Vec<D>)), 0) << emp::name(w) << ", x = " << x.transpose();
                    ASSERT_EQ(std::memcmp(&apic[I * W + 1], aff[I].data(), sizeof(Vec<D>)), 0) << emp::name(w) << ", x = " << x.transpose();
                }
            }
            ASSERT_EQ(std::memcmp(aff.data(), aff2.data(), nodes * sizeof(Vec<D>)), 0) << emp::name(w) << ", x = " << x.transpose();
            ASSERT_EQ(std::memcmp(mass.data(), mass2.data(), nodes * sizeof(double)), 0) << emp::name(w);
            const std::size_t bytes = nodes * sizeof(Vec<D>);
            ASSERT_EQ(std::memcmp(mom.data(), mom2.data(), bytes), 0) << emp::name(w) << ", x = " << x.transpose();
            ASSERT_EQ(std::memcmp(force.data(), force2.data(), bytes), 0) << emp::name(w) << ", x = " << x.transpose();
            ASSERT_EQ(std::memcmp(grav.data(), grav2.data(), bytes), 0) << emp::name(w) << ", x = " << x.transpose();
            ASSERT_NE(std::memcmp(force.data(), field0.data(), bytes), 0);  // (the forms wrote something)
            // The sums that read nodes (gradientOf, affineSums, G2P's sums by forEachRow) give the
            // same bits with the indices from the base node as from a table of the same nodes.
            St tabled = st;
            g.remap.resize(St::NS);
            for (int q = 0; q < St::NS; ++q) g.remap[q] = st.regularNode(g, q);
            tabled.remap = 0;
            const auto v = [&](int I) { return field0[I]; };
            const Mat<D> L1 = st.gradientOf(g, v), L2 = tabled.gradientOf(g, v);
            ASSERT_EQ(std::memcmp(L1.data(), L2.data(), sizeof L1), 0) << emp::name(w);
            Vec<D> s1, s2, a1 = Vec<D>::Zero(), a2 = Vec<D>::Zero();
            Mat<D> B1, B2;
            st.affineSums(g, o, v, s1, B1);
            tabled.affineSums(g, o, v, s2, B2);
            ASSERT_EQ(std::memcmp(s1.data(), s2.data(), sizeof s1), 0) << emp::name(w);
            ASSERT_EQ(std::memcmp(B1.data(), B2.data(), sizeof B1), 0) << emp::name(w);
            st.forEachRow(g, [&](int I0, const double* N) {
                for (int i = 0; i < S; ++i) a1 += N[i] * field0[I0 + i];
            });
            tabled.forEach(g, [&](int I, double N, const Vec<D>&) { a2 += N * field0[I]; });
            ASSERT_EQ(std::memcmp(a1.data(), a2.data(), sizeof a1), 0) << emp::name(w);
            // The sums that read the nodal arrays run in 4-lane vectors (3D: emp::Lane3; 2D's
            // gradient: both of a row's sums in one vector; a callable that returns a value takes
            // Eigen's path, as above): the same bits, in the lanes' width, with either node indexing.
            std::copy(field0.begin(), field0.end(), g.velocity.begin());
            const auto ref = [&](int I) -> const Vec<D>& { return g.velocity[I]; };
            for (const St* s : {&st, &tabled}) {
                Mat<D> L3, B3;
                Vec<D> s3;
                emp::withLaneIsa([&]() EMP_LAMBDA_INLINE {
                    L3 = s->gradientOf(g, ref);
                    s->affineSums(g, o, ref, s3, B3);
                });
                ASSERT_EQ(std::memcmp(L3.data(), L1.data(), sizeof L1), 0) << emp::name(w);
                ASSERT_EQ(std::memcmp(s3.data(), s1.data(), sizeof s1), 0) << emp::name(w);
                ASSERT_EQ(std::memcmp(B3.data(), B1.data(), sizeof B1), 0) << emp::name(w);
            }
            if constexpr (D == 3) {  // (G2P's sums)
                emp::Lane3 rows = emp::Lane3::zero(), each = emp::Lane3::zero();
                emp::withLaneIsa([&]() EMP_LAMBDA_INLINE {
                    st.forEachRow(g, [&](int I0, const double* N) EMP_LAMBDA_INLINE {
                        for (int i = 0; i < S; ++i) rows += N[i] * emp::Lane3::load(g.velocity[I0 + i]);
                    });
                    tabled.forEach(g, [&](int I, double N, const Vec<D>&) { each += N * emp::Lane3::load(g.velocity[I]); });
                });
                const Vec<D> r3 = rows.vec(), e3 = each.vec();
                ASSERT_EQ(std::memcmp(r3.data(), a1.data(), sizeof a1), 0) << emp::name(w);
                ASSERT_EQ(std::memcmp(e3.data(), a1.data(), sizeof a1), 0) << emp::name(w);
                if constexpr (S == 3) {
                    // APIC's G2P sums by rows (Stencil::affineRowSums3): bitwise the plain order
                    // (p_ijk = N_ijk v_ijk; each row's r and q, each plane's P, T and Q; the folds
                    // with the offsets) in every lane width, and affineSums' to round-off of the
                    // terms' sizes.
                    Vec<D> as;
                    Mat<D> aB;
                    emp::withLaneIsa([&]() EMP_LAMBDA_INLINE {
                        st.affineRowSums3(g, o[0][0], o[1][0], o[2][0], g.velocity.data(), as, aB);
                    });
                    Vec<D> ps, sizeOf = Vec<D>::Zero();
                    Mat<D> pB;
                    for (int d = 0; d < D; ++d) {
                        double P[S], T[S], Q[S];
                        for (int k = 0; k < S; ++k) {
                            double r[S], q[S];
                            for (int j = 0; j < S; ++j) {
                                double p[S];
                                for (int i = 0; i < S; ++i) {
                                    p[i] = (st.w[0][i] * (st.w[1][j] * st.w[2][k])) * g.velocity[st.rowStart(g, j, k) + i][d];
                                    sizeOf[d] += std::abs(p[i]) * (1 + std::abs(o[0][i]) + std::abs(o[1][j]) + std::abs(o[2][k]));
                                }
                                r[j] = (p[0] + p[1]) + p[2];
                                q[j] = (p[1] + p[2]) + p[2];
                            }
                            P[k] = (r[0] + r[1]) + r[2];
                            T[k] = (r[1] + r[2]) + r[2];
                            Q[k] = (q[0] + q[1]) + q[2];
                        }
                        ps[d] = (P[0] + P[1]) + P[2];
                        pB(d, 0) = o[0][0] * ps[d] + ((Q[0] + Q[1]) + Q[2]);
                        pB(d, 1) = o[1][0] * ps[d] + ((T[0] + T[1]) + T[2]);
                        pB(d, 2) = o[2][0] * ps[d] + ((P[1] + P[2]) + P[2]);
                    }
                    ASSERT_EQ(std::memcmp(as.data(), ps.data(), sizeof as), 0) << emp::name(w);
                    ASSERT_EQ(std::memcmp(aB.data(), pB.data(), sizeof aB), 0) << emp::name(w);
                    for (int d = 0; d < D; ++d) {
                        ASSERT_NEAR(as[d], s1[d], 4e-16 * sizeOf[d]) << emp::name(w);
                        for (int e = 0; e < D; ++e) ASSERT_NEAR(aB(d, e), B1(d, e), 4e-15 * sizeOf[d]) << emp::name(w);
                    }
                }
            }
            if constexpr (D == 2 && S == 3) {
                // G2P's sums by columns (Stencil::columnSums2): bitwise the plain column order
                // (each column's sum over the rows, then (column 0 + column 1) + column 2) in every
                // lane width, and the node-by-node sums to round-off.
                std::vector<Vec<D>> field1(nodes);
                for (int I = 0; I < nodes; ++I) field1[I] = Vec<D>(field0[I][1] - 0.5, 2.0 * field0[I][0]);
                Vec<D> ca, cb;
                emp::withLaneIsa([&]() EMP_LAMBDA_INLINE { st.columnSums2(g, field0.data(), field1.data(), ca, cb); });
                const auto plain = [&](const std::vector<Vec<D>>& f, int d) {
                    double c[S], sizeOf = 0, nodeSum = 0;
                    for (int i = 0; i < S; ++i)
                        for (int j = 0; j < S; ++j) {
                            const double term = (st.w[0][i] * st.w[1][j]) * f[st.rowStart(g, j) + i][d];
                            c[i] = j == 0 ? term : c[i] + term;
                            sizeOf += std::abs(term);
                        }
                    tabled.forEach(g, [&](int I, double N, const Vec<D>&) { nodeSum += N * f[I][d]; });
                    return std::array<double, 3>{(c[0] + c[1]) + c[2], nodeSum, sizeOf};
                };
                for (int d = 0; d < D; ++d)
                    for (const auto& [sum, f] : {std::pair{ca[d], &field0}, std::pair{cb[d], &field1}}) {
                        const auto [columns, nodeSum, sizeOf] = plain(*f, d);
                        ASSERT_EQ(std::memcmp(&sum, &columns, sizeof sum), 0) << emp::name(w) << ", component " << d;
                        ASSERT_NEAR(sum, nodeSum, 2e-15 * sizeOf) << emp::name(w);
                    }
                // APIC's G2P sums by columns (Stencil::affineColumnSums2): bitwise the plain order
                // (p_ij = N_ij v_ij; c_i and t_i over the rows; then the folds with the offsets) in
                // every lane width, and affineSums' to round-off of the terms' sizes.
                Vec<D> as, ps;
                Mat<D> aB, pB;
                emp::withLaneIsa([&]() EMP_LAMBDA_INLINE { st.affineColumnSums2(g, o[0][0], o[1][0], field0.data(), as, aB); });
                Vec<D> sizeOf = Vec<D>::Zero();
                for (int d = 0; d < D; ++d) {
                    double c[S], t[S], p[S][S];
                    for (int i = 0; i < S; ++i) {
                        for (int j = 0; j < S; ++j) {
                            p[i][j] = (st.w[0][i] * st.w[1][j]) * field0[st.rowStart(g, j) + i][d];
                            sizeOf[d] += std::abs(p[i][j]) * (1 + std::abs(o[0][i]) + std::abs(o[1][j]));
                        }
                        c[i] = (p[i][0] + p[i][1]) + p[i][2];
                        t[i] = (p[i][1] + p[i][2]) + p[i][2];
                    }
                    ps[d] = (c[0] + c[1]) + c[2];
                    pB(d, 0) = o[0][0] * ps[d] + (c[1] + (c[2] + c[2]));
                    pB(d, 1) = o[1][0] * ps[d] + ((t[0] + t[1]) + t[2]);
                }
                ASSERT_EQ(std::memcmp(as.data(), ps.data(), sizeof as), 0) << emp::name(w);
                ASSERT_EQ(std::memcmp(aB.data(), pB.data(), sizeof aB), 0) << emp::name(w);
                Vec<D> es;
                Mat<D> eB;
                st.affineSums(g, o, [&](int I) { return field0[I]; }, es, eB);
                for (int d = 0; d < D; ++d) {
                    ASSERT_NEAR(as[d], es[d], 4e-16 * sizeOf[d]) << emp::name(w);
                    for (int e = 0; e < D; ++e) ASSERT_NEAR(aB(d, e), eB(d, e), 4e-15 * sizeOf[d]) << emp::name(w);
                }
            }
            ++compared;
        }
    }
    emp::setLaneIsa(before);
    EXPECT_GE(compared, 200);
}
TEST(Stencil, RowFormsAreBitwiseNodeForms2D) { checkRowForms<2, GimpKernel>(); }
TEST(Stencil, RowFormsAreBitwiseNodeForms3D) { checkRowForms<3, GimpKernel>(); }
TEST(Stencil, RowFormsAreBitwiseNodeForms2DLinear) { checkRowForms<2, emp::LinearKernel>(); }
TEST(Stencil, RowFormsAreBitwiseNodeForms3DLinear) { checkRowForms<3, emp::LinearKernel>(); }
