// Bodies in one grid (BodyFieldContact.hpp): the solver's stages that only scenes with several
// bodies run, in their own translation unit so that the step's hot passes in Solver.cpp are
// compiled as before (with them in Solver.cpp GCC generated a different, 4 % slower stress pass
// for the default 2D step, although it ran fewer instructions).
#include <algorithm>
#include <cmath>
#include <string>

#include "Errors.hpp"
#include "Solver.hpp"

namespace emp {

template <int D, class K> void Solver<D, K>::markBodyNodes()
{
    // Bodies in one grid: the nodes that points of two or more bodies reach (any node of their
    // S^D supports), with a twin per further body (PhantomNodes::updateBodies). Serial, one
    // stencil per point: only scenes with several bodies pay it.
    if (!points_.bodies) return;
    auto& g = grid_;
    bodyReach_.assign(g.numNodes(), 0);
    int bodies = 1;
    St st;
    for (std::size_t p = 0; p < points_.size(); ++p) {
        st.compute(points_.x[p], g, lp_);
        const int b = points_.body[p];
        bodies = std::max(bodies, b + 1);
        const std::uint64_t bit = std::uint64_t(1) << b;
        for (int k = 0; k < St::NS; ++k) bodyReach_[st.regularNode(g, k)] |= bit;
    }
    g.setTwins(phantom_.updateBodies(g, bodyReach_, bodies));
    mapping_ = phantom_.markedNodes().empty() ? 0 : 2;
    markedBox();
}

template <int D, class K> void Solver<D, K>::bodyGradients()
{
    // Each field's mass gradient sum m_p grad N_I at the nodes the bodies share (their normals):
    // the points that reach a marked node are those whose support was remapped.
    if (mapping_ != 2) return;
    auto& G = bodyContact_.gradient;
    G.assign(grid_.totalNodes(), Vec<D>::Zero());
    const auto& order = schedule_.order();
    for (std::size_t k = 0; k < order.size(); ++k) {
        const St& st = stencil_[k];
        if (st.remap < 0) continue;
        const double m = points_.mass(order[k]);
        st.forEach(grid_, [&](int I, double, const Vec<D>& grad) { G[I] += m * grad; });
    }
}

// Out of line, so that P2G's loop stays the same for scenes without cracks or bodies.
template <int D, class K> EMP_NOINLINE void Solver<D, K>::mapSupport(St& st, int p, int slot)
{
    if (mapping_ == 2)
        st.mapBodies(points_.body[p], grid_, phantom_, slot);
    else
        st.mapAcrossCracks(points_.x[p], grid_, phantom_, slot);
}

// P2G's run of the points order[begin .. end) after Stencil::computeRun: the supports of those
// flagged near (near[k - begin]) mapped, as mapSupport(stencil_[k], order[k], k) would.
template <int D, class K> EMP_NOINLINE void Solver<D, K>::mapRun(int begin, int end, const int* near)
{
    const auto& order = schedule_.order();
    typename St::SupportMemo memo;  // (the run's points one after another: a support's findings kept)
    for (int k = begin; k < end; ++k) {
        if (!near[k - begin]) continue;
        const int p = order[k];
        if (mapping_ == 2)
            stencil_[k].mapBodies(points_.body[p], grid_, phantom_, k);
        else
            stencil_[k].mapAcrossCracks(points_.x[p], grid_, phantom_, k, &memo);
    }
}

template <int D, class K> void Solver<D, K>::setPointBodies(int first, int count, int body)
{
    const int n = static_cast<int>(points_.size());
    require(body >= 0 && body < 64, "body", body, "0 <= body <= 63");
    require(first >= 0 && count >= 0 && first + count <= n, "points", std::to_string(first) + " + " + std::to_string(count),
            "points of this engine (0 .. " + std::to_string(n) + ")");
    require(phantom_.empty() || body == 0, "body", body,
            "0 in an engine with pre-existing cracks (a crack and bodies in one grid both use the phantom "
            "twins; use one engine per cracked body)");
    if (body == 0 && !points_.bodies) return;
    if (!points_.bodies) {
        points_.bodies = true;
        points_.body.assign(points_.size(), 0);
    }
    std::fill(points_.body.begin() + first, points_.body.begin() + first + count, body);
}

template <int D, class K> void Solver<D, K>::setBodyFriction(double friction)
{
    require(std::isfinite(friction) && friction >= 0, "bodyFriction", friction, "0 <= bodyFriction < inf");
    bodyContact_.friction = friction;
}

#define EMP_INSTANTIATE(D, K)                                                         \
    template void Solver<D, K>::markBodyNodes();                                      \
    template void Solver<D, K>::bodyGradients();                                      \
    template void Solver<D, K>::mapSupport(Stencil<D, K>&, int, int);                 \
    template void Solver<D, K>::mapRun(int, int, const int*);                         \
    template void Solver<D, K>::setPointBodies(int, int, int);                        \
    template void Solver<D, K>::setBodyFriction(double);
EMP_SOLVER_CONFIGURATIONS(EMP_INSTANTIATE)
#undef EMP_INSTANTIATE

}  // namespace emp
