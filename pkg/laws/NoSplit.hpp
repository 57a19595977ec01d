// No split: the whole strain energy is tensile (psi+ = psi, sigma+ = sigma, sigma- = 0). An
// eroded point then carries no stress at all, in compression too. For comparisons with the
// split laws, and for materials whose fracture is not driven by tension alone.
#pragma once
#include <cmath>

#include "../ElasticMaterial.hpp"

namespace emp {

struct NoSplit {
    static constexpr const char* name = "none";
    static constexpr Compression tensionFree = Compression::none;

    template <int D> static LawResponse<D> response(const Mat<D>& eps, const ElasticMaterial& m)
    {
        LawResponse<D> s;
        s.sigmaPlus = hooke<D>(eps, m.lambda, m.mu);
        s.sigmaMinus.setZero();
        s.psiPlus = strainEnergy<D>(eps, m.lambda, m.mu);
        s.psiMinus = 0.0;
        return s;
    }

    static double outOfPlaneStress(const Mat<2>& eps, double c, const ElasticMaterial& m)
    {
        return m.planeStress ? 0.0 : c * m.lambda * eps.trace();
    }

    static double waveSpeed(const ElasticMaterial& m) { return std::sqrt((m.lambda + 2.0 * m.mu) / m.rho); }
};

}  // namespace emp
