// Material points as a struct of arrays: one contiguous array per quantity, indexed by point id.
#pragma once
#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "ElasticMaterial.hpp"
#include "Kinematics.hpp"
#include "Laws.hpp"
#include "PointTensor.hpp"

namespace emp {

/// The points' arrays as plain pointers, under MaterialPoints' names (x[p], v[p], mass(p), ...),
/// for a pass's loop over points. Made in the function that runs the loop, its pointers stay in
/// registers; read through the vectors, they are loaded again after every store of an SSE or AVX
/// vector (the intrinsics' vector types may alias any object, a vector's own pointers included).
/// With it, 2D G2P executes 11 instructions per point fewer (doc/performance.md, "Session 30").
template <int D> struct PointsView {
    Vec<D>* x;
    Vec<D>* v;
    const double* volume;
    PointTensor<D>* strain;
    double* energy;
    double* history;
    double* damage;
    const std::int32_t* material;
    Mat<D>* affineVelocity;
    Mat<D>* deformationGradient;
    const double* density;
    bool oneMaterial;  ///< one material: its density without the point's material id
    double mass(std::size_t p) const { return (oneMaterial ? density[0] : density[material[p]]) * volume[p]; }
};

template <int D> struct MaterialPoints {
    std::vector<Vec<D>> x;        ///< position
    std::vector<Vec<D>> v;        ///< velocity v^{n-1/2}
    std::vector<double> volume;   ///< V_p (reference volume; small-strain theory)
    /// Total small strain eps of the small-strain update (2D: symmetric, PointTensor.hpp). Empty
    /// when `deformation` is on: the co-rotated strain U - I follows from F (strainOf).
    std::vector<PointTensor<D>> strain;
    // The Cauchy stress sigma = g(c) sigma+ + sigma- (Eq 7) is not stored: it follows from the
    // strain (or F) and the damage (stressOf), and the step's force pass keeps each run's own.
    /// Elastic energy density c psi+ + psi- (Eqs 3-4, 7) at the strain and damage of the last
    /// stress update (erosion updates the points it erodes): what elasticEnergy sums. psi+ and
    /// psi- themselves are the law's at `strain`, not stored (_eigenmpm's psiPlus(), psiMinus()).
    std::vector<double> energy;
    std::vector<double> history;  ///< H = max psi+ over time (Eq 22)
    std::vector<double> damage;   ///< c: 1 intact, 0 eroded (g(c) = c)
    std::vector<std::int32_t> material;
    /// APIC's B_p = sum N v_I (x_I - x_p)^T (Kinematics.hpp; C_p = B_p D_p^-1), between steps;
    /// within a step, from P2G to G2P, h C_p at the point's position. Empty unless `affine` is on.
    std::vector<Mat<D>> affineVelocity;
    /// Deformation gradient F of the co-rotational update (Kinematics.hpp); empty unless
    /// `deformation` is on. The co-rotated strain U - I of F = R U is then not stored (strainOf).
    std::vector<Mat<D>> deformationGradient;
    /// The body each point belongs to (0-63): bodies in one grid touch without bonding
    /// (Solver::setPointBodies). Empty unless `bodies` is on: one body pays nothing.
    std::vector<std::int32_t> body;
    /// The point's index in the single-process scene (Distribution.hpp): a rank's points stay
    /// sorted by it. Empty unless `distributed` is on.
    std::vector<std::int32_t> globalId;
    /// Where each point was added (output measures displacement from it). Empty unless
    /// `referenced` is on: in a run distributed at set-up (Solver::distributeSetup) no rank holds
    /// every point, so the point carries it; otherwise the Python engine keeps it.
    std::vector<Vec<D>> reference;
    bool affine = false, deformation = false, bodies = false, distributed = false, referenced = false;  ///< which optional arrays the points carry

    /// The density of each material, by material id (kept by the Solver; not per point).
    std::vector<double> density;

    /// The arrays as plain pointers, with these names (PointsView).
    PointsView<D> view()
    {
        return {x.data(),       v.data(),      volume.data(),   strain.data(),         energy.data(),
                history.data(), damage.data(), material.data(), affineVelocity.data(), deformationGradient.data(),
                density.data(),  density.size() == 1};
    }

    std::size_t size() const { return x.size(); }
    /// Point p's strain: the small-strain update's eps, or the co-rotational update's co-rotated
    /// strain U - I of its F = R U, bitwise the one the stress update used (polarDecomposition,
    /// whose numbers the stress pass's lanes reproduce). Not stored with F: the step then writes
    /// 24 B (2D) or 72 B (3D) less per point. NaN for a degenerate F (the step's stress is NaN).
    Mat<D> strainOf(std::size_t p) const
    {
        if (!deformation) return full(strain[p]);
        Mat<D> R, U;
        if (!polarDecomposition(deformationGradient[p], R, U)) return Mat<D>::Constant(std::numeric_limits<double>::quiet_NaN());
        return U - Mat<D>::Identity();
    }
    /// Point p's Cauchy stress sigma = c sigma+ + sigma- (Eq 7) at its strain and damage, with
    /// materials[material[p]]'s law: the co-rotational update's rotated back to the spatial
    /// frame (Kinematics.hpp, cauchyStress), NaN for a degenerate F. Bitwise the stress the
    /// step's force used (the same operations as the stress pass's lanes), and after erosion
    /// (c = 0) sigma- alone; with APIC + co-rotational, whose G2P has moved F since, the stress
    /// the next step's force will use (Solver::deformationInG2P). Not stored: the step writes 24 B (2D) or 72 B (3D) less per point.
    /// `eps`, when given, receives the strain the law saw (strainOf(p), without a second polar
    /// decomposition).
    Mat<D> stressOf(std::size_t p, const std::vector<ElasticMaterial>& materials, Mat<D>* eps = nullptr) const
    {
        const ElasticMaterial& m = materials[material[p]];
        Mat<D> e;
        if (!deformation) {
            e = full(strain[p]);
            if (eps) *eps = e;
            const LawResponse<D> r = lawResponse<D>(e, m);
            return full(PointTensor<D>(Mat<D>(damage[p] * r.sigmaPlus + r.sigmaMinus)));
        }
        Mat<D> R, U;
        const Mat<D> nan = Mat<D>::Constant(std::numeric_limits<double>::quiet_NaN());
        const bool ok = polarDecomposition(deformationGradient[p], R, U);
        e = ok ? Mat<D>(U - Mat<D>::Identity()) : nan;
        if (eps) *eps = e;
        if (!ok) return nan;
        const LawResponse<D> r = lawResponse<D>(e, m);
        return full(PointTensor<D>(cauchyStress<D>(R, U, damage[p] * r.sigmaPlus + r.sigmaMinus)));
    }
    /// m_p = rho V_p: computed, not stored (8 B per point less; bitwise the mass stored before,
    /// which was rho V_p as the point was added).
    double mass(std::size_t p) const { return density[material[p]] * volume[p]; }
    /// Every point's mass, in id order.
    std::vector<double> masses() const
    {
        std::vector<double> m(size());
        for (std::size_t p = 0; p < size(); ++p) m[p] = mass(p);
        return m;
    }

    /// Calls f(name, array) for every per-point array: the state a restart needs. A new field
    /// is added here and in add(); saving and loading then follow.
    template <class F> void forEachArray(F&& f)
    {
        f("x", x);
        f("v", v);
        f("volume", volume);
        f("strain", strain);
        f("energy", energy);
        f("history", history);
        f("damage", damage);
        f("material", material);
        f("affineVelocity", affineVelocity);
        f("deformationGradient", deformationGradient);
        f("body", body);
        f("globalId", globalId);
        f("reference", reference);
    }

    /// Whether the points carry the array `name`: every non-optional one, an optional one when on.
    bool carries(const std::string& name) const
    {
        if (name == "affineVelocity") return affine;
        if (name == "deformationGradient") return deformation;
        if (name == "strain") return !deformation;
        if (name == "body") return bodies;
        if (name == "globalId") return distributed;
        if (name == "reference") return referenced;
        return true;
    }
    /// The length an array must have: every point's, or 0 for an optional one that is off.
    std::size_t expectedLength(const std::string& name) const { return carries(name) ? size() : 0; }

    /// Room for `more` points to be added: the arrays grow once (to the exact size when they
    /// must grow by more than their length, by doubling otherwise), not step by step, so that
    /// a scene added in bulk leaves no freed buffers of the arrays' growth behind in the heap.
    void reserveFor(std::size_t more)
    {
        const std::size_t need = size() + more;
        if (need <= x.capacity()) return;
        const std::size_t cap = std::max(need, 2 * size());
        forEachArray([&](const char* name, auto& a) {
            if (carries(name)) a.reserve(cap);
        });
    }

    void add(const Vec<D>& pos, const Vec<D>& vel, double vol, int mat)
    {
        x.push_back(pos);
        v.push_back(vel);
        volume.push_back(vol);
        if (!deformation) strain.push_back(PointTensor<D>(Mat<D>::Zero()));
        energy.push_back(0.0);
        history.push_back(0.0);
        damage.push_back(1.0);
        material.push_back(mat);
        if (affine) affineVelocity.push_back(Mat<D>::Zero());
        if (deformation) deformationGradient.push_back(Mat<D>::Identity());
        if (bodies) body.push_back(0);
        if (referenced) reference.push_back(pos);
    }
};

}  // namespace emp
