// The plain reference step: paper Section 4.1 written for clarity, one loop per stage, no fusion,
// no binning or colouring, no cached stencils, brute-force eigenerosion. Start here to learn
// the method; pkg/Solver.cpp is the same step organised for speed, and
// test_reference_step.cpp checks that the two agree to round-off on random scenes.
//
// It reuses the building blocks that are physics rather than step organisation: the kernels'
// 1D weights (Eq 15-16), the laws (Eqs 2-7), the phantom-node rule (PhantomNodes), the grid
// conditions' own hooks and the crack transport stage.
#pragma once
#include <memory>
#include <vector>

#include "CrackTransport.hpp"
#include "Laws.hpp"
#include "Solver.hpp"

namespace emptest {

using emp::Mat;
using emp::Vec;

template <int D, class K> struct ReferenceScene {
    emp::MaterialPoints<D> P;
    std::vector<Mat<D>> stress;  ///< each point's stress, kept (the solver's points do not store it)
    emp::Grid<D> g;
    emp::PhantomNodes<D> cracks;
    std::vector<emp::ElasticMaterial> materials;
    std::vector<std::shared_ptr<emp::GridCondition<D>>> conditions;
    std::vector<emp::TractionCondition> tractions;
    Vec<D> gravity;
    double lp = 0, massCutoff = 0, time = 0;
    bool erosion = false;
    emp::ErosionSettings erosionSettings{};
    double dissipated = 0;

    /// Copies the state and set-up of solver s (initialised, before or between steps).
    template <class Sv> explicit ReferenceScene(const Sv& s)
        : P(s.points()), g(s.grid()), cracks(s.phantomNodes()), materials(s.materials()),
          tractions(s.tractions()), gravity(s.settings().gravity.template head<D>()), lp(s.halfWidth()),
          massCutoff(s.massCutoffAbsolute()), time(s.time())
    {
        for (std::size_t p = 0; p < P.size(); ++p) stress.push_back(s.stressOf(p));
        for (const auto& c : s.velocityConditions())
            conditions.push_back(std::make_shared<emp::VelocityCondition<D>>(*c));
        if (s.erosion()) {
            erosion = true;
            erosionSettings = s.erosion()->settings();
            dissipated = s.erosion()->dissipatedEnergy();
        }
    }
};

/// One support node of a point: its index (a twin across a crack), N_Ip and grad N_Ip.
template <int D> struct SupportNode {
    int I;
    double N;
    Vec<D> grad;
};

/// Eq 15 as a tensor product of the kernel's 1D weights, with the phantom-node rule.
template <int D, class K>
std::vector<SupportNode<D>> supportOf(const Vec<D>& x, const emp::Grid<D>& g, const emp::PhantomNodes<D>& cracks, double lp)
{
    double w[D][K::S], dw[D][K::S];
    int base[D];
    for (int d = 0; d < D; ++d) base[d] = K::eval((x[d] - g.origin[d]) / g.h, lp, w[d], dw[d]);
    std::vector<SupportNode<D>> out;
    const int nk = D == 3 ? K::S : 1;
    for (int k = 0; k < nk; ++k)
        for (int j = 0; j < K::S; ++j)
            for (int i = 0; i < K::S; ++i) {
                const int ijk[3] = {i, j, k};
                SupportNode<D> s{0, 1.0, Vec<D>::Ones()};
                for (int d = 0; d < D; ++d) {
                    s.I += (base[d] + ijk[d]) * g.stride[d];
                    s.N *= w[d][ijk[d]];
                    for (int e = 0; e < D; ++e) s.grad[e] *= (e == d ? dw[d][ijk[d]] / g.h : w[d][ijk[d]]);
                }
                if (!cracks.empty() && cracks.marked(s.I)) s.I = cracks.map(x, s.I, g.nodePosition(s.I));
                out.push_back(s);
            }
    return out;
}

template <int D, class K> void referenceStep(ReferenceScene<D, K>& s, double dt)
{
    auto& P = s.P;
    auto& g = s.g;
    const int np = static_cast<int>(P.size());
    // Phantom nodes for the cracks' current position (Section 3.3.1).
    const int twins = s.cracks.empty() ? 0 : s.cracks.update(g, K::crackRings);
    const int nn = g.numNodes() + twins;
    g.mass.assign(nn, 0.0);
    g.invMass.assign(nn, 0.0);
    g.momentum.assign(nn, Vec<D>::Zero());
    g.velocity.assign(nn, Vec<D>::Zero());
    g.force.assign(nn, Vec<D>::Zero());
    std::vector<std::vector<SupportNode<D>>> sup(np);
    for (int p = 0; p < np; ++p) sup[p] = supportOf<D, K>(P.x[p], g, s.cracks, s.lp);

    // (1) P2G: nodal mass (Eq 12) and momentum (Eq 25).
    for (int p = 0; p < np; ++p)
        for (const auto& n : sup[p]) {
            g.mass[n.I] += n.N * P.mass(p);
            g.momentum[n.I] += n.N * (P.mass(p) * P.v[p]);
        }
    // (2) Nodal velocity (Eq 26); 1/m only above the small-mass cut-off.
    for (int I = 0; I < nn; ++I) {
        g.velocity[I] = g.mass[I] > 0 ? Vec<D>(g.momentum[I] / g.mass[I]) : Vec<D>::Zero();
        g.invMass[I] = g.mass[I] > s.massCutoff ? 1.0 / g.mass[I] : 0.0;
    }
    emp::GridState<D> before{g, P, s.cracks, std::max(s.time - 0.5 * dt, 0.0), dt};
    for (auto& c : s.conditions) c->afterNodalVelocity(before);

    // (3) Strain increment (Eq 27), the law's split (Eqs 2-7), history (Eq 22).
    for (int p = 0; p < np; ++p) {
        Mat<D> L = Mat<D>::Zero();
        for (const auto& n : sup[p]) {
            const bool empty = K::gradientJumpsAtNodes && !(g.mass[n.I] > 0);
            L += (empty ? P.v[p] : g.velocity[n.I]) * n.grad.transpose();
        }
        P.strain[p] += Mat<D>(0.5 * dt * (L + L.transpose()));
        const auto r = emp::lawResponse<D>(emp::full(P.strain[p]), s.materials[P.material[p]]);
        s.stress[p] = emp::full(emp::PointTensor<D>(Mat<D>(P.damage[p] * r.sigmaPlus + r.sigmaMinus)));
        P.energy[p] = P.damage[p] * r.psiPlus + r.psiMinus;
        P.history[p] = std::max(P.history[p], r.psiPlus);
    }
    // (4) Eigenerosion (Eqs 23-24) by brute force; all qualifying points erode together.
    if (s.erosion) {
        const auto& e = s.erosionSettings;
        std::vector<int> eroding;
        for (int p = 0; p < np; ++p) {
            if (!(P.damage[p] > 0)) continue;
            double mh = 0, m = 0;
            for (int q = 0; q < np; ++q)
                if (P.damage[q] > 0 && (P.x[q] - P.x[p]).squaredNorm() <= e.kappa * e.kappa) {
                    mh += P.mass(q) * P.history[q];
                    m += P.mass(q);
                }
            if (e.alpha * e.kappa * mh / m >= e.Gc) eroding.push_back(p);
        }
        for (int p : eroding) {
            P.damage[p] = 0.0;
            s.stress[p] = emp::full(emp::PointTensor<D>(emp::lawResponse<D>(emp::full(P.strain[p]), s.materials[P.material[p]]).sigmaMinus));
            s.dissipated += e.Gc / (2.0 * e.kappa) * P.volume[p];  // Eq 33
        }
    }
    // (5) Internal and body force (Eqs 13-14), traction (Eq 28), conditions on the forces.
    for (int p = 0; p < np; ++p)
        for (const auto& n : sup[p]) g.force[n.I] += n.N * P.mass(p) * s.gravity - P.volume[p] * s.stress[p] * n.grad;
    for (const auto& t : s.tractions)
        for (int p : t.points) {
            const Vec<D> tr = (emp::rampFactor(s.time, t.rampTime) * t.traction).template head<D>();
            for (const auto& n : sup[p]) g.force[n.I] += n.N * (tr * (P.volume[p] / t.layer));
        }
    emp::GridState<D> after{g, P, s.cracks, s.time + 0.5 * dt, dt};
    for (auto& c : s.conditions) c->afterForces(after);
    // (5) Nodal momentum (Eq 29).
    for (int I = 0; I < nn; ++I) g.momentum[I] += dt * g.force[I];
    // (6) G2P: FLIP velocity (Eq 30) and position from the nodal momentum (Eq 31).
    for (int p = 0; p < np; ++p) {
        Vec<D> a = Vec<D>::Zero(), v = Vec<D>::Zero();
        for (const auto& n : sup[p]) {
            a += n.N * g.force[n.I] * g.invMass[n.I];
            v += n.N * g.momentum[n.I] * g.invMass[n.I];
        }
        P.v[p] += dt * a;
        P.x[p] += dt * v;
    }
    // Crack vertices move with the material.
    if (!s.cracks.empty()) emp::transportCracks<D, K>(s.cracks, g, s.lp, dt);
    s.time += dt;
}

}  // namespace emptest
