#include "ElasticMaterial.hpp"

#include <cmath>

#include "Errors.hpp"
#include "Laws.hpp"

namespace emp {

ElasticMaterial ElasticMaterial::make(double E, double nu, double rho, bool planeStress, int dim, int law)
{
    require(std::isfinite(E) && E > 0, "E (Young's modulus, Pa)", E, "E > 0");
    require(std::isfinite(nu) && nu > -1.0 && nu < 0.5, "nu (Poisson's ratio)", nu, "-1 < nu < 0.5");
    require(std::isfinite(rho) && rho > 0, "rho (density, kg/m3)", rho, "rho > 0");
    require(law >= 0 && law < RegisteredLaws::size, "law (index of the split)", law,
            "0 <= law < " + std::to_string(RegisteredLaws::size) + " (registered laws)");
    ElasticMaterial m;
    m.E = E;
    m.nu = nu;
    m.rho = rho;
    m.planeStress = planeStress && dim == 2;
    m.law = law;
    m.mu = E / (2.0 * (1.0 + nu));
    m.lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    if (m.planeStress) m.lambda = 2.0 * m.lambda * m.mu / (m.lambda + 2.0 * m.mu);
    return m;
}

double ElasticMaterial::waveSpeed() const
{
    double c = 0;
    withLaw(law, [&](auto l) { c = decltype(l)::waveSpeed(*this); });
    return c;
}

}  // namespace emp
