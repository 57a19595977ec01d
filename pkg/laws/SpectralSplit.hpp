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
        const Plain r(exx + eyy, c, lambda, mu);
        r.energies(r.squares(l0) + r.squares(l1), psiPlus, psiMinus);
        sxx = r.stress(1.0, exx, pxx);
        sxy = r.stress(0.0, exy, pxy);
        syx = r.stress(0.0, eyx, pyx);
        syy = r.stress(1.0, eyy, pyy);
    }

    /// Eqs 3-4 and 7 on plain numbers, for response2 and response3: in the operations and the
    /// order of response<D>, so that the results are bitwise the same.
    struct Plain {
        /// The sums of squared positive and negative principal strains, tr(eps+^2) and tr(eps-^2).
        struct Squares {
            double plus, minus;
            EMP_ALWAYS_INLINE Squares operator+(const Squares& o) const { return {plus + o.plus, minus + o.minus}; }
        };
        double tr, c, lambda, mu, lp, lm, twoMu;
        EMP_ALWAYS_INLINE Plain(double tr, double c, double lambda, double mu)
            : tr(tr), c(c), lambda(lambda), mu(mu), lp(lambda * positivePart(tr)), lm(lambda * negativePart(tr)),
              twoMu(2.0 * mu)
        {
        }
        /// A principal strain's squares. (Summed from the first, as response<D>'s loop sums them
        /// from 0: both squares are >= +0, so 0 + x is x.)
        EMP_ALWAYS_INLINE static Squares squares(double l)
        {
            return {positivePart(l) * positivePart(l), negativePart(l) * negativePart(l)};
        }
        EMP_ALWAYS_INLINE void energies(const Squares& s, double& psiPlus, double& psiMinus) const
        {
            psiPlus = 0.5 * lambda * positivePart(tr) * positivePart(tr) + mu * s.plus;   // Eq 3
            psiMinus = 0.5 * lambda * negativePart(tr) * negativePart(tr) + mu * s.minus;  // Eq 4
        }
        /// Eq 7's c sigma+ + sigma- = c (lambda <tr>+ I + 2 mu eps+) + lambda <tr>- I + 2 mu eps-,
        /// one entry: `identity` is I's entry (its zeros multiplied, as in response<D>), e eps's
        /// and p eps+'s.
        EMP_ALWAYS_INLINE double stress(double identity, double e, double p) const
        {
            return c * (lp * identity + twoMu * p) + (lm * identity + twoMu * (e - p));
        }
    };

    /// Whether the 3D tensile part takes a strain whose largest entry (in magnitude) is amax
    /// directly: its squares and products neither underflow nor overflow. Others (strains far
    /// below 1e-154 at the leading edge of a wave in a 3D block: 1e-167 and, at a finer h,
    /// subnormal 1e-316 measured) are scaled by a power of two to order 1 and back, which is exact
    /// in binary floating point and gives bitwise what the direct path would. A NaN strain is
    /// ordinary (its NaN reaches the stress, which the step's check reports).
    EMP_ALWAYS_INLINE static bool ordinary3(double amax) { return !(amax >= 1e100) & !((amax > 0) & (amax <= 1e-100)); }

    /// The 3D tensile part (Eq 5) of a symmetric strain given by its lower triangle, on plain
    /// numbers and without branches, so that the solver evaluates it for several points at once
    /// in a vectorised loop (response3): principal strains l0, l1, l2 (a set, in no order) and
    /// eps+ = (pxx, pyx, pzx; pyx, pyy, pzy; pzx, pzy, pzz). For an ordinary3 strain.
    ///
    /// No eigenvectors and no trigonometric function. With q = tr/3 and p^2 = |e - q I|^2 / 6,
    /// B = (e - q I) / p has the principal values 2 cos(phi + 2 pi j / 3), cos(3 phi) = det(B)/2 =
    /// r. The value farther from the other two (the largest for r > 0, else the smallest) is
    /// beta_k = +-2 c with c the largest root of 4 c^3 - 3 c = |r|, c in [sqrt(3)/2, 1]: four Newton
    /// steps from the chord c = sqrt(3)/2 + (1 - sqrt(3)/2) |r| reach it to round-off for every r
    /// (three do; measured against cos(acos(|r|)/3) on 2e5 values). Its value l_k = q + p beta_k is
    /// accurate to round-off of the deviator, and so is its spectral projector, which needs no
    /// other value: the other two are the roots of beta^2 + beta_k beta + beta_k^2 - 3 (trace 0,
    /// tr(B^2) = 6), so P_k = (B^2 + beta_k B + (beta_k^2 - 3) I) / (3 (beta_k^2 - 1)), with a
    /// denominator between 6 and 9. The other pair lives in the plane Q = I - P_k as e - l_k P_k;
    /// its values m -+ s come from its trace and the norm of its deviator in the plane, with no
    /// cancellation, so a repeated pair (even at zero) is split exactly. allTensile and
    /// allCompressive tell when eps+ is all of e or none of it (every principal strain of one
    /// sign by more than 1e-6 of their spread, or e = q I).
    EMP_ALWAYS_INLINE static void tensilePart3(double xx, double yy, double zz, double yx, double zx, double zy,
                                               double& l0, double& l1, double& l2, double& pxx, double& pyy,
                                               double& pzz, double& pyx, double& pzx, double& pzy, bool& allTensile,
                                               bool& allCompressive)
    {
        const double tr = xx + (yy + zz), q = tr / 3.0;
        const double a = xx - q, b = yy - q, c = zz - q;
        const double p = std::sqrt(((a * a + b * b) + c * c + 2.0 * ((yx * yx + zx * zx) + zy * zy)) / 6.0);
        const bool isotropic = !(p > 0);  // e = q I (or NaN)
        const double ip = 1.0 / (isotropic ? 1.0 : p);
        const double ba = a * ip, bb = b * ip, bc = c * ip, byx = yx * ip, bzx = zx * ip, bzy = zy * ip;
        const double det = ba * (bb * bc - bzy * bzy) - byx * (byx * bc - bzy * bzx) + bzx * (byx * bzy - bb * bzx);
        const double h = 0.5 * det, r = h > 1.0 ? 1.0 : h < -1.0 ? -1.0 : h;
        const double ar = r < 0 ? -r : r;
        // (Written out: a loop left inside the lanes' loop keeps GCC from vectorising it.)
        const auto newton = [ar](double x) EMP_LAMBDA_INLINE { return x - ((4.0 * x * x - 3.0) * x - ar) / (12.0 * x * x - 3.0); };
        const double cs = newton(newton(newton(newton(0.8660254037844386 + 0.1339745962155614 * ar))));
        const double beta = r > 0 ? 2.0 * cs : -2.0 * cs;
        const double lk = q + p * beta;
        const double k0 = beta * beta - 3.0, id = 1.0 / (3.0 * (beta * beta - 1.0));
        const double Pxx = (((ba * ba + byx * byx) + bzx * bzx) + beta * ba + k0) * id;
        const double Pyy = (((byx * byx + bb * bb) + bzy * bzy) + beta * bb + k0) * id;
        const double Pzz = (((bzx * bzx + bzy * bzy) + bc * bc) + beta * bc + k0) * id;
        const double Pyx = (((byx * ba + bb * byx) + bzy * bzx) + beta * byx) * id;
        const double Pzx = (((bzx * ba + bzy * byx) + bc * bzx) + beta * bzx) * id;
        const double Pzy = (((bzx * byx + bzy * bb) + bc * bzy) + beta * bzy) * id;
        // The pair: e - l_k P_k (its part in the plane) and its deviator there, minus m (I - P_k).
        const double Bxx = xx - lk * Pxx, Byy = yy - lk * Pyy, Bzz = zz - lk * Pzz;
        const double Byx = yx - lk * Pyx, Bzx = zx - lk * Pzx, Bzy = zy - lk * Pzy;
        const double m = 0.5 * (tr - lk);
        const double Dxx = Bxx - m * (1.0 - Pxx), Dyy = Byy - m * (1.0 - Pyy), Dzz = Bzz - m * (1.0 - Pzz);
        const double Dyx = Byx + m * Pyx, Dzx = Bzx + m * Pzx, Dzy = Bzy + m * Pzy;
        const double s = std::sqrt(0.5 * ((Dxx * Dxx + Dyy * Dyy) + Dzz * Dzz + 2.0 * ((Dyx * Dyx + Dzx * Dzx) + Dzy * Dzy)));
        const double lminus = m - s, lplus = m + s;
        // All principal strains clearly of one sign: eps+ = e or 0; else <l_k>+ P_k plus the
        // pair's positive part: all of it, lplus times the projector on its vector
        // (B - lminus Q) / (2 s), or none. (The quotients of the unused cases are never read.)
        const double lmin = lk < lminus ? lk : lminus, lmax = lk > lplus ? lk : lplus;
        const double margin = 1e-6 * (lmax - lmin);
        allTensile = (isotropic & (q >= 0)) | (!isotropic & (lmin >= margin));
        allCompressive = (isotropic & !(q >= 0)) | (!isotropic & (lmax <= -margin));
        const double pk = positivePart(lk);
        const bool whole = lminus >= 0, part = !whole & (lplus > 0);
        const double t = part ? lplus / (2.0 * s) : 0.0;
        const auto pick = [&](double e, double P, double B, double Q) EMP_LAMBDA_INLINE {
            const double pair = whole ? B : t * (B - lminus * Q);
            return allTensile ? e : allCompressive ? 0.0 : pk * P + pair;
        };
        pxx = pick(xx, Pxx, Bxx, 1.0 - Pxx);
        pyy = pick(yy, Pyy, Byy, 1.0 - Pyy);
        pzz = pick(zz, Pzz, Bzz, 1.0 - Pzz);
        pyx = pick(yx, Pyx, Byx, 0.0 - Pyx);
        pzx = pick(zx, Pzx, Bzx, 0.0 - Pzx);
        pzy = pick(zy, Pzy, Bzy, 0.0 - Pzy);
        l0 = isotropic ? q : lk;
        l1 = isotropic ? q : lminus;
        l2 = isotropic ? q : lplus;
    }

    /// Principal strains l (a set) and the tensile part eps+ (Eq 5) in 3D: tensilePart3 of the
    /// strain's lower triangle, scaled to order 1 and back where it is not ordinary3. A strain
    /// that is not quite symmetric (R k R^T rounded) keeps its upper triangle where eps+ is all
    /// of it, so that a tensile strain has no compressive part at all; elsewhere eps+ is the
    /// lower triangle's, mirrored.
    static void tensilePart(const Mat<3>& e, Vec<3>& l, Mat<3>& ep)
    {
        double xx = e(0, 0), yy = e(1, 1), zz = e(2, 2), yx = e(1, 0), zx = e(2, 0), zy = e(2, 1);
        const double amax = largest3(xx, yy, zz, yx, zx, zy);
        double up = 1.0;
        if (!ordinary3(amax) && std::isfinite(amax)) {
            int exponent = 0;
            std::frexp(amax, &exponent);
            const int half = -exponent / 2;  // 2^1049 for a subnormal: two finite factors
            const double down1 = std::ldexp(1.0, half), down2 = std::ldexp(1.0, -exponent - half);
            up = std::ldexp(1.0, exponent);
            for (double* x : {&xx, &yy, &zz, &yx, &zx, &zy}) *x = (down1 * *x) * down2;
        }
        double pxx, pyy, pzz, pyx, pzx, pzy;
        bool allTensile, allCompressive;
        tensilePart3(xx, yy, zz, yx, zx, zy, l(0), l(1), l(2), pxx, pyy, pzz, pyx, pzx, pzy, allTensile, allCompressive);
        ep << pxx, pyx, pzx, pyx, pyy, pzy, pzx, pzy, pzz;
        if (up != 1.0) {
            ep *= up;
            l *= up;
        }
        if (allTensile) ep = e;
    }

    /// The largest magnitude of six numbers, or NaN if one is NaN (for ordinary3).
    EMP_ALWAYS_INLINE static double largest3(double xx, double yy, double zz, double yx, double zx, double zy)
    {
        const auto larger = [](double m, double x) EMP_LAMBDA_INLINE {
            const double a = std::fabs(x);
            return a > m || a != a ? a : m;
        };
        return larger(larger(larger(larger(larger(std::fabs(xx), yy), zz), yx), zx), zy);
    }

    /// The 3D response on plain numbers (Law.hpp, "pointwise 3D response"): at a symmetric strain
    /// (lower triangle) and damage c, the stress c sigma+ + sigma- (lower triangle), psi+ and
    /// psi-. Bitwise response<3> followed by the solver's degradation, for an ordinary3 strain
    /// (`ordinary` tells; the solver takes the others point by point).
    EMP_ALWAYS_INLINE static void response3(double xx, double yy, double zz, double yx, double zx, double zy, double c,
                                            double lambda, double mu, double& sxx, double& syy, double& szz,
                                            double& syx, double& szx, double& szy, double& psiPlus,
                                            double& psiMinus, bool& ordinary)
    {
        ordinary = ordinary3(largest3(xx, yy, zz, yx, zx, zy));
        double l0, l1, l2, pxx, pyy, pzz, pyx, pzx, pzy;
        bool allTensile, allCompressive;
        tensilePart3(xx, yy, zz, yx, zx, zy, l0, l1, l2, pxx, pyy, pzz, pyx, pzx, pzy, allTensile, allCompressive);
        const Plain r(xx + (yy + zz), c, lambda, mu);
        r.energies(r.squares(l0) + r.squares(l1) + r.squares(l2), psiPlus, psiMinus);
        sxx = r.stress(1.0, xx, pxx);
        syy = r.stress(1.0, yy, pyy);
        szz = r.stress(1.0, zz, pzz);
        syx = r.stress(0.0, yx, pyx);
        szx = r.stress(0.0, zx, pzx);
        szy = r.stress(0.0, zy, pzy);
    }

    template <int D> EMP_ALWAYS_INLINE static LawResponse<D> response(const Mat<D>& eps, const ElasticMaterial& mat)
    {
        const double lambda = mat.lambda, mu = mat.mu;
        Vec<D> l;
        Mat<D> ep;
        tensilePart(eps, l, ep);
        const Mat<D> em = eps - ep;  // Eq 6
        const double tr = D == 2 ? eps.trace() : eps(0, 0) + (eps(1, 1) + eps(D - 1, D - 1));  // (as response3)
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
