// The paper's law: linear elasticity with the spectral tension/compression split of the strain
// (Miehe et al.; paper Eqs 2-7). eps+ = sum <eps_i>+ n_i n_i over the principal strains,
//   psi+ = lambda/2 <tr eps>+^2 + mu tr(eps+^2),   psi- = lambda/2 <tr eps>-^2 + mu tr(eps-^2),
//   sigma+ = lambda <tr eps>+ I + 2 mu eps+,       sigma- = lambda <tr eps>- I + 2 mu eps-.
// Every principal strain <= 0 gives psi+ = 0: compression never erodes. In 2D plane strain the
// out-of-plane principal strain is 0 and adds nothing, so the 2D formulas are the 3D ones.
#pragma once
#include <algorithm>
#include <cmath>

#include "../ElasticMaterial.hpp"
#include "../Inline.hpp"

namespace emp {

struct SpectralSplit {
    static constexpr const char* name = "spectral";
    static constexpr Compression tensionFree = Compression::allPrincipal;

    /// Principal strains l and the tensile part eps+ (Eq 5) in 2D (tensilePart2 below).
    static void tensilePart(const Mat<2>& e, Vec<2>& l, Mat<2>& ep)
    {
        tensilePart2(e(0, 0), e(0, 1), e(1, 0), e(1, 1), l(0), l(1), ep(0, 0), ep(0, 1), ep(1, 0), ep(1, 1));
    }

    /// The 2D tensile part on plain numbers: eps = (exx, exy; eyx, eyy) gives the principal
    /// strains l0 >= l1 and eps+ = (pxx, pxy; pyx, pyy). Plain numbers and no branch, so that the
    /// solver can evaluate it for several points at once in a vectorised loop (response2): in a
    /// cracking or vibrating body the sign pattern changes from point to point.
    EMP_ALWAYS_INLINE static void tensilePart2(double exx, double exy, double eyx, double eyy, double& l0, double& l1,
                                               double& pxx, double& pxy, double& pyx, double& pyy)
    {
        const double m = 0.5 * (exx + eyy);
        const double d = 0.5 * (exx - eyy);
        const double r = std::sqrt(d * d + exy * exy);
        l0 = m + r;
        l1 = m - r;
        // Both principal strains >= 0: eps+ = eps; both <= 0: 0; else l0 > 0 > l1, the values
        // differ and the projector on n0 is (e - l1 I)/(l0 - l1). (The quotient of the unused
        // cases is never read; its denominator is kept nonzero.)
        const bool allTensile = l1 >= 0, allCompressive = l0 <= 0;
        const bool oneSign = allTensile | allCompressive;
        const double q = l0 / (oneSign ? 1.0 : l0 - l1);
        const double s = allTensile ? 1.0 : allCompressive ? 0.0 : q;
        const double shift = oneSign ? 0.0 : l1;
        pxx = s * (exx - shift);
        pyy = s * (eyy - shift);
        pxy = s * exy;
        pyx = s * eyx;
    }

    /// The 2D response on plain numbers (Law.hpp, "pointwise 2D response"): at strain eps =
    /// (exx, exy; eyx, eyy) and damage c, the stress c sigma+ + sigma- = (sxx, sxy; syx, syy),
    /// psi+ and psi-. Bitwise response<2> followed by the solver's degradation.
    EMP_ALWAYS_INLINE static void response2(double exx, double exy, double eyx, double eyy, double c, double lambda,
                                            double mu, double& sxx, double& sxy, double& syx, double& syy,
                                            double& psiPlus, double& psiMinus)
    {
        double l0, l1, pxx, pxy, pyx, pyy;
        tensilePart2(exx, exy, eyx, eyy, l0, l1, pxx, pxy, pyx, pyy);
        const double tr = exx + eyy;
        double sp2 = 0, sm2 = 0;
        sp2 += positivePart(l0) * positivePart(l0);
        sm2 += negativePart(l0) * negativePart(l0);
        sp2 += positivePart(l1) * positivePart(l1);
        sm2 += negativePart(l1) * negativePart(l1);
        psiPlus = 0.5 * lambda * positivePart(tr) * positivePart(tr) + mu * sp2;   // Eq 3
        psiMinus = 0.5 * lambda * negativePart(tr) * negativePart(tr) + mu * sm2;  // Eq 4
        // Eq 7: lambda <tr>+- I + 2 mu eps+-, the identity's zeros multiplied as in response<2>.
        const double lp = lambda * positivePart(tr), lm = lambda * negativePart(tr), twoMu = 2.0 * mu;
        sxx = c * (lp * 1.0 + twoMu * pxx) + (lm * 1.0 + twoMu * (exx - pxx));
        sxy = c * (lp * 0.0 + twoMu * pxy) + (lm * 0.0 + twoMu * (exy - pxy));
        syx = c * (lp * 0.0 + twoMu * pyx) + (lm * 0.0 + twoMu * (eyx - pyx));
        syy = c * (lp * 1.0 + twoMu * pyy) + (lm * 1.0 + twoMu * (eyy - pyy));
    }

