#include "CrackTransport.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "Configurations.hpp"
#include "Stencil.hpp"

namespace emp {

template <int D, class K>
void transportCracks(PhantomNodes<D>& phantom, const Grid<D>& g, double lp, double dt)
{
    // Crack vertices move with the material: the mass-weighted grid velocity around the vertex,
    // sum N (P_I + P_twins) / sum N (m_I + m_twins), i.e. the mean motion of both faces. Weighting
    // by mass keeps it bounded where a vertex sits among nearly empty nodes.
    // A vertex not fully inside the material (a node of its stencil has no mass, or the stencil
    // leaves the grid: the outer end of an edge crack, the ends of a through crack) has no
    // velocity of its own, or one biased towards the material's interior. It moves with the
    // linear velocity field fitted (mass-weighted least squares) to the nodes around the crack,
    // so that a translating or rotating body carries the whole crack rigidly with it.
    auto sample = [&](const Vec<D>& x, double& m, Vec<D>& mom) {
        m = 0;
        mom.setZero();
        for (int d = 0; d < D; ++d) {
            const int b = K::base((x[d] - g.origin[d]) * g.invh);
            if (b < 0 || b > g.n[d] - K::S) return false;
        }
        Stencil<D, K> st;
        st.compute(x, g, lp);
        bool full = true;
        st.forEach(g, [&](int I, double N, const Vec<D>&) {
            double mI = g.mass[I];
            Vec<D> pI = g.momentum[I];
            phantom.forEachTwin(I, [&](int t) {
                mI += g.mass[t];
                pI += g.momentum[t];
            });
            full = full && mI > 0;
            m += N * mI;
            mom += N * pI;
        });
        return full;
    };
    std::vector<Vec<D>> vel, xs, us;
    std::vector<double> ws;
    for (std::size_t c = 0; c < phantom.numCracks(); ++c) {
        auto& verts = phantom.vertices(static_cast<int>(c));
        const std::size_t nv = verts.size();
        vel.assign(nv, Vec<D>::Zero());
        std::vector<char> own(nv, 0);
        bool allOwn = true;
        for (std::size_t k = 0; k < nv; ++k) {
            double m;
            Vec<D> mom;
            own[k] = sample(verts[k], m, mom) && m > 0;
            if (own[k]) vel[k] = mom / m;
            allOwn = allOwn && own[k];
        }
        if (!allOwn) {
            // Fit over the nodes this crack marks (they hug it, within the grid), weighted by
            // the mass of each node and its twins: u(x) = a + G (x - xbar) / h. Directions
            // without data get the minimum-norm solution.
            xs.clear();
            us.clear();
            ws.clear();
            for (int I : phantom.markedNodes()) {
                if (phantom.twin(static_cast<int>(c), I) < 0) continue;
                double m = g.mass[I];
                Vec<D> p = g.momentum[I];
                phantom.forEachTwin(I, [&](int t) {
                    m += g.mass[t];
                    p += g.momentum[t];
                });
                if (m > 0) {
                    xs.push_back(g.nodePosition(I));
                    us.push_back(p / m);
                    ws.push_back(m);
                }
            }
            if (!xs.empty()) {
                double wsum = 0, wmax = 0;
                Vec<D> xbar = Vec<D>::Zero();
                for (std::size_t i = 0; i < xs.size(); ++i) {
                    wsum += ws[i];
                    wmax = std::max(wmax, ws[i]);
                    xbar += ws[i] * xs[i];
                }
                xbar /= wsum;
                Eigen::MatrixXd A(xs.size(), D + 1), B(xs.size(), D);
                for (std::size_t i = 0; i < xs.size(); ++i) {
                    const double sw = std::sqrt(ws[i] / wmax);
                    A(i, 0) = sw;
                    A.row(i).tail<D>() = (sw * g.invh) * (xs[i] - xbar).transpose();
                    B.row(i) = sw * us[i].transpose();
                }
                Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
                cod.setThreshold(1e-6);
                cod.compute(A);
                const Eigen::MatrixXd X = cod.solve(B);
                for (std::size_t k = 0; k < nv; ++k)
                    if (!own[k]) {
                        Eigen::RowVectorXd r(D + 1);
                        r(0) = 1.0;
                        r.tail<D>() = g.invh * (verts[k] - xbar).transpose();
                        vel[k] = (r * X).transpose();
                    }
            }
        }
        for (std::size_t k = 0; k < nv; ++k) verts[k] += dt * vel[k];
    }
}

#define EMP_INSTANTIATE(D, K) template void transportCracks<D, K>(PhantomNodes<D>&, const Grid<D>&, double, double);
EMP_SOLVER_CONFIGURATIONS(EMP_INSTANTIATE)
#undef EMP_INSTANTIATE

}  // namespace emp
