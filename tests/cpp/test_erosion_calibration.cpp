// The initiation ratio of Eq 23 for a sharp crack (pkg/ErosionCalibration.hpp): kappa <psi+> = ratio G
// on the singular crack-tip field, so that alpha = 1/ratio starts a crack at Griffith's G = Gc.
//   - the unsplit law's ratio against its closed form (Sih's strain energy density of mode I);
//   - the ratio does not depend on the material's stiffness, only on nu, the law and the plane
//     condition; mode II and 3D values are finite and larger than mode I's where they should be;
//   - the erosion engine's own G_p (EigenErosion::energyReleaseRate) of a point at the tip of the
//     closed-form field on a point lattice approaches ratio * G as kappa / spacing grows.
#include <cmath>

#include "ErosionCalibration.hpp"
#include "EigenErosion.hpp"
#include "test_helpers.hpp"

namespace {

using emp::CrackMode;
using emp::ElasticMaterial;

// Unsplit law, mode I: r psi = K^2 (1 + cos t)(k - cos t) / (16 pi mu) (Sih), so
// kappa <psi> = (2k - 1) / (16 pi mu) K^2 over a disc centred on the tip, with k = 3 - 4 nu (plane
// strain) or (3 - nu)/(1 + nu) (plane stress).
TEST(ErosionCalibration, UnsplitModeIRatioIsSihsClosedForm)
{
    const int none = emp::lawIndex("none");
    for (double nu : {0.0, 0.2, 0.3, 0.45})
        for (bool planeStress : {false, true}) {
            const auto m = ElasticMaterial::make(70e9, nu, 2500, planeStress, 2, none);
            const double k = planeStress ? (3 - nu) / (1 + nu) : 3 - 4 * nu;
            const double Eprime = planeStress ? m.E : m.E / (1 - nu * nu);
            const double mu = m.E / (2 * (1 + nu));
            const double expected = (2 * k - 1) / (16 * M_PI * mu) * Eprime;
            EXPECT_NEAR(emp::initiationRatio<2>(m, CrackMode::I), expected, 2e-6 * expected)
                << "nu " << nu << (planeStress ? " plane stress" : " plane strain");
        }
}

TEST(ErosionCalibration, RatioDependsOnNuAndTheSplitNotOnStiffness)
{
    for (const auto& law : emp::lawNames()) {
        const int id = emp::lawIndex(law);
        const auto a = ElasticMaterial::make(1e6, 0.2, 1000, false, 2, id);
        const auto b = ElasticMaterial::make(7e10, 0.2, 2500, false, 2, id);
        EXPECT_NEAR(emp::initiationRatio<2>(a, CrackMode::I), emp::initiationRatio<2>(b, CrackMode::I), 1e-12) << law;
        // 3D: the plane-strain field over a ball around a point of a straight front.
        const auto c = ElasticMaterial::make(7e10, 0.2, 2500, false, 3, id);
        const double r3 = emp::initiationRatio<3>(c, CrackMode::I);
        EXPECT_GT(r3, 0.0) << law;
        EXPECT_LT(r3, 1.0) << law;
        // Mode II puts more of the energy into psi+ than mode I does for every law here.
        EXPECT_GT(emp::initiationRatio<2>(b, CrackMode::II), emp::initiationRatio<2>(b, CrackMode::I)) << law;
    }
    // The spectral split at nu = 0.2 (glass-like) in plane strain: the 0.165, and the
    // 1.7x initiation stress at alpha = 2.
    const auto glass = ElasticMaterial::make(32e9, 0.2, 2450, false, 2, emp::lawIndex("spectral"));
    const double r = emp::initiationRatio<2>(glass, CrackMode::I);
    EXPECT_NEAR(r, 0.168, 0.002);
    EXPECT_NEAR(1.0 / std::sqrt(2.0 * r), 1.72, 0.01);
    EXPECT_DOUBLE_EQ(emp::griffithAlpha<2>(glass), 1.0 / r);
}

// A 2D lattice of points (spacing s) around a crack tip at the origin (crack along -x), with the
// history H = psi+ of the mode-I field for K = 1; G_p of the point nearest ahead of the tip, by
// the erosion engine, over ratio * G.
double latticeOverContinuum(double kappaOverSpacing, double offsetInSpacings)
{
    const auto m = ElasticMaterial::make(32e9, 0.2, 2450, false, 2, emp::lawIndex("spectral"));
    const double s = 1.0e-3, kappa = kappaOverSpacing * s;
    emp::MaterialPoints<2> P;
    P.density = {1.0};
    const int n = static_cast<int>(std::ceil(kappa / s)) + 2;
    int probe = -1;
    for (int j = -n; j < n; ++j)
        for (int i = -n; i < n; ++i) {
            const emp::Vec<2> x((i + 0.5) * s, (j + 0.5) * s);
            P.add(x, emp::Vec<2>::Zero(), 1.0, 0);
            const double rho = x.norm(), theta = std::atan2(x[1], x[0]);
            const Eigen::Vector3d sg = emp::singularStress(CrackMode::I, theta) / std::sqrt(rho);
            const emp::Mat<2> eps = emp::strainOf<2>(sg, m);
            P.history.back() = emp::lawResponse<2>(eps, m).psiPlus;
            if (i == static_cast<int>(offsetInSpacings) && j == 0) probe = static_cast<int>(P.size()) - 1;
        }
    emp::EigenErosion<2> e({1.0, 1.0, kappa});
    const double G = e.energyReleaseRate(P, {probe})[0];
    // The continuum ratio for a disc centred where the probe is: (i + 1/2, 1/2) spacings from the tip.
    const double Gfield = (1 - m.nu * m.nu) / m.E;
    const double d = P.x[probe].norm() / kappa;
    return G / (emp::initiationRatio<2>(m, CrackMode::I, d) * Gfield);
}

TEST(ErosionCalibration, EngineOnAPointLatticeApproachesTheContinuumRatio)
{
    // kappa = 1.1 h = 2.2 spacings at ppc = 2 (the paper's), then 4.4 and 8.8 spacings.
    const double e1 = latticeOverContinuum(2.2, 0) - 1;
    const double e2 = latticeOverContinuum(4.4, 0) - 1;
    const double e3 = latticeOverContinuum(8.8, 0) - 1;
    std::printf("lattice / continuum - 1 at kappa = 2.2, 4.4, 8.8 spacings: %+.4f %+.4f %+.4f\n", e1, e2, e3);
    EXPECT_LT(std::fabs(e1), 0.10);  // the discrete mean at the paper's kappa = 1.1 h
    EXPECT_LT(std::fabs(e3), std::fabs(e1));
    EXPECT_LT(std::fabs(e3), 0.05);
}

}  // namespace