    static void tensilePart(const Mat<3>& e, Vec<3>& l, Mat<3>& ep)
    {
        // Eigenvalues in closed form (no eigenvectors). They are accurate to round-off of the
        // deviator except within a nearly repeated pair, whose two values can be off by ~1e-8 of
        // the deviator while their sum stays exact.
        Eigen::SelfAdjointEigenSolver<Mat<3>> es;
        es.computeDirect(e, Eigen::EigenvaluesOnly);
        l = es.eigenvalues();  // ascending
        const double spread = l(2) - l(0);
        if (!(spread > 0)) {  // e = l I exactly
            if (l(0) >= 0) ep = e; else ep.setZero();
            return;
        }
        // All principal strains clearly of one sign (by much more than that error): Eq 5 directly.
        const double margin = 1e-6 * spread;
        if (l(0) >= margin) {
            ep = e;
            return;
        }
        if (l(2) <= -margin) {
            ep.setZero();
            return;
        }
        // Mixed or nearly zero principal strains. The products in mixedSigns square the strains:
        // strains far below 1e-154 (the leading edge of a wave in a 3D block: 1e-167 and, at a
        // finer h, subnormal 1e-316 measured) would underflow its projector's denominator to 0.
        // Such strains are scaled by a power of two to order 1 and back: exact in binary floating
        // point. Strains of ordinary size take the direct path (the scaling costs 6 % of a 3D
        // step), with bitwise the results either path would give.
        const double size = std::max(-l(0), l(2));
        if (size > 1e-100 && size < 1e100) {
            mixedSigns(e, l, ep);
            return;
        }
        int exponent = 0;
        std::frexp(e.cwiseAbs().maxCoeff(), &exponent);
        const int half = -exponent / 2;  // 2^1049 for a subnormal: two finite factors
        const double down1 = std::ldexp(1.0, half), down2 = std::ldexp(1.0, -exponent - half);
        const double up = std::ldexp(1.0, exponent);
        l = (down1 * l) * down2;
        mixedSigns((down1 * e) * down2, l, ep);
        ep *= up;
        l *= up;
    }

    /// Eq 5 for principal strains l (ascending) of mixed or nearly zero signs; l becomes the set of
    /// principal strains it used. The eigenvalue l_k farther from the other two is accurate, and so
    /// is its spectral projector P_k = (e - l_a I)(e - l_b I)/((l_k - l_a)(l_k - l_b)) (the pair's
    /// errors cancel to second order). The pair lives in the plane Q = I - P_k as B = e - l_k P_k;
    /// its values m -+ r come from the trace and the norm of B's deviator in the plane, with no
    /// cancellation, so a repeated pair (even at zero) is split exactly.
    static void mixedSigns(const Mat<3>& e, Vec<3>& l, Mat<3>& ep)
    {
        const int k = l(1) - l(0) >= l(2) - l(1) ? 0 : 2, a = k == 0 ? 1 : 0, b = k == 0 ? 2 : 1;
        const Mat<3> I = Mat<3>::Identity();
        const Mat<3> Pk = (e - l(a) * I) * (e - l(b) * I) / ((l(k) - l(a)) * (l(k) - l(b)));
        const Mat<3> Q = I - Pk;
        const Mat<3> B = e - l(k) * Pk;
        const double m = 0.5 * (e.trace() - l(k));
        const double r = std::sqrt(0.5 * (B - m * Q).squaredNorm());
        const double lminus = m - r, lplus = m + r;
        ep = positivePart(l(k)) * Pk;
        if (lminus >= 0)
            ep += B;
        else if (lplus > 0)
            ep += (lplus / (2.0 * r)) * (B - lminus * Q);  // lplus times the projector on its vector
        l << l(k), lminus, lplus;  // only the set of values is used below
    }

    template <int D> EMP_ALWAYS_INLINE static LawResponse<D> response(const Mat<D>& eps, const ElasticMaterial& mat)
    {
        const double lambda = mat.lambda, mu = mat.mu;
        Vec<D> l;
        Mat<D> ep;
        tensilePart(eps, l, ep);
        const Mat<D> em = eps - ep;  // Eq 6
        const double tr = eps.trace();
        double sp2 = 0, sm2 = 0;  // tr(eps+^2), tr(eps-^2) from the principal strains
        for (int i = 0; i < D; ++i) {
            sp2 += positivePart(l(i)) * positivePart(l(i));
            sm2 += negativePart(l(i)) * negativePart(l(i));
        }
        LawResponse<D> s;
        s.psiPlus = 0.5 * lambda * positivePart(tr) * positivePart(tr) + mu * sp2;   // Eq 3
        s.psiMinus = 0.5 * lambda * negativePart(tr) * negativePart(tr) + mu * sm2;  // Eq 4
        s.sigmaPlus = lambda * positivePart(tr) * Mat<D>::Identity() + 2.0 * mu * ep;  // Eq 7
        s.sigmaMinus = lambda * negativePart(tr) * Mat<D>::Identity() + 2.0 * mu * em;
        return s;
    }

    /// Plane strain: eps_zz = 0 is a principal strain, so sigma_zz = lambda (c <tr>+ + <tr>-).
    static double outOfPlaneStress(const Mat<2>& eps, double c, const ElasticMaterial& m)
    {
        if (m.planeStress) return 0.0;
        const double tr = eps.trace();
        return m.lambda * (c * positivePart(tr) + negativePart(tr));
    }

    static double waveSpeed(const ElasticMaterial& m) { return std::sqrt((m.lambda + 2.0 * m.mu) / m.rho); }
};

}  // namespace emp
