// The points' strain and stress as they are stored (MaterialPoints). In 2D a symmetric 2 x 2
// tensor by its three components, 24 bytes instead of a matrix's 32 (issue 12 item 3: the
// memory per point); in 3D the full matrix.
//
// Storing three numbers loses nothing in 2D: every path of the step produces bitwise symmetric
// tensors from a symmetric strain (the small-strain increment sym(L) dt, the co-rotational
// update's symmetrised U and Cauchy stress, and each registered law's response; tested in
// test_laws.cpp and test_kinematics.cpp). A tensor that is not symmetric (a user's law) is
// stored as its symmetric part, which for a symmetric one is bitwise itself: 0.5 (a + a) = a.
#pragma once
#include <cmath>
#include <type_traits>

#include "Law.hpp"

namespace emp {

/// A symmetric 2 x 2 tensor: xx, xy (= yx), yy. Trivially copyable (saved states, a distributed
/// run's messages copy it by its bytes).
struct Sym2 {
    double xx = 0, xy = 0, yy = 0;

    Sym2() = default;
    Sym2(double a, double b, double c) : xx(a), xy(b), yy(c) {}
    /// The symmetric part of m (bitwise m's own components when m is symmetric).
    Sym2(const Mat<2>& m) : Sym2(of(m(0, 0), m(0, 1), m(1, 0), m(1, 1))) {}

    /// The symmetric part of (xx, xy; yx, yy).
    static Sym2 of(double xx, double xy, double yx, double yy) { return {xx, 0.5 * (xy + yx), yy}; }

    Mat<2> mat() const
    {
        Mat<2> m;
        m << xx, xy, xy, yy;
        return m;
    }
    double operator()(int i, int j) const { return i != j ? xy : i == 0 ? xx : yy; }
    double trace() const { return xx + yy; }
    bool allFinite() const { return std::isfinite(xx) && std::isfinite(xy) && std::isfinite(yy); }
    void setConstant(double v) { xx = xy = yy = v; }
    /// Adds a symmetric increment (its yx is not read: the increments added are symmetric).
    Sym2& operator+=(const Mat<2>& d)
    {
        xx += d(0, 0);
        xy += d(0, 1);
        yy += d(1, 1);
        return *this;
    }
    bool operator==(const Sym2& o) const { return xx == o.xx && xy == o.xy && yy == o.yy; }
    bool operator!=(const Sym2& o) const { return !(*this == o); }
};
static_assert(std::is_trivially_copyable<Sym2>::value && sizeof(Sym2) == 3 * sizeof(double), "Sym2 is three doubles");

/// A point's strain or stress as stored.
template <int D> using PointTensor = std::conditional_t<D == 2, Sym2, Mat<D>>;

/// The D x D matrix of a stored tensor.
inline Mat<2> full(const Sym2& s) { return s.mat(); }
inline const Mat<3>& full(const Mat<3>& m) { return m; }
/// The sum of a stored tensor's numbers: finite exactly when each is, unless it overflows.
inline double sumOf(const Sym2& s) { return s.xx + s.xy + s.yy; }
inline double sumOf(const Mat<3>& m) { return m.sum(); }

/// Stores the value of the matrix expression e (2D: its symmetric part).
template <class E> void store(Sym2& t, const Eigen::MatrixBase<E>& e) { t = Sym2(Mat<2>(e)); }
template <class E> void store(Mat<3>& t, const Eigen::MatrixBase<E>& e) { t = e; }

}  // namespace emp
