// TEMPLATE for a new constitutive law: copy this file to laws/MyLaw.hpp, rename the struct and
// `name`, fill in the hooks, then register it with one line in Laws.hpp (include + list entry).
// Python picks the name up from the module (ElasticMaterial(split='mylaw')), and the typed
// tests in tests/cpp/test_laws.cpp run on every registered law: energy identities (psi+ + psi-
// is the strain energy, sigma+ and sigma- are the derivatives of psi+ and psi-), the promise
// `tensionFree`, the patch test of the solver and the eroded stress.
//
// This template is not registered (users cannot select it) but compiles and passes the typed
// tests, which list it explicitly: as written it is linear elasticity with no split.
#pragma once
#include <cmath>

#include "../ElasticMaterial.hpp"

namespace emp {

struct TemplateLaw {
    /// The user's name (ElasticMaterial(split=...)); unique among the registered laws.
    static constexpr const char* name = "template";

    /// The compressive states the law promises to leave without tensile energy (psi+ = 0):
    /// none, hydrostatic, or allPrincipal. The typed tests check the promise.
    static constexpr Compression tensionFree = Compression::none;

    /// The response at total small strain eps (D = 2 or 3): sigma = g(c) sigma+ + sigma-
    /// (paper Eq 7) with the degradation g(c) = c applied by the solver; psi+ drives the history
    /// H = max psi+ (Eq 22) and erosion; psi- counts in the elastic energy (Eq 32). An eroded
    /// point (c = 0) keeps sigma-. Called once per point per step: keep it inline, free of
    /// allocation and of branches the compiler cannot predict. The material gives lambda and mu
    /// (plane-stress lambda* in 2D plane stress), nu, rho and planeStress.
    template <int D> static LawResponse<D> response(const Mat<D>& eps, const ElasticMaterial& m)
    {
        LawResponse<D> s;
        s.sigmaPlus = hooke<D>(eps, m.lambda, m.mu);
        s.sigmaMinus.setZero();
        s.psiPlus = strainEnergy<D>(eps, m.lambda, m.mu);
        s.psiMinus = 0.0;
        return s;
    }

    /// sigma_zz of a 2D point with damage variable c (output only: VTK, stress()). Plane stress
    /// returns 0; plane strain the law's sigma_zz at eps_zz = 0.
    static double outOfPlaneStress(const Mat<2>& eps, double c, const ElasticMaterial& m)
    {
        return m.planeStress ? 0.0 : c * m.lambda * eps.trace();
    }

    // Optional (Law.hpp): static void response2(...) and response3(...), the 2D and 3D responses
    // on plain numbers, which the solver then evaluates for runs of points in one vectorised
    // loop; see SpectralSplit.

    /// Dilatational wave speed: sets the critical time step h / (c + v_max).
    static double waveSpeed(const ElasticMaterial& m) { return std::sqrt((m.lambda + 2.0 * m.mu) / m.rho); }
};

}  // namespace emp
