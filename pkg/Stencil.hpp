// The shape functions of one point on its S^D support nodes (paper Eq 15: tensor products of the
// kernel's 1D weights), and the phantom-node rule that swaps marked nodes for their twins across
// a pre-existing crack (Section 3.3.1). Computed once per point per step, in P2G, and reused by
// the stress/force pass and by G2P.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <type_traits>

#include "Grid.hpp"
#include "PhantomNodes.hpp"
#include "ShapeFunction.hpp"

#include "Inline.hpp"
#include "Lanes.hpp"

namespace emp {

/// A 3-vector in the first three lanes of a 4-double vector (GCC's vector extension: one AVX
/// register inside withLaneIsa, two SSE ones outside). Its sums are those of Eigen's 3-vectors,
/// component by component (the same operations in the same order: the same values), which GCC
/// leaves as three scalar operations each. Nodal arrays carry a tail (ZeroPages::tail), so that
/// the 32 bytes from any element may be read; the fourth lane is cleared after the load.
struct Lane3 {
    typedef double V __attribute__((vector_size(4 * sizeof(double))));
    typedef long long Bits __attribute__((vector_size(4 * sizeof(double))));
    V v;
    static EMP_ALWAYS_INLINE Lane3 zero() { return Lane3{V{0.0, 0.0, 0.0, 0.0}}; }
    /// The nodal value at `at` (an element of a ZeroPages array).
    static EMP_ALWAYS_INLINE Lane3 load(const Vec<3>& at)
    {
        V loaded;
        __builtin_memcpy(&loaded, at.data(), sizeof(V));
        // (A mask in a register: clearing the lane by an element store went through the stack,
        // and the reload waited on the two stores, about twice the time of the sums it served.)
        return Lane3{reinterpret_cast<V>(reinterpret_cast<Bits>(loaded) & Bits{-1, -1, -1, 0})};
    }
    /// a in the first three lanes; the fourth repeats the third (scatterRowsAffineOf, its only user,
    /// reads no sum of it). Built from two 2-lane halves: as V{a0, a1, a2, 0} GCC assembled the
    /// vector in memory, and reading it back waited on the narrower stores. (A zero fourth lane
    /// made GCC emit a register form of vmovq that valgrind 3.19 does not decode.)
    static EMP_ALWAYS_INLINE Lane3 of(const Vec<3>& a)
    {
        typedef double V2 __attribute__((vector_size(2 * sizeof(double))));
        const V2 lo{a[0], a[1]}, hi{a[2], a[2]};
        return Lane3{__builtin_shufflevector(lo, hi, 0, 1, 2, 3)};
    }
    friend EMP_ALWAYS_INLINE Lane3 operator+(const Lane3& a, const Lane3& b) { return Lane3{a.v + b.v}; }
    EMP_ALWAYS_INLINE Lane3& operator+=(const Lane3& o)
    {
        v += o.v;
        return *this;
    }
    friend EMP_ALWAYS_INLINE Lane3 operator*(double s, const Lane3& a) { return Lane3{s * a.v}; }
    EMP_ALWAYS_INLINE Vec<3> vec() const { return Vec<3>(v[0], v[1], v[2]); }
};

template <int D, class K> struct Stencil {
    static constexpr int S = K::S;
    static constexpr int NS = D == 2 ? S * S : S * S * S;
    /// APIC's P2G needs of a point's position, per direction d: b[d], the offset (x_I - x_p) / h
    /// of its first support node, and r[d], the reciprocal of h times its moment diagonal in
    /// cells, or 0 where that is not positive (affineFrameAlong).
    struct AffineFrame {
        double b[D], r[D];
    };
    /// The frames of a run of up to R points (computeRun), by direction: point i's r[d] at
    /// r[d][i], and its offsets written to b[d][i] (the caller's arrays: Solver::offset_, which
    /// G2P reads), with no copy into per-point frames in between. Where rOut is set, r[d][i] goes
    /// to rOut[d][i] too (Solver: G2P reads r as well; a copy of the run's r after computeRun was a
    /// library memcpy per run, 1.5 % of the 2D step with both options).
    template <int R> struct AffineRun {
        double* b[D];
        double* rOut[D] = {};
        alignas(64) double r[D][R];
        EMP_ALWAYS_INLINE AffineFrame frame(int i) const
        {
            AffineFrame f;
            for (int d = 0; d < D; ++d) f.b[d] = b[d][i], f.r[d] = r[d][i];
            return f;
        }
    };
    /// Index of the support's base node (its lowest corner) on the regular lattice. One number
    /// instead of the D lattice coordinates (8 B per point less in 2D and 3D: issue 12 item 3);
    /// baseOf recovers a coordinate where one is needed.
    int first;
    int remap;  ///< offset of the node indices in Grid::remap, or -1 (the regular lattice's nodes)
    double w[D][S], dw[D][S];

    /// The base node's index from its lattice coordinates b.
    static EMP_ALWAYS_INLINE int firstOf(const Grid<D>& g, const int* b)
    {
        int f = b[0] + b[1] * g.stride[1];
        if constexpr (D == 3) f += b[D - 1] * g.stride[D - 1];
        return f;
    }
    /// The base node's lattice coordinate along d (integer divisions: outside the passes' loops).
    int baseOf(const Grid<D>& g, int d) const
    {
        int r = first;
        for (int e = D - 1; e > d; --e) r %= g.stride[e];
        return r / g.stride[d];
    }
    /// The base node's coordinate along d of the point at x, from x as compute() found it (the
    /// same operations, so the same integer; cheaper than baseOf's divisions in the passes).
    static EMP_ALWAYS_INLINE int baseAt(const Vec<D>& x, const Grid<D>& g, int d)
    {
        return K::base((x[d] - g.origin[d]) * g.invh);
    }

    /// Weights and derivatives of the point at x for the particle half-width lp (cells).
    void compute(const Vec<D>& x, const Grid<D>& g, const HalfWidth& lp)
    {
        double xi[D];
        int base[D];
        for (int d = 0; d < D; ++d) xi[d] = (x[d] - g.origin[d]) * g.invh;
        K::template evalAll<D>(xi, lp, base, w, dw);
        first = firstOf(g, base);
        remap = -1;
    }

    /// compute() for the n <= R points at positions x(0) ... x(n-1), into out[0 ... n-1], with a
    /// kernel that evaluates one point per lane (K::laneEvaluation): the weights of all n in one
    /// loop in the processor's widest vectors (pkg/Lanes.hpp), then copied into the stencils.
    /// Bitwise compute()'s (the same operations per point).
    /// With `box` (the marked nodes' box, Solver::markedBox), near[i] tells whether point i's
    /// support overlaps it (overlaps(): the same base nodes, so the same answer), from the lanes'
    /// base nodes instead of the position once more per point in the scatter; `any` whether
    /// one does. near holds R flags, written only where `any` is set.
    struct Box {
        const int* lo;
        const int* hi;
        int* near;
        int any;
    };
    template <int R, class X>
    static EMP_ALWAYS_INLINE void computeRun(int n, X&& x, const Grid<D>& g, const HalfWidth& lp, Stencil* out,
                                             Box* box = nullptr)
    {
        computeRun<R, false>(n, x, g, lp, out, static_cast<AffineRun<R>*>(nullptr), box);
    }
    /// computeRun with each point's APIC frame (affineFrame) too, from the same lanes, into
    /// `frames` (point i's frame: frames.frame(i)).
    template <int R, class X>
    static EMP_ALWAYS_INLINE void computeRun(int n, X&& x, const Grid<D>& g, const HalfWidth& lp, Stencil* out,
                                             AffineRun<R>& frames, Box* box = nullptr)
    {
        computeRun<R, true>(n, x, g, lp, out, &frames, box);
    }
    template <int R, bool affine, class X>
    static EMP_ALWAYS_INLINE void computeRun(int n, X&& x, const Grid<D>& g, const HalfWidth& lp, Stencil* out,
                                             AffineRun<R>* frames, Box* box = nullptr)
    {
        // The weights and their derivatives, value m of lane i at wd[m][i] (m = (d, k) of w, then
        // of dw: the order of a Stencil's w and dw).
        constexpr int M = 2 * D * S;
        alignas(64) double xs[D][R], wd[M][R];
        double (*const ws)[S][R] = reinterpret_cast<double (*)[S][R]>(&wd[0][0]);
        double (*const dws)[S][R] = reinterpret_cast<double (*)[S][R]>(&wd[D * S][0]);
        alignas(64) double fb[affine ? D : 1][R], fr[affine ? D : 1][R];
        alignas(64) int bs[D][R];
        for (int i = 0; i < n; ++i) {
            const Vec<D>& xi = x(i);
            for (int d = 0; d < D; ++d) xs[d][i] = xi[d];
        }
        double origin[D];
        for (int d = 0; d < D; ++d) origin[d] = g.origin[d];
        const double invh = g.invh, h = g.h;
        forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
            for (int d = 0; d < D; ++d)
                bs[d][i] = K::template evalLane<R>((xs[d][i] - origin[d]) * invh, lp, &ws[d][0][i], &dws[d][0][i]);
            if constexpr (affine)
                for (int d = 0; d < D; ++d)
                    affineFrameAlong((xs[d][i] - origin[d]) * invh, bs[d][i], [&](int k) { return ws[d][k][i]; }, h,
                                     fb[d][i], fr[d][i]);
        });
        if constexpr (affine)
            for (int d = 0; d < D; ++d) {
                double* b = frames->b[d];
                for (int i = 0; i < n; ++i) b[i] = fb[d][i];
                for (int i = 0; i < n; ++i) frames->r[d][i] = fr[d][i];
                if (double* out = frames->rOut[d])
                    for (int i = 0; i < n; ++i) out[i] = fr[d][i];
            }
        for (int i = 0; i < n; ++i) {
            Stencil& st = out[i];
            int base[D];
            for (int d = 0; d < D; ++d) base[d] = bs[d][i];
            st.first = firstOf(g, base);
            st.remap = -1;
        }
        if (box) {  // (only while supports map onto twins: one vector loop over the run)
            int lo[D], hi[D];
            for (int d = 0; d < D; ++d) lo[d] = box->lo[d] - (S - 1), hi[d] = box->hi[d];
            // (in the lanes into a local array, whose R flags then give `any` and are copied in
            // vectors; with the flags stored through box->near and `any` summed in the lanes'
            // loop, GCC's code took about 15 instructions a point)
            alignas(64) int in[R] = {};
            forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
                int inside = 1;
                for (int d = 0; d < D; ++d) inside &= (bs[d][i] <= hi[d]) & (bs[d][i] >= lo[d]);
                in[i] = inside;
            });
            int any = 0;
            for (int i = 0; i < R; ++i) any |= in[i];
            if (any) std::memcpy(box->near, in, sizeof in);
            box->any = any;
        }
        withLaneIsa([&]() EMP_LAMBDA_INLINE { transposeInto<R, M>(n, wd, out); });
    }

    /// Copies value m of lane i, v[m][i], to the i-th stencil's w and dw (value m at offset m
    /// from w[0][0], the order of those two arrays): a transposition, four lanes by four values
    /// at a time through shuffles of 4-lane vectors (one by one, it took 24 scalar loads and
    /// stores per 2D point, 8 % of the 2D step: doc/performance.md, "Session 29").
    template <int R, int M> static EMP_ALWAYS_INLINE void transposeInto(int n, const double (*v)[R], Stencil* out)
    {
        static_assert(M == 2 * D * S, "w and dw");
        typedef double V4 __attribute__((vector_size(4 * sizeof(double))));
        const auto at = [&](int i) EMP_LAMBDA_INLINE { return reinterpret_cast<char*>(&out[i]) + offsetof(Stencil, w); };
        int i = 0;
        for (; i + 4 <= n; i += 4) {
            for (int m = 0; m + 4 <= M; m += 4) {
                // (Four named vectors, each loaded and stored once: as arrays with loops over
                // them, GCC copied each vector through the stack in 2-lane halves and read it
                // back whole, which waits until the halves' stores are done.)
                V4 a0, a1, a2, a3;
                __builtin_memcpy(&a0, &v[m][i], sizeof(V4));
                __builtin_memcpy(&a1, &v[m + 1][i], sizeof(V4));
                __builtin_memcpy(&a2, &v[m + 2][i], sizeof(V4));
                __builtin_memcpy(&a3, &v[m + 3][i], sizeof(V4));
                const V4 lo01 = __builtin_shufflevector(a0, a1, 0, 4, 2, 6), hi01 = __builtin_shufflevector(a0, a1, 1, 5, 3, 7);
                const V4 lo23 = __builtin_shufflevector(a2, a3, 0, 4, 2, 6), hi23 = __builtin_shufflevector(a2, a3, 1, 5, 3, 7);
                const V4 o0 = __builtin_shufflevector(lo01, lo23, 0, 1, 4, 5), o1 = __builtin_shufflevector(hi01, hi23, 0, 1, 4, 5);
                const V4 o2 = __builtin_shufflevector(lo01, lo23, 2, 3, 6, 7), o3 = __builtin_shufflevector(hi01, hi23, 2, 3, 6, 7);
                const std::size_t off = m * sizeof(double);
                __builtin_memcpy(at(i) + off, &o0, sizeof(V4));
                __builtin_memcpy(at(i + 1) + off, &o1, sizeof(V4));
                __builtin_memcpy(at(i + 2) + off, &o2, sizeof(V4));
                __builtin_memcpy(at(i + 3) + off, &o3, sizeof(V4));
            }
            for (int m = M / 4 * 4; m < M; ++m)
                for (int q = 0; q < 4; ++q) __builtin_memcpy(at(i + q) + m * sizeof(double), &v[m][i + q], sizeof(double));
        }
        for (; i < n; ++i)
            for (int m = 0; m < M; ++m) __builtin_memcpy(at(i) + m * sizeof(double), &v[m][i], sizeof(double));
    }

    /// Whether the support of the point at x (this stencil's point) can touch a marked node: it
    /// overlaps the box [lo, hi] of them.
    static EMP_ALWAYS_INLINE bool overlaps(const Vec<D>& x, const Grid<D>& g, const int* lo, const int* hi)
    {
        for (int d = 0; d < D; ++d) {
            const int base = baseAt(x, g, d);
            if (base > hi[d] || base + S - 1 < lo[d]) return false;
        }
        return true;
    }

    /// What mapAcrossCracks finds of a support alone (2D): whether no crack comes near its box,
    /// and which of its nodes are marked; for the points of one base node (`first`) after another.
    struct SupportMemo {
        int first = -1;
        bool clear = false;
        unsigned marked = 0;
    };
    /// Phantom-node rule: a marked node is replaced by its twin when the segment from the point
    /// to the node crosses the crack. Writes the S^D node indices into slot `slot` of Grid::remap
    /// when any node is marked. `memo` (2D; may be null): the findings of the support of the
    /// point mapped before, with the same cracks' marks (Solver::mapRun's run).
    void mapAcrossCracks(const Vec<D>& x, Grid<D>& g, const PhantomNodes<D>& ph, int slot, SupportMemo* memo = nullptr)
    {
        // The point lies in its support's box (the nodes base .. base + S - 1): when no crack
        // passes near that box, no segment from the point to a node can cross one. That and the
        // marked nodes depend on the support alone: with a memo, the previous point's findings
        // when it had the same base node (as the next point in a strip often has).
        const bool known = D == 2 && memo && memo->first == first;
        if (known && (memo->clear || !memo->marked)) return;
        // The base node's lattice coordinates from x, whose stencil this is (baseAt: the same
        // integers as baseOf, without its integer divisions), once for every marked node.
        int base[D];
        for (int d = 0; d < D; ++d) base[d] = baseAt(x, g, d);
        if constexpr (D == 2) {
            // The nodes' coordinates (nodePosition's numbers), by column and by row.
            double xs[S], ys[S];
            for (int i = 0; i < S; ++i) {
                xs[i] = g.origin[0] + (base[0] + i) * g.h;
                ys[i] = g.origin[1] + (base[1] + i) * g.h;
            }
            int node[NS];
            for (int k = 0; k < NS; ++k) node[k] = regularNode(g, k);
            SupportMemo m;
            if (known) {
                m = *memo;
            } else {
                m.first = first;
                m.clear = ph.clearOf(Vec<2>(xs[0], ys[0]), Vec<2>(xs[S - 1], ys[S - 1]), 1e-6 * g.h);
                if (!m.clear)
                    for (int k = 0; k < NS; ++k)
                        if (ph.marked(node[k])) m.marked |= 1u << k;
                if (memo) *memo = m;
                if (m.clear) return;
            }
            // (PhantomNodes::mapSupport: map() for each marked node, the whole support at once.)
            if (!m.marked || !ph.template mapSupport<S>(x, xs, ys, m.marked, node)) return;
            remap = slot * NS;
            std::copy(node, node + NS, &g.remap[remap]);
        } else {
            mapMarked<true>(g, ph, slot, [&](int I, int k) { return ph.map(x, I, nodePosition(g, base, k)); });
        }
    }

    /// Bodies in one grid (PhantomNodes::updateBodies): a point of `body` uses that body's twin of
    /// each marked node.
    void mapBodies(int body, Grid<D>& g, const PhantomNodes<D>& ph, int slot)
    {
        mapMarked<false>(g, ph, slot, [&](int I, int) { return ph.mapBody(body, I); });
    }

    /// Replaces each marked support node I (support node k) by f(I, k), writing the S^D node
    /// indices into slot `slot` of Grid::remap, when any node is marked. With `changedOnly`, only
    /// when f replaced one: a support whose marked nodes all stay themselves (a point near a
    /// crack whose segments to them cross none) keeps the regular lattice and its sums by rows,
    /// the same numbers. (Bodies in one grid need the slot written: it tells which points reach
    /// a shared node.)
    template <bool changedOnly, class F> void mapMarked(Grid<D>& g, const PhantomNodes<D>& ph, int slot, F&& f)
    {
        int node[NS];
        bool any = false;
        for (int k = 0; k < NS; ++k) {
            node[k] = regularNode(g, k);
            any = any || ph.marked(node[k]);
        }
        if (!any) return;
        bool changed = false;
        for (int k = 0; k < NS; ++k)
            if (ph.marked(node[k])) {
                const int I = f(node[k], k);
                changed = changed || I != node[k];
                node[k] = I;
            }
        if (changedOnly && !changed) return;
        remap = slot * NS;
        std::copy(node, node + NS, &g.remap[remap]);
    }

    /// Index of support node k (x fastest) on the regular lattice.
    int regularNode(const Grid<D>& g, int k) const
    {
        int I = first + k % S + (k / S) % S * g.stride[1];
        if constexpr (D == 3) I += k / (S * S) * g.stride[2];
        return I;
    }

    /// Position of support node k: Grid::nodePosition(regularNode(g, k)) from the base node's
    /// lattice coordinates (baseOf), without Grid's integer divisions (the same numbers).
    Vec<D> nodePosition(const Grid<D>& g, const int* base, int k) const
    {
        Vec<D> x;
        for (int d = 0, r = k; d < D; ++d, r /= S) x[d] = g.origin[d] + (base[d] + r % S) * g.h;
        return x;
    }

    /// Offsets x_I - x_p (m) of the support nodes from the point at x, per direction: o[d][k]
    /// for the node base + k along d (a twin sits where its node is).
    void offsets(const Vec<D>& x, const Grid<D>& g, double (*o)[S]) const
    {
        for (int d = 0; d < D; ++d) {
            const int base = baseOf(g, d);
            for (int k = 0; k < S; ++k) o[d][k] = g.origin[d] + (base + k) * g.h - x[d];
        }
    }

    /// APIC's frame of a point along one direction, from its position xi in cells, its base node
    /// and its weights w(k): b = base - xi, the offset in cells of its first support node (node k
    /// at b + k, as cellOffsets), and r = 1 / (h du), du = sum_k w_k (b + k)^2 the moment
    /// diagonal in cells (momentDiagonal), or r = 0 where du is not positive. The same operations
    /// per point (affineFrame) and in computeRun's lanes, where the divisions go 4 or 8 at a time.
    template <class W>
    static EMP_ALWAYS_INLINE void affineFrameAlong(double xi, int base, W&& w, double h, double& b, double& r)
    {
        b = base - xi;
        double du = 0;
        for (int k = 0; k < S; ++k) du += w(k) * (b + k) * (b + k);
        // (The division for every lane, then the choice: a division under a condition would not
        // vectorise; where du > 0 it is the same division.)
        const double q = 1.0 / (h * (du > 0 ? du : 1.0));
        r = du > 0 ? q : 0.0;
    }
    /// This stencil's APIC frame (affineFrameAlong in each direction) for the point at x, the
    /// position the stencil was computed at.
    EMP_ALWAYS_INLINE AffineFrame affineFrame(const Vec<D>& x, const Grid<D>& g) const
    {
        AffineFrame f;
        for (int d = 0; d < D; ++d) {
            const double xi = (x[d] - g.origin[d]) * g.invh;
            affineFrameAlong(xi, K::base(xi), [&](int k) { return w[d][k]; }, g.h, f.b[d], f.r[d]);
        }
        return f;
    }

    /// The same offsets in cells, u[d][k] = (x_I - x_p) / h (APIC's transfers: with these, the
    /// moment matrix is h^2 diag(momentDiagonal(u)) and h cancels from C_p (x_I - x_p)). Two
    /// operations per direction and one per node, against four per node for `offsets`.
    /// x must be the position the stencil was computed at (its base is found again from it).
    /// The passes take these numbers from P2G's frame (AffineFrame::b, kept for G2P in
    /// Solver::offset_); this is their plain form, against which the tests check the frame's.
    EMP_ALWAYS_INLINE void cellOffsets(const Vec<D>& x, const Grid<D>& g, double (*u)[S]) const
    {
        for (int d = 0; d < D; ++d) {
            const double xi = (x[d] - g.origin[d]) * g.invh;
            const double b = K::base(xi) - xi;
            for (int k = 0; k < S; ++k) u[d][k] = b + k;
        }
    }

    /// The diagonal of the moment matrix D_p = sum_I N_Ip (x_I - x_p)(x_I - x_p)^T (APIC), from
    /// the offsets (in metres, or in cells from cellOffsets: then D_p / h^2): a tensor-product
    /// kernel that reproduces linear fields has no off-diagonal terms (the first moments vanish
    /// in every direction).
    Vec<D> momentDiagonal(const double (*o)[S]) const
    {
        Vec<D> m;
        for (int d = 0; d < D; ++d) {
            m[d] = 0;
            for (int k = 0; k < S; ++k) m[d] += w[d][k] * o[d][k] * o[d][k];
        }
        return m;
    }

    /// forEach with the offset x_I - x_p as a fourth argument: f(I, N, grad N, dx) (the plain form
    /// of forEachAffine and affineSums, kept as their reference in the tests).
    template <class F> EMP_ALWAYS_INLINE void forEachWithOffset(const Grid<D>& g, const double (*o)[S], F&& f) const
    {
        int c = 0;  // support node number, in forEach's order (x fastest)
        forEach(g, [&](int I, double N, const Vec<D>& grad) {
            Vec<D> dx;
            dx[0] = o[0][c % S];
            dx[1] = o[1][(c / S) % S];
            if constexpr (D == 3) dx[2] = o[2][c / (S * S)];
            f(I, N, grad, dx);
            ++c;
        });
    }

    /// Calls f(node index, N, a + M (x_I - x_p)) for every support node in forEach's order (APIC's
    /// P2G: a = m v, M = m C). The affine field is built direction by direction, one vector sum
    /// per node instead of a matrix-vector product (forEachWithOffset is the plain form).
    template <class F>
    EMP_ALWAYS_INLINE void forEachAffine(const Grid<D>& g, const double (*o)[S], const Vec<D>& a, const Mat<D>& M,
                                         F&& f) const
    {
        int node[NS];
        nodes(g, node);
        Vec<D> x[S];
        for (int i = 0; i < S; ++i) x[i] = o[0][i] * M.col(0);
        if constexpr (D == 2) {
            for (int j = 0; j < S; ++j) {
                const Vec<2> r = a + o[1][j] * M.col(1);
                for (int i = 0; i < S; ++i) f(node[i + S * j], w[0][i] * w[1][j], Vec<2>(r + x[i]));
            }
        } else {
            for (int k = 0; k < S; ++k) {
                const Vec<3> q = a + o[2][k] * M.col(2);
                for (int j = 0; j < S; ++j) {
                    const double wjk = w[1][j] * w[2][k];
                    const Vec<3> r = q + o[1][j] * M.col(1);
                    for (int i = 0; i < S; ++i) f(node[i + S * (j + S * k)], w[0][i] * wjk, Vec<3>(r + x[i]));
                }
            }
        }
    }

    /// sum = sum_I N_I v(I) and B = sum_I N_I v(I) (x_I - x_p)^T for the nodal values v(I) (APIC's
    /// G2P). The offsets are applied to the sums over each row and plane of the support and over
    /// each node column, not node by node: three additions per node instead of a rank-one update.
    template <class V>
    EMP_ALWAYS_INLINE void affineSums(const Grid<D>& g, const double (*o)[S], V&& v, Vec<D>& sum, Mat<D>& B) const
    {
        withNodeOf(g, [&](auto nodeOf) EMP_LAMBDA_INLINE {
            Vec<D> column[S];  // sums over the nodes first + i of every row
            for (int i = 0; i < S; ++i) column[i].setZero();
            sum.setZero();
            B.setZero();
            if constexpr (D == 2) {
                for (int j = 0; j < S; ++j) {
                    Vec<2> row = Vec<2>::Zero();
                    for (int i = 0; i < S; ++i) {
                        const Vec<2> nv = (w[0][i] * w[1][j]) * v(nodeOf(i, j, 0));
                        row += nv;
                        column[i] += nv;
                    }
                    sum += row;
                    B.col(1) += o[1][j] * row;
                }
            } else if constexpr (std::is_lvalue_reference_v<decltype(v(0))>) {
                // The same sums in 4-lane vectors (Lane3), from the nodal arrays.
                Lane3 col[S], s3 = Lane3::zero(), b0 = Lane3::zero(), b1 = Lane3::zero(), b2 = Lane3::zero();
                for (int i = 0; i < S; ++i) col[i] = Lane3::zero();
                for (int k = 0; k < S; ++k) {
                    Lane3 plane = Lane3::zero();
                    for (int j = 0; j < S; ++j) {
                        const double wjk = w[1][j] * w[2][k];
                        Lane3 row = Lane3::zero();
                        for (int i = 0; i < S; ++i) {
                            const Lane3 nv = (w[0][i] * wjk) * Lane3::load(v(nodeOf(i, j, k)));
                            row += nv;
                            col[i] += nv;
                        }
                        plane += row;
                        b1 += o[1][j] * row;
                    }
                    s3 += plane;
                    b2 += o[2][k] * plane;
                }
                for (int i = 0; i < S; ++i) b0 += o[0][i] * col[i];
                sum = s3.vec();
                B.col(0) = b0.vec();
                B.col(1) = b1.vec();
                B.col(2) = b2.vec();
                return;
            } else {
                for (int k = 0; k < S; ++k) {
                    Vec<3> plane = Vec<3>::Zero();
                    for (int j = 0; j < S; ++j) {
                        const double wjk = w[1][j] * w[2][k];
                        Vec<3> row = Vec<3>::Zero();
                        for (int i = 0; i < S; ++i) {
                            const Vec<3> nv = (w[0][i] * wjk) * v(nodeOf(i, j, k));
                            row += nv;
                            column[i] += nv;
                        }
                        plane += row;
                        B.col(1) += o[1][j] * row;
                    }
                    sum += plane;
                    B.col(2) += o[2][k] * plane;
                }
            }
            for (int i = 0; i < S; ++i) B.col(0) += o[0][i] * column[i];
        });
    }

    /// The node indices of the support, in forEach's order (x fastest): from the base node, or
    /// near a pre-existing crack from the remap table (phantom twins).
    EMP_ALWAYS_INLINE void nodes(const Grid<D>& g, int* node) const
    {
        if (remap >= 0) {
            for (int k = 0; k < NS; ++k) node[k] = g.remap[remap + k];
            return;
        }
        // regularNode for every k, from the first node and the strides read once: with g's
        // strides and the base read in the sum for each node, GCC reloaded them after every
        // store to node[] (it may alias them), about 6 instructions a node in 3D.
        const int s1 = g.stride[1], s2 = D == 3 ? g.stride[D - 1] : 0;
        const int first = this->first;
        for (int k = 0; k < NS; ++k) node[k] = first + k % S + (k / S) % S * s1 + k / (S * S) * s2;
    }

    /// f(nodeOf) with nodeOf(i, j, k) the index of support node (i, j, k) (k = 0 in 2D): on the
    /// regular lattice computed from the first node (a row's nodes are then one address and
    /// constant offsets, no table to write and read back), near a pre-existing crack read from
    /// the remap table (nodes). The same indices either way, so the same sums.
    template <class F> EMP_ALWAYS_INLINE decltype(auto) withNodeOf(const Grid<D>& g, F&& f) const
    {
        if (remap < 0) return f([&](int i, int j, int k) EMP_LAMBDA_INLINE { return rowStart(g, j, k) + i; });
        int node[NS];
        nodes(g, node);
        return f([&](int i, int j, int k) EMP_LAMBDA_INLINE { return node[i + S * (j + S * k)]; });
    }

    /// sum_I v(I) grad N_I^T for the nodal values v(I) (Eq 27's velocity gradient). grad N is a
    /// tensor product of the 1D weights and derivatives, so the sums run direction by direction:
    /// the inner sums over x serve two (2D) or three (3D) columns.
    template <class V> EMP_ALWAYS_INLINE Mat<D> gradientOf(const Grid<D>& g, V&& v) const
    {
        return withNodeOf(g, [&](auto nodeOf) EMP_LAMBDA_INLINE {
            Mat<D> L;
            if constexpr (D == 2 && std::is_lvalue_reference_v<decltype(v(0))>) {
                Lane3::V c;  // (c0 in lanes 0-1, c1 in 2-3)
                gradientSums2(nodeOf, v, c);
                L.col(0) = g.invh * Vec<2>(c[0], c[1]);
                L.col(1) = g.invh * Vec<2>(c[2], c[3]);
            } else if constexpr (D == 2) {
                Vec<2> a, b;  // the sums over x of one row of the support (rowSums)
                Vec<2> c0 = Vec<2>::Zero(), c1 = Vec<2>::Zero();
                for (int j = 0; j < S; ++j) {
                    rowSums([&](int i) EMP_LAMBDA_INLINE { return nodeOf(i, j, 0); }, v, a, b);
                    c0 += w[1][j] * a;
                    c1 += dw[1][j] * b;
                }
                L.col(0) = g.invh * c0;
                L.col(1) = g.invh * c1;
            } else {
                // In 4-lane vectors (Lane3) when v gives elements of the nodal arrays, in Eigen's
                // 3-vectors otherwise: the same operations on each component.
                const auto sums = [&](auto zero, auto load, auto vec) EMP_LAMBDA_INLINE {
                    auto c0 = zero, c1 = zero, c2 = zero;
                    gradientSums3(nodeOf, load, zero, c0, c1, c2);
                    L.col(0) = g.invh * vec(c0);
                    L.col(1) = g.invh * vec(c1);
                    L.col(2) = g.invh * vec(c2);
                };
                if constexpr (std::is_lvalue_reference_v<decltype(v(0))>)
                    sums(Lane3::zero(), [&](int I) EMP_LAMBDA_INLINE { return Lane3::load(v(I)); },
                         [](const Lane3& x) EMP_LAMBDA_INLINE { return x.vec(); });
                else
                    sums(Vec<3>(Vec<3>::Zero()), [&](int I) EMP_LAMBDA_INLINE { return Vec<3>(v(I)); },
                         [](const Vec<3>& x) EMP_LAMBDA_INLINE { return x; });
            }
            return L;
        });
    }

    /// 2D, v giving elements of the nodal arrays: the unscaled columns of gradientOf's L (L =
    /// c / h), c0 in lanes 0-1 and c1 in lanes 2-3 of one 4-lane vector (one AVX register inside
    /// withLaneIsa): lanes 0-1 carry a = sum dw_x,i v_i and then c0 = sum w_y,j a_j, lanes 2-3 b =
    /// sum w_x,i v_i and then c1 = sum dw_y,j b_j, each lane the same operations in the same order
    /// as the sums by rows (rowSums), so the same values. Each node's velocity is read once into
    /// both halves. nodeOf as withNodeOf gives it. (The vector is an out parameter: returned,
    /// it would change the ABI of the baseline's copy, -Wpsabi.)
    template <class N, class V> EMP_ALWAYS_INLINE void gradientSums2(N&& nodeOf, V&& v, Lane3::V& c) const
    {
        static_assert(D == 2, "2D");
        typedef Lane3::V V4;
        // (x, x, y, y) as a blend of two broadcasts (from pairs of 2-lane halves, GCC added a
        // register copy to each half; a macro: a function returning the vector would change
        // the baseline copy's ABI, -Wpsabi)
#define EMP_PAIR(x, y) __builtin_shufflevector(V4{x, x, x, x}, V4{y, y, y, y}, 0, 1, 6, 7)
        V4 q[S];
        for (int i = 0; i < S; ++i) q[i] = EMP_PAIR(dw[0][i], w[0][i]);
        c = V4{0.0, 0.0, 0.0, 0.0};
        for (int j = 0; j < S; ++j) {
            V4 ab{0.0, 0.0, 0.0, 0.0};
            for (int i = 0; i < S; ++i) {
                // (element by element, GCC reads the nodes straight into the shuffles, two
                // neighbours from one 4-lane load; from a 2-lane load and a shuffle it emitted
                // both: 2.9 instructions a particle-step more)
                const double* vi = v(nodeOf(i, j, 0)).data();
                ab += q[i] * V4{vi[0], vi[1], vi[0], vi[1]};
            }
            c += EMP_PAIR(w[1][j], dw[1][j]) * ab;
        }
#undef EMP_PAIR
    }

    /// 3D: the unscaled columns of gradientOf's L (L = (c0 c1 c2) / h) from the nodal values
    /// load(I) (Lane3 or Eigen 3-vectors, starting from zero), the sums direction by direction:
    /// the inner sums over x serve two columns.
    template <class N, class Load, class T>
    EMP_ALWAYS_INLINE void gradientSums3(N&& nodeOf, Load&& load, const T& zero, T& c0, T& c1, T& c2) const
    {
        c0 = zero, c1 = zero, c2 = zero;
        for (int k = 0; k < S; ++k) {
            T A = zero, B = zero, C = zero;
            for (int j = 0; j < S; ++j) {
                T a = zero, b = zero;  // the sums over x of one row
                for (int i = 0; i < S; ++i) {
                    const T vi = load(nodeOf(i, j, k));
                    a += dw[0][i] * vi;
                    b += w[0][i] * vi;
                }
                A += w[1][j] * a;
                B += dw[1][j] * b;
                C += w[1][j] * b;
            }
            c0 += w[2][k] * A;
            c1 += w[2][k] * B;
            c2 += dw[2][k] * C;
        }
    }

    /// 3D: gradientSums3 of the nodal velocities v (Grid's array) on this support, in Lane3.
    template <class V> EMP_ALWAYS_INLINE void velocitySums3(const Grid<D>& g, V&& v, Lane3& c0, Lane3& c1, Lane3& c2) const
    {
        withNodeOf(g, [&](auto nodeOf) EMP_LAMBDA_INLINE {
            gradientSums3(nodeOf, [&](int I) EMP_LAMBDA_INLINE { return Lane3::load(v(I)); }, Lane3::zero(), c0, c1, c2);
        });
    }

    /// 2D: gradientSums2 of the nodal velocities v (Grid's array) on this support.
    template <class V> EMP_ALWAYS_INLINE void velocitySums2(const Grid<D>& g, V&& v, Lane3::V& c) const
    {
        withNodeOf(g, [&](auto nodeOf) EMP_LAMBDA_INLINE { gradientSums2(nodeOf, v, c); });
    }

    /// a = sum_i dw_x,i v(row(i)) and b = sum_i w_x,i v(row(i)) over the S nodes row(0) ...
    /// row(S - 1) of one row (gradientOf).
    template <class R, class V> EMP_ALWAYS_INLINE void rowSums(R&& row, V&& v, Vec<D>& a, Vec<D>& b) const
    {
        a.setZero();
        b.setZero();
        for (int i = 0; i < S; ++i) {
            const Vec<D> vi = v(row(i));
            a += dw[0][i] * vi;
            b += w[0][i] * vi;
        }
    }

    /// Calls f(node index, N, M grad N) for every support node in forEach's order, for a matrix M
    /// (the stress pass's V sigma): the products factored by direction, about half the
    /// multiplications of forming grad N and then M grad N.
    template <class F> EMP_ALWAYS_INLINE void forEachProjected(const Grid<D>& g, const Mat<D>& M, F&& f) const
    {
        forEachProjected(g, M, dw, std::forward<F>(f));
    }
    /// The same with dv in place of the derivatives dw: f(I, N, M g_I) with g_I's component d
    /// dv[d][i_d] / h times the other directions' weights.
    template <class F>
    EMP_ALWAYS_INLINE void forEachProjected(const Grid<D>& g, const Mat<D>& M, const double (*dv)[S], F&& f) const
    {
        int node[NS];
        nodes(g, node);
        Vec<D> a[S], b[S];
        for (int i = 0; i < S; ++i) {
            a[i] = (dv[0][i] * g.invh) * M.col(0);
            b[i] = (w[0][i] * g.invh) * M.col(1);
        }
        if constexpr (D == 2) {
            for (int j = 0; j < S; ++j)
                for (int i = 0; i < S; ++i) f(node[i + S * j], w[0][i] * w[1][j], Vec<2>(w[1][j] * a[i] + dv[1][j] * b[i]));
        } else {
            Vec<3> c[S];
            for (int i = 0; i < S; ++i) c[i] = (w[0][i] * g.invh) * M.col(2);
            for (int k = 0; k < S; ++k)
                for (int j = 0; j < S; ++j) {
                    const double p = w[1][j] * w[2][k], q = dv[1][j] * w[2][k], r = w[1][j] * dv[2][k];
                    for (int i = 0; i < S; ++i)
                        f(node[i + S * (j + S * k)], w[0][i] * p, Vec<3>(p * a[i] + q * b[i] + r * c[i]));
                }
        }
    }

    // ---- By rows: the same values, for a support on the regular lattice ---------------------
    // A row is the S nodes base[0] ... base[0] + S - 1 along x of one (j) or (j, k): without
    // phantom twins they lie next to each other in the nodal arrays, S * D numbers of a vector
    // field in a row. The row forms below give a caller the row's weights N[i] and values
    // t[i * D + d] (node-major), computed with the operations of their node-by-node form and in
    // its order of rows, so that a caller's update of each node is bitwise that of the node form.
    // Written as flat loops over the row's numbers, which the compiler vectorises across nodes
    // (the node form works on one node's D components; in 3D, Eigen's 3-vectors are scalar).

    /// Whether the support lies on the regular lattice (no phantom twin): the row forms apply.
    bool regular() const { return remap < 0; }

    /// The first node of row j (2D) or (j, k) (3D) of a regular support.
    EMP_ALWAYS_INLINE int rowStart(const Grid<D>& g, int j, int k = 0) const
    {
        int I = first + j * g.stride[1];
        if constexpr (D == 3) I += k * g.stride[2];
        return I;
    }

    /// 3D: a support's row starts and its y and z weights as plain values, for the scatters that
    /// store through __builtin_memcpy (which may alias anything, so that GCC reloaded the grid's
    /// strides, the first node and the weights from memory after every row's stores). The same
    /// numbers as rowStart and w.
    struct Rows {
        int first, s1, s2;
        double y[S], z[S];
        EMP_ALWAYS_INLINE int start(int j, int k) const { return first + j * s1 + k * s2; }
    };
    EMP_ALWAYS_INLINE Rows rowsOf(const Grid<D>& g) const
    {
        static_assert(D == 3, "3D rows");
        Rows r{first, g.stride[1], g.stride[2], {}, {}};
        for (int i = 0; i < S; ++i) r.y[i] = w[1][i], r.z[i] = w[2][i];
        return r;
    }

    /// forEach by rows (its weights N): row(first node, N).
    template <class Row> EMP_ALWAYS_INLINE void forEachRow(const Grid<D>& g, Row&& row) const
    {
        double N[S];
        if constexpr (D == 2) {
            for (int j = 0; j < S; ++j) {
                for (int i = 0; i < S; ++i) N[i] = w[0][i] * w[1][j];
                row(rowStart(g, j), N);
            }
        } else {
            for (int k = 0; k < S; ++k)
                for (int j = 0; j < S; ++j) {
                    const double wjk = w[1][j] * w[2][k];
                    for (int i = 0; i < S; ++i) N[i] = w[0][i] * wjk;
                    row(rowStart(g, j, k), N);
                }
        }
    }

    typedef double V2 __attribute__((vector_size(2 * sizeof(double))));
    typedef double V4 __attribute__((vector_size(4 * sizeof(double))));
    /// 2D, S = 3: row j's products N_I f_I (N_I = w_x,i w_y,j; forEachRow's weights) of a nodal
    /// 2-vector field whose row starts at r (six numbers): nodes 0 and 1 in p01, node 2 in p2
    /// (columnSums2, affineColumnSums2).
    EMP_ALWAYS_INLINE void rowProducts2(int j, const double* r, V4& p01, V2& p2) const
    {
        const V4 x01{w[0][0], w[0][0], w[0][1], w[0][1]};
        const V2 x2{w[0][2], w[0][2]};
        const double y = w[1][j];
        V4 f01;
        V2 f2;
        __builtin_memcpy(&f01, r, sizeof(V4));
        __builtin_memcpy(&f2, r + 4, sizeof(V2));
        p01 = (x01 * V4{y, y, y, y}) * f01;  // (N of nodes 0 and 1, each twice)
        p2 = (x2 * V2{y, y}) * f2;
    }

    /// 2D, S = 3: G2P's sums a = sum N_I f_I and b = sum N_I u_I over a regular support, for two
    /// nodal 2-vector fields f and u (arrays of D numbers per node), with forEachRow's weights
    /// N_I = w_x,i w_y,j. Summed by columns: node i of every row goes to column sum i (nodes 0 and 1
    /// of a row side by side in one 4-lane vector, node 2 in a 2-lane one; a row's three nodes are
    /// six numbers in a row of the arrays), each column's sum starting from its first row's
    /// product, then a = (column 0 + column 1) + column 2. Not the node-by-node order of
    /// forEachRow: the same products, other sums (round-off), the same bits in every lane width.
    /// (G2P's 2D loop: 14 instructions a particle-step fewer than its sums by rows.)
    template <class F> EMP_ALWAYS_INLINE void columnSums2(const Grid<D>& g, const F* f, const F* u, Vec<D>& a, Vec<D>& b) const
    {
        static_assert(D == 2 && S == 3, "2D, three nodes a row");
        V4 a01, b01;
        V2 a2, b2;
        for (int j = 0; j < S; ++j) {
            const int I0 = rowStart(g, j);
            V4 f01, u01;
            V2 f2, u2;
            rowProducts2(j, f[I0].data(), f01, f2);
            rowProducts2(j, u[I0].data(), u01, u2);
            if (j == 0) {  // (the first row's products start the sums)
                a01 = f01, a2 = f2, b01 = u01, b2 = u2;
            } else {
                a01 += f01, a2 += f2, b01 += u01, b2 += u2;
            }
        }
        const V2 ra = (V2{a01[0], a01[1]} + V2{a01[2], a01[3]}) + a2;
        const V2 rb = (V2{b01[0], b01[1]} + V2{b01[2], b01[3]}) + b2;
        __builtin_memcpy(a.data(), &ra, sizeof(V2));
        __builtin_memcpy(b.data(), &rb, sizeof(V2));
    }

    /// 2D, S = 3: APIC's G2P sums (affineSums) over a regular support by columns, as columnSums2:
    /// sum = sum N_I v_I and B = sum N_I v_I (x_I - x_p)^T for the nodal 2-vectors v, with the
    /// offsets in cells b0, b1 of the first support node (cellOffsets: node (i, j) at (b0 + i, b1 + j)).
    /// With p_ij = N_ij v_ij, column i's sums over the rows are c_i = (p_i0 + p_i1) + p_i2 and
    /// t_i = (p_i1 + p_i2) + p_i2 (= sum_j j p_ij); then sum = (c_0 + c_1) + c_2, B's column 0 =
    /// b0 sum + (c_1 + (c_2 + c_2)) and column 1 = b1 sum + ((t_0 + t_1) + t_2): the offsets
    /// applied to the sums, not to each node. Not affineSums' order (round-off), the same bits in
    /// every lane width. (APIC's G2P loop: about 40 instructions a particle-step fewer than
    /// affineSums.)
    template <class F>
    EMP_ALWAYS_INLINE void affineColumnSums2(const Grid<D>& g, double b0, double b1, const F* v, Vec<D>& sum, Mat<D>& B) const
    {
        static_assert(D == 2 && S == 3, "2D, three nodes a row");
        V4 p01[S];
        V2 p2[S];
        for (int j = 0; j < S; ++j) rowProducts2(j, v[rowStart(g, j)].data(), p01[j], p2[j]);
        const V4 c01 = (p01[0] + p01[1]) + p01[2], t01 = (p01[1] + p01[2]) + p01[2];
        const V2 c2 = (p2[0] + p2[1]) + p2[2], t2 = (p2[1] + p2[2]) + p2[2];
        const V2 c0{c01[0], c01[1]}, c1{c01[2], c01[3]};
        const V2 rs = (c0 + c1) + c2;
        const V2 r0 = V2{b0, b0} * rs + (c1 + (c2 + c2));
        const V2 r1 = V2{b1, b1} * rs + ((V2{t01[0], t01[1]} + V2{t01[2], t01[3]}) + t2);
        __builtin_memcpy(sum.data(), &rs, sizeof(V2));
        __builtin_memcpy(B.col(0).data(), &r0, sizeof(V2));
        __builtin_memcpy(B.col(1).data(), &r1, sizeof(V2));
    }

    /// 3D, S = 3: APIC's G2P sums (affineSums) over a regular support, the offsets applied to the
    /// sums as in affineColumnSums2: with p_ijk = N_ijk v_ijk (4-lane vectors, Lane3), each row's
    /// r = (p_0 + p_1) + p_2 and q = (p_1 + p_2) + p_2 (= sum_i i p_i); each plane's P = (r_0 +
    /// r_1) + r_2, T = (r_1 + r_2) + r_2 and Q = (q_0 + q_1) + q_2; then sum = (P_0 + P_1) + P_2,
    /// B's column 0 = b0 sum + ((Q_0 + Q_1) + Q_2), column 1 = b1 sum + ((T_0 + T_1) + T_2) and
    /// column 2 = b2 sum + ((P_1 + P_2) + P_2), for the offsets in cells b0, b1, b2 of the first
    /// support node. N_ijk = w_x,i (w_y,j w_z,k), as forEachRow's. Not affineSums' order
    /// (round-off), the same bits in every lane width. (It keeps each product only within its row:
    /// affineSums' column sums had GCC keep all 27 on the stack.)
    template <class F>
    EMP_ALWAYS_INLINE void affineRowSums3(const Grid<D>& g, double b0, double b1, double b2, const F* v, Vec<D>& sum,
                                          Mat<D>& B) const
    {
        static_assert(D == 3 && S == 3, "3D, three nodes a row");
        typedef Lane3::V V4;
        V4 wx[S], P[S], T[S], Q[S];
        for (int i = 0; i < S; ++i) wx[i] = V4{w[0][i], w[0][i], w[0][i], w[0][i]};
        for (int k = 0; k < S; ++k) {
            V4 r[S], q[S];
            for (int j = 0; j < S; ++j) {
                const F* row = v + rowStart(g, j, k);
                const double f = w[1][j] * w[2][k];
                const V4 fv{f, f, f, f};
                V4 p[S];
                for (int i = 0; i < S; ++i) p[i] = (wx[i] * fv) * Lane3::load(row[i]).v;
                r[j] = (p[0] + p[1]) + p[2];
                q[j] = (p[1] + p[2]) + p[2];
            }
            P[k] = (r[0] + r[1]) + r[2];
            T[k] = (r[1] + r[2]) + r[2];
            Q[k] = (q[0] + q[1]) + q[2];
        }
        const V4 s = (P[0] + P[1]) + P[2];
        const V4 c0 = V4{b0, b0, b0, b0} * s + ((Q[0] + Q[1]) + Q[2]);
        const V4 c1 = V4{b1, b1, b1, b1} * s + ((T[0] + T[1]) + T[2]);
        const V4 c2 = V4{b2, b2, b2, b2} * s + ((P[1] + P[2]) + P[2]);
        sum = Lane3{s}.vec();
        B.col(0) = Lane3{c0}.vec();
        B.col(1) = Lane3{c1}.vec();
        B.col(2) = Lane3{c2}.vec();
    }

    /// 3D: P2G's sums into a field of 4 numbers per node (Grid::massMomentum): node I of the
    /// support gets N_I a[c] added to its number c, with N_I forEachRow's weight (the same
    /// products, in the same order: w[0][i] times the row's weight, then times a[c]). at(I)
    /// gives node I's numbers: one 4-lane vector per node, one addition.
    template <class At> EMP_ALWAYS_INLINE void scatterRowsOf(const Grid<D>& g, const double* a, At&& at) const
    {
        static_assert(D == 3 && Grid<D>::sumsWidth == 4, "3D: one 4-lane vector per node");
        typedef double V2 __attribute__((vector_size(2 * sizeof(double))));
        typedef double V4 __attribute__((vector_size(4 * sizeof(double))));
        const V2 lo{a[0], a[1]}, hi{a[2], a[3]};
        const V4 av = __builtin_shufflevector(lo, hi, 0, 1, 2, 3);
        V4 wx[S];
        for (int i = 0; i < S; ++i) wx[i] = V4{w[0][i], w[0][i], w[0][i], w[0][i]};
        const Rows rows = rowsOf(g);  // (locals: the stores below may alias the stencil's members)
        for (int k = 0; k < S; ++k)
            for (int j = 0; j < S; ++j) {
                double* r = at(rows.start(j, k));
                const double f = rows.y[j] * rows.z[k];
                for (int i = 0; i < S; ++i) {
                    V4 x;
                    __builtin_memcpy(&x, r + 4 * i, sizeof(V4));
                    x += (wx[i] * f) * av;
                    __builtin_memcpy(r + 4 * i, &x, sizeof(V4));
                }
            }
    }

    /// forEachProjected by rows: row(first node, N, t) with t the row's M grad N.
    template <class Row> EMP_ALWAYS_INLINE void forEachRowProjected(const Grid<D>& g, const Mat<D>& M, Row&& row) const
    {
        forEachRowProjected(g, M, dw, std::forward<Row>(row));
    }
    /// The same with dv in place of the derivatives dw (as forEachProjected's).
    template <class Row>
    EMP_ALWAYS_INLINE void forEachRowProjected(const Grid<D>& g, const Mat<D>& M, const double (*dv)[S], Row&& row) const
    {
        constexpr int E = S * D;
        double a[E], b[E], c[D == 3 ? E : 1], N[S], t[E];
        for (int i = 0; i < S; ++i) {
            const double da = dv[0][i] * g.invh, wb = w[0][i] * g.invh;
            for (int d = 0; d < D; ++d) {
                a[i * D + d] = da * M(d, 0);
                b[i * D + d] = wb * M(d, 1);
                if constexpr (D == 3) c[i * D + d] = wb * M(d, 2);
            }
        }
        if constexpr (D == 2) {
#pragma GCC unroll 4
            for (int j = 0; j < S; ++j) {
                const double p = w[1][j], q = dv[1][j];
                for (int i = 0; i < S; ++i) N[i] = w[0][i] * p;
                for (int e = 0; e < E; ++e) t[e] = p * a[e] + q * b[e];
                row(rowStart(g, j), N, t);
            }
        } else {
#pragma GCC unroll 4
            for (int k = 0; k < S; ++k)
#pragma GCC unroll 4
                for (int j = 0; j < S; ++j) {
                    const double p = w[1][j] * w[2][k], q = dv[1][j] * w[2][k], r = w[1][j] * dv[2][k];
                    for (int i = 0; i < S; ++i) N[i] = w[0][i] * p;
                    for (int e = 0; e < E; ++e) t[e] = p * a[e] + q * b[e] + r * c[e];
                    row(rowStart(g, j, k), N, t);
                }
        }
    }

    /// forEachAffine by rows, with M = m C: row(first node, N, Nt) with Nt the row's
    /// N_I (a + M (x_I - x_p)), node by node (S x D numbers: the same operations as
    /// forEachAffine's, in the same order). (M is formed here, column by column: as an Eigen
    /// temporary it went through the stack, and reading it back waited on the stores.) 3D:
    /// APIC's momentum goes through scatterRowsAffineOf; this form scatters the force of APIC
    /// with the co-rotational update (Solver::particleToGrid).
    template <class Row>
    EMP_ALWAYS_INLINE void forEachRowAffine(const Grid<D>& g, const double (*o)[S], const Vec<D>& a, double m,
                                            const Mat<D>& C, Row&& row) const
    {
        constexpr int E = S * D;
        double N[S];
        alignas(32) double Nt[E];
        const Mat<D> M = m * C;
        double x[E];
        for (int i = 0; i < S; ++i)
            for (int d = 0; d < D; ++d) x[i * D + d] = o[0][i] * M(d, 0);
        if constexpr (D == 2) {
#pragma GCC unroll 4
            for (int j = 0; j < S; ++j) {
                const Vec<2> r = a + o[1][j] * M.col(1);
                for (int i = 0; i < S; ++i) N[i] = w[0][i] * w[1][j];
                for (int e = 0; e < E; ++e) Nt[e] = N[e / D] * (r[e % D] + x[e]);
                row(rowStart(g, j), N, Nt);
            }
        } else {
#pragma GCC unroll 4
            for (int k = 0; k < S; ++k) {
                const Vec<3> q = a + o[2][k] * M.col(2);
#pragma GCC unroll 4
                for (int j = 0; j < S; ++j) {
                    const double wjk = w[1][j] * w[2][k];
                    const Vec<3> r = q + o[1][j] * M.col(1);
                    for (int i = 0; i < S; ++i) N[i] = w[0][i] * wjk;
                    for (int e = 0; e < E; ++e) Nt[e] = N[e / D] * (r[e % D] + x[e]);
                    row(rowStart(g, j, k), N, Nt);
                }
            }
        }
    }

    /// APIC's P2G: C_u = B_p diag(r) in place (r[d] = 1 / (h du_d) from the point's frame; a
    /// direction with r[d] <= 0 gets 0: Solver::particleToGrid); 3D in 4-lane vectors: the same
    /// products, and +0 where the scalar form `r > 0 ? C.col(d) * r : 0` puts it. 3D: c[d] gets
    /// column d in lanes 0-2 (lane 3 holds another number), for scatterRowsAffineOf. (The scalar
    /// form has a branch per column and rebuilt C_u into vectors after its stores: 3D APIC's P2G
    /// point loop 348 -> 337 instructions.)
    static EMP_ALWAYS_INLINE void scaleAffine(Mat<D>& C, const double* r, typename Lane3::V* c = nullptr)
    {
        if constexpr (D == 2) {
            // (Scalar: its 4-lane form cost 2D APIC about 1 % more time, `bench/option_cost.py`,
            // although 2 instructions fewer; forEachRowAffine reads C_u right after.)
            for (int d = 0; d < D; ++d) C.col(d) = r[d] > 0 ? Vec<D>(C.col(d) * r[d]) : Vec<D>::Zero();
        } else {
            typedef typename Lane3::V V4;
            typedef typename Lane3::Bits B4;
            double* e = C.data();  // (column-major)
            const V4 zero{}, r0{r[0], r[0], r[0], r[0]}, r1{r[1], r[1], r[1], r[1]}, r2{r[2], r[2], r[2], r[2]};
            V4 c0, c1, t;  // columns 0 and 1 from their first entry, column 2 in lanes 1-3 of t
            __builtin_memcpy(&c0, e, sizeof c0);
            __builtin_memcpy(&c1, e + 3, sizeof c1);
            __builtin_memcpy(&t, e + 5, sizeof t);
            c0 = reinterpret_cast<V4>(reinterpret_cast<B4>(c0 * r0) & (r0 > zero));
            c1 = reinterpret_cast<V4>(reinterpret_cast<B4>(c1 * r1) & (r1 > zero));
            t = reinterpret_cast<V4>(reinterpret_cast<B4>(t * r2) & (r2 > zero));
            // Stored in this order, each store's last lane overwritten by the next; entry 5
            // (column 1's last) goes in t's lane 0.
            const V4 t5 = __builtin_shufflevector(t, c1, 6, 1, 2, 3);
            __builtin_memcpy(e, &c0, sizeof c0);
            __builtin_memcpy(e + 3, &c1, sizeof c1);
            __builtin_memcpy(e + 5, &t5, sizeof t5);
            if (c) c[0] = c0, c[1] = c1, c[2] = __builtin_shufflevector(t, t, 1, 2, 3, 3);
        }
    }

    /// 3D: APIC's P2G sums by rows, with M = m C, into a field of 4 numbers per node
    /// (Grid::massMomentum, as scatterRowsOf): node I gets N_I m added to its number 0 and
    /// N_I (a + M (x_I - x_p)) to its numbers 1 .. D, the same operations as forEachAffine's
    /// (N_I times the sum of the row's part and the column's part of a + M (x_I - x_p)). A node's
    /// numbers are one 4-lane vector: N_I times (0, the row's part) + (m, the column's part).
    /// C's columns come as scaleAffine's vectors c (lanes 0-2).
    template <class At>
    EMP_ALWAYS_INLINE void scatterRowsAffineOf(const Grid<D>& g, const double (*o)[S], const Vec<D>& a, double m,
                                               const typename Lane3::V* c, At&& at) const
    {
        static_assert(D == 3 && Grid<D>::sumsWidth == 4, "3D: one 4-lane vector per node");
        typedef typename Lane3::V V4;
        V4 wx[S], X[S];  // w[0][i] in each lane; (m, the column's part M_0 o_0i)
        for (int i = 0; i < S; ++i) wx[i] = V4{w[0][i], w[0][i], w[0][i], w[0][i]};
        const auto add = [&](double* r, double f, const V4& R) EMP_LAMBDA_INLINE {
            for (int i = 0; i < S; ++i) {
                V4 x;
                __builtin_memcpy(&x, r + 4 * i, sizeof(V4));
                x += (wx[i] * f) * (R + X[i]);
                __builtin_memcpy(r + 4 * i, &x, sizeof(V4));
            }
        };
        // (The 3-vectors shifted up by one lane, with m or 0 in lane 0. The row's part is summed
        // in the shifted lanes: 0 + o 0 in lane 0 is the 0 a shift of its sum would put there,
        // and one shift per point instead of one per row.)
        const V4 zero{}, mv{m, m, m, m};
        const auto shifted = [&](const V4& x) EMP_LAMBDA_INLINE { return __builtin_shufflevector(x, zero, 4, 0, 1, 2); };
        const V4 m0 = shifted(mv * c[0]), m1 = shifted(mv * c[1]), m2 = shifted(mv * c[2]), a3 = shifted(Lane3::of(a).v);
        for (int i = 0; i < S; ++i) X[i] = __builtin_shufflevector(o[0][i] * m0, mv, 4, 1, 2, 3);
        const Rows rows = rowsOf(g);  // (as in scatterRowsOf)
#pragma GCC unroll 4
        for (int k = 0; k < S; ++k) {
            const V4 q3 = a3 + o[2][k] * m2;
#pragma GCC unroll 4
            for (int j = 0; j < S; ++j) add(at(rows.start(j, k)), rows.y[j] * rows.z[k], q3 + o[1][j] * m1);
        }
    }

    /// Calls f(node index, N, grad N) for every support node, in a fixed order.
    template <class F> EMP_ALWAYS_INLINE void forEach(const Grid<D>& g, F&& f) const
    {
        // Node indices: from the base node, or near a pre-existing crack from the remap table
        // (phantom twins). Gathering them first keeps one copy of f's body, so that the compiler
        // inlines forEach and f into each pass and keeps the pass's sums in registers.
        int node[NS];
        nodes(g, node);
        if constexpr (D == 2) {
            for (int j = 0; j < S; ++j)
                for (int i = 0; i < S; ++i)
                    f(node[i + S * j], w[0][i] * w[1][j],
                      Vec<2>(dw[0][i] * w[1][j] * g.invh, w[0][i] * dw[1][j] * g.invh));
        } else {
            for (int k = 0; k < S; ++k)
                for (int j = 0; j < S; ++j) {
                    const double wjk = w[1][j] * w[2][k];
                    for (int i = 0; i < S; ++i)
                        f(node[i + S * (j + S * k)], w[0][i] * wjk,
                          Vec<3>(dw[0][i] * wjk * g.invh, w[0][i] * dw[1][j] * w[2][k] * g.invh,
                                 w[0][i] * w[1][j] * dw[2][k] * g.invh));
                }
        }
    }
};

}  // namespace emp
