// An isotropic elastic material: its constants and the law (split) it uses. The laws are
// compile-time policies (Law.hpp, laws/, Laws.hpp); a material names one by its index.
#pragma once
#include "Law.hpp"

namespace emp {

/// Isotropic elastic constants and the law of one material. In 2D the material is plane strain
/// or plane stress; plane stress replaces lambda by 2 lambda mu / (lambda + 2 mu), so the 2D law
/// is the plane-stress law.
struct ElasticMaterial {
    double E = 0, nu = 0, rho = 0;
    bool planeStress = false;
    double lambda = 0, mu = 0;  ///< Lame constants used by the (2D or 3D) law
    int law = 0;                ///< index of the law in RegisteredLaws

    /// Validates E > 0, -1 < nu < 0.5, rho > 0 and the law index (0 <= law < number of
    /// registered laws), and computes the Lame constants; planeStress is ignored in 3D.
    static ElasticMaterial make(double E, double nu, double rho, bool planeStress, int dim, int law);
    /// Speed of the dilatational wave of the material's law.
    double waveSpeed() const;
};

}  // namespace emp
