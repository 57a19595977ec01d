// Shared helpers of the C++ unit tests (header only; CMake globs only tests/cpp/*.cpp).
#pragma once
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "Errors.hpp"
#include "Laws.hpp"
#include "Solver.hpp"

namespace emptest {

using emp::Mat;
using emp::Vec;

/// The bits of a double (a signed zero differs from the other, a NaN equals itself).
inline std::uint64_t bits(double x)
{
    std::uint64_t b;
    std::memcpy(&b, &x, sizeof b);
    return b;
}

/// Every point's stress (Solver::stressOf: not stored), by point id.
template <class Sv> std::vector<Mat<Sv::dim>> stressesOf(const Sv& s)
{
    std::vector<Mat<Sv::dim>> out(s.points().size());
    for (std::size_t p = 0; p < out.size(); ++p) out[p] = s.stressOf(p);
    return out;
}

/// The stresses as s's stress pass makes them (Solver::observeStresses), by point id, from the
/// next step on (each step's replace the last's; NaN until a step); for tests of the pass's
/// vectorised laws and of stressOf. The points must have been added.
template <class Sv> std::shared_ptr<std::vector<Mat<Sv::dim>>> recordStresses(Sv& s)
{
    constexpr int D = Sv::dim;
    auto out = std::make_shared<std::vector<Mat<D>>>(s.points().size(), Mat<D>::Constant(std::numeric_limits<double>::quiet_NaN()));
    s.observeStresses([o = out.get()](const int* ids, int n, const emp::PointTensor<D>* sigma) {
        for (int i = 0; i < n; ++i) (*o)[ids[i]] = emp::full(sigma[i]);
    });
    return out;
}

/// A (dimension, shape function) pair for typed tests.
template <int D_, class K_> struct Config {
    static constexpr int D = D_;
    using K = K_;
    using S = emp::Solver<D_, K_>;
};

/// ::testing::Types of a TypeList, each element turned into T<element>.
template <class L, template <class> class T> struct GTestTypes;
template <class... E, template <class> class T> struct GTestTypes<emp::TypeList<E...>, T> {
    using type = ::testing::Types<typename T<E>::type...>;
};
template <class C> struct ConfigOf {
    using type = Config<C::D, typename C::Kernel>;
};
/// Every configuration the product is built for (Configurations.hpp): the typed tests' list.
using AllSolvers = typename GTestTypes<emp::Configurations, ConfigOf>::type;

/// Settings of a typical test scene: 2 points per cell, the engine's mass cut-off and padding,
/// no gravity; h is set by each test (the solver takes no defaults of its own).
inline emp::SolverSettings typicalSettings(double h = std::numeric_limits<double>::quiet_NaN(), int ppc = 2)
{
    emp::SolverSettings s;
    s.h = h;
    s.ppc = ppc;
    s.massCutoff = 1e-14;
    s.padding = 3;
    s.gravity.setZero();
    s.transfer = emp::Transfer::flip;
    s.stressUpdate = emp::StressUpdate::smallStrain;
    return s;
}

/// Pads a D-vector to the 3-vector the Solver interface takes.
template <int D> Eigen::Vector3d to3(const Vec<D>& v)
{
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    r.head<D>() = v;
    return r;
}

/// Calls f(std::array<int, D> index) for every index in the box [lo, hi).
template <int D, class F> void forBox(const std::array<int, D>& lo, const std::array<int, D>& hi, F&& f)
{
    std::array<int, D> i = lo;
    for (int d = 0; d < D; ++d)
        if (hi[d] <= lo[d]) return;
    while (true) {
        f(i);
        int d = 0;
        while (d < D) {
            if (++i[d] < hi[d]) break;
            i[d] = lo[d];
            ++d;
        }
        if (d == D) return;
    }
}

/// Regular block of points at the centres of the ppc^D sub-cells of the cells [cellLo, cellHi)
/// (cell c spans [c h, (c+1) h)). Each point gets velocity vel(x). Returns the new point ids.
template <int D, class K, class VelFn>
std::vector<int> addBlock(emp::Solver<D, K>& s, const std::array<int, D>& cellLo,
                          const std::array<int, D>& cellHi, int mat, VelFn&& vel)
{
    const double h = s.settings().h;
    const int ppc = s.settings().ppc;
    const double dx = h / ppc;
    const double vol = std::pow(dx, D);
    std::array<int, D> lo, hi;
    for (int d = 0; d < D; ++d) {
        lo[d] = cellLo[d] * ppc;
        hi[d] = cellHi[d] * ppc;
    }
    std::vector<int> ids;
    forBox<D>(lo, hi, [&](const std::array<int, D>& i) {
        Vec<D> x;
        for (int d = 0; d < D; ++d) x[d] = (i[d] + 0.5) * dx;
        const Vec<D> v = vel(x);
        ids.push_back(s.addPoint(to3<D>(x), to3<D>(v), vol, mat));
    });
    return ids;
}

template <int D, class K>
std::vector<int> addBlock(emp::Solver<D, K>& s, const std::array<int, D>& cellLo,
                          const std::array<int, D>& cellHi, int mat)
{
    return addBlock<D, K>(s, cellLo, cellHi, mat, [](const Vec<D>&) { return Vec<D>::Zero(); });
}

template <int D> Vec<D> totalMomentum(const emp::MaterialPoints<D>& P)
{
    Vec<D> m = Vec<D>::Zero();
    for (std::size_t p = 0; p < P.size(); ++p) m += P.mass(p) * P.v[p];
    return m;
}

template <int D> Vec<D> massMoment(const emp::MaterialPoints<D>& P)
{
    Vec<D> m = Vec<D>::Zero();
    for (std::size_t p = 0; p < P.size(); ++p) m += P.mass(p) * P.x[p];
    return m;
}

template <class A> double sum(const std::vector<double, A>& a)
{
    double s = 0;
    for (double x : a) s += x;
    return s;
}

/// Random rotation matrix (uniform enough for tests) from a generator.
template <int D> Mat<D> randomRotation(std::mt19937& rng)
{
    std::normal_distribution<double> n(0.0, 1.0);
    Mat<D> a;
    for (int i = 0; i < D; ++i)
        for (int j = 0; j < D; ++j) a(i, j) = n(rng);
    Eigen::HouseholderQR<Mat<D>> qr(a);
    Mat<D> q = qr.householderQ();
    if (q.determinant() < 0) q.col(0) *= -1.0;
    return q;
}

template <int D> Mat<D> randomSymmetric(std::mt19937& rng, double scale)
{
    std::uniform_real_distribution<double> u(-scale, scale);
    Mat<D> a;
    for (int i = 0; i < D; ++i)
        for (int j = 0; j < D; ++j) a(i, j) = u(rng);
    return 0.5 * (a + a.transpose());
}

/// Isotropic Hooke's law with the Lame constants (lambda, mu).
template <int D> Mat<D> hooke(const Mat<D>& eps, double lambda, double mu)
{
    return lambda * eps.trace() * Mat<D>::Identity() + 2.0 * mu * eps;
}

inline bool contains(const std::string& s, const std::string& sub) { return s.find(sub) != std::string::npos; }

/// Runs f, expects an exception of type Ex and returns its message.
template <class Ex, class F> std::string messageOf(F&& f)
{
    try {
        f();
    } catch (const Ex& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "wrong exception type: " << e.what();
        return "";
    }
    ADD_FAILURE() << "no exception thrown";
    return "";
}

}  // namespace emptest
