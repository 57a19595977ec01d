// Volumetric-deviatoric tension/compression split (Amor, Marigo & Maurini 2009): only volume
// expansion and shape change carry tensile energy,
//   psi+ = K/2 <tr eps>+^2 + mu dev(eps):dev(eps),   psi- = K/2 <tr eps>-^2,
//   sigma+ = K <tr eps>+ I + 2 mu dev(eps),           sigma- = K <tr eps>- I,
// with the bulk modulus K = lambda + 2 mu / n and dev(eps) = eps - tr(eps)/n I in n dimensions.
// Hydrostatic compression has psi+ = 0 and never erodes; compression with shear does carry
// tensile energy (the split's known trait: it lets cracks grow in shear under compression).
// 3D and 2D plane strain use n = 3 (in plane strain eps_zz = 0 but dev_zz = -tr/3 counts);
// 2D plane stress uses the 2D law with lambda* (Law.hpp) and n = 2, so that with c = 1 every
// case is Hooke's law with the material's lambda and mu.
#pragma once
#include <cmath>

#include "../ElasticMaterial.hpp"

namespace emp {

struct VolumetricSplit {
    static constexpr const char* name = "volumetric";
    static constexpr Compression tensionFree = Compression::hydrostatic;

    /// Dimension n of the split: 2 for plane stress, 3 otherwise.
    template <int D> static int splitDimension(const ElasticMaterial& m) { return D == 2 && m.planeStress ? 2 : 3; }

    template <int D> static LawResponse<D> response(const Mat<D>& eps, const ElasticMaterial& m)
    {
        const int n = splitDimension<D>(m);
        const double K = m.lambda + 2.0 * m.mu / n;
        const double tr = eps.trace();
        const Mat<D> dev = eps - (tr / n) * Mat<D>::Identity();
        // dev:dev, with the out-of-plane component -tr/3 of a plane-strain point.
        const double devOut = D == 2 && n == 3 ? tr / 3.0 : 0.0;
        const double devdev = dev.squaredNorm() + devOut * devOut;
        const double tp = positivePart(tr), tm = negativePart(tr);
        LawResponse<D> s;
        s.psiPlus = 0.5 * K * tp * tp + m.mu * devdev;
        s.psiMinus = 0.5 * K * tm * tm;
        s.sigmaPlus = K * tp * Mat<D>::Identity() + 2.0 * m.mu * dev;
        s.sigmaMinus = K * tm * Mat<D>::Identity();
        return s;
    }

    /// Plane strain: sigma_zz = c (K <tr>+ - 2 mu tr/3) + K <tr>-.
    static double outOfPlaneStress(const Mat<2>& eps, double c, const ElasticMaterial& m)
    {
        if (m.planeStress) return 0.0;
        const double K = m.lambda + 2.0 * m.mu / 3.0, tr = eps.trace();
        return c * (K * positivePart(tr) - 2.0 * m.mu * tr / 3.0) + K * negativePart(tr);
    }

    static double waveSpeed(const ElasticMaterial& m) { return std::sqrt((m.lambda + 2.0 * m.mu) / m.rho); }
};

}  // namespace emp
