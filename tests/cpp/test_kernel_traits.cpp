// The traits a kernel declares (ShapeFunction.hpp) agree with what its functions do, so that
// the solver, the phantom-node marking and the stress update can trust them:
//   - crackRings: the support of a point in cell c lies within cells c - crackRings .. c +
//     crackRings (the rings a crack must mark), and is reached;
//   - gradientJumpsAtNodes: dN/dx is discontinuous at a node exactly when declared.
#include <cmath>
#include <random>

#include "test_helpers.hpp"

namespace {

template <class C> struct KernelTraitsTest : ::testing::Test {};
TYPED_TEST_SUITE(KernelTraitsTest, emptest::AllSolvers);

TYPED_TEST(KernelTraitsTest, CrackRingsCoverTheSupportOfAPointInACell)
{
    using K = typename TypeParam::K;
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int ppc = 1; ppc <= 4; ++ppc) {
        const double lp = 0.5 / ppc;
        int reach = 0;
        for (int i = 0; i < 20000; ++i) {
            const double xi = 10.0 + u(rng);
            double w[K::S], dw[K::S];
            const int b = K::eval(xi, lp, w, dw);
            // Nodes with a nonzero weight or gradient.
            for (int k = 0; k < K::S; ++k) {
                if (w[k] == 0.0 && dw[k] == 0.0) continue;
                const int node = b + k;  // cell 10 has nodes 10 and 11
                const int ring = node < 10 ? 10 - node : std::max(0, node - 11);
                reach = std::max(reach, ring);
                ASSERT_LE(ring, K::crackRings) << K::name << ": xi = " << xi << ", node " << node;
            }
        }
        EXPECT_EQ(reach, K::crackRings) << K::name << ", ppc " << ppc << ": the declared rings are never reached";
    }
}

TYPED_TEST(KernelTraitsTest, GradientJumpsAtNodesOnlyWhenDeclared)
{
    using K = typename TypeParam::K;
    const double lp = 0.25, e = 1e-9;
    double maxJump = 0;
    for (int node = 9; node <= 11; ++node) {
        double wa[K::S], dwa[K::S], wb[K::S], dwb[K::S];
        const int ba = K::eval(node - e, lp, wa, dwa), bb = K::eval(node + e, lp, wb, dwb);
        // The derivative of N_J, for every node J the two evaluations share or not.
        for (int J = node - 2; J <= node + 2; ++J) {
            const double da = J >= ba && J < ba + K::S ? dwa[J - ba] : 0.0;
            const double db = J >= bb && J < bb + K::S ? dwb[J - bb] : 0.0;
            maxJump = std::max(maxJump, std::fabs(da - db));
        }
    }
    if (K::gradientJumpsAtNodes)
        EXPECT_GT(maxJump, 0.5) << K::name;
    else
        EXPECT_LT(maxJump, 1e-6) << K::name;
}

}  // namespace

namespace {

// The solver's passes evaluate the kernel with evalAll (all directions at once, selects instead
// of branches, and for uGIMP only the pieces a node can lie on when lp <= 1/2); eval is the
// plain version. They agree bitwise when lp is a power of two (ppc = 1, 2, 4, ..., 64) and
// within two ulps of the largest weight otherwise, for every ppc the solver accepts (1 to 64),
// on random positions and on the lattice sites of an undeformed block, where the pieces of the
// uGIMP function meet.
template <int D, class K> void checkEvalAll()
{
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-3.0, 40.0);
    for (int ppc = 1; ppc <= 64; ++ppc) {
        const double lp = 0.5 / ppc;
        const bool exact = (ppc & (ppc - 1)) == 0;
        for (int i = 0; i < 20000; ++i) {
            double xi[D];
            for (int d = 0; d < D; ++d)
                xi[d] = i % 2 ? u(rng) : std::floor(u(rng)) + (0.5 + (i / 2) % ppc) / ppc;  // lattice sites
            int base[D];
            double w[D][K::S], dw[D][K::S];
            K::template evalAll<D>(xi, lp, base, w, dw);
            for (int d = 0; d < D; ++d) {
                double we[K::S], dwe[K::S];
                ASSERT_EQ(base[d], K::eval(xi[d], lp, we, dwe)) << K::name << " xi = " << xi[d];
                for (int k = 0; k < K::S; ++k) {
                    if (exact) {
                        ASSERT_EQ(w[d][k], we[k]) << K::name << " ppc " << ppc << " xi = " << xi[d] << " node " << k;
                        ASSERT_EQ(dw[d][k], dwe[k]) << K::name << " ppc " << ppc << " xi = " << xi[d] << " node " << k;
                    } else {
                        ASSERT_NEAR(w[d][k], we[k], 4.5e-16) << K::name << " ppc " << ppc << " xi = " << xi[d];
                        ASSERT_NEAR(dw[d][k], dwe[k], 4.5e-16) << K::name << " ppc " << ppc << " xi = " << xi[d];
                    }
                }
            }
        }
    }
}

TYPED_TEST(KernelTraitsTest, EvalAllIsEvalInEveryDirection)
{
    checkEvalAll<TypeParam::D, typename TypeParam::K>();
}

}  // namespace
