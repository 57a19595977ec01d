// The explicit MPM/GIMP solver (paper Section 4.1): update-stress-first central difference.
// Dimension and shape function are template parameters; each of the four combinations is
// instantiated once in Solver.cpp. Per-point loops have no virtual call and no allocation.
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <vector>

#include "BoundaryConditions.hpp"
#include "EigenErosion.hpp"
#include "ElasticMaterial.hpp"
#include "Grid.hpp"
#include "PhantomNodes.hpp"
#include "MaterialPoints.hpp"
#include "ShapeFunction.hpp"

namespace emp {

struct SolverSettings {
    double h = 0;          ///< cell size, m
    int ppc = 2;           ///< points per cell per direction (sets the uGIMP half-width)
    Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  ///< body force b, m/s2
    double massCutoff = 1e-14;  ///< nodes lighter than this fraction of the mean point mass are void
    int padding = 3;           ///< cells added around the points when the grid is sized automatically
};

template <int D, class Kernel> class Solver {
public:
    static_assert(D == 2 || D == 3, "EigenMPM runs in 2D or 3D");
    static constexpr int dim = D;
    static constexpr int S = Kernel::S;
    /// Cells per colouring strip: strips two apart never share a node (needs W >= S - 1).
    static constexpr int stripWidth = 4;

    explicit Solver(const SolverSettings& s);

    // --- set-up -------------------------------------------------------------------------
    int addMaterial(double E, double nu, double rho, bool planeStress);
    /// Appends a point; returns its id. Velocity in m/s, volume in m^D (2D: area x thickness).
    int addPoint(const Eigen::Vector3d& x, const Eigen::Vector3d& v, double volume, int material);
    /// Grid covering the box [lo, hi] (snapped outwards to multiples of h). Without it the grid
    /// covers the points' bounding box plus `padding` cells, when the first step runs.
    void setDomain(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
    /// Builds the grid now if it does not exist yet (node positions are needed for BC regions).
    void initialize();
    int addVelocityCondition(const std::vector<int>& nodes, const std::vector<int>& points,
                             unsigned mask, const Eigen::Vector3d& velocity, double rampTime);
    void setConditionVelocity(int id, const Eigen::Vector3d& velocity, double rampTime);
    int addTraction(const std::vector<int>& points, const Eigen::Vector3d& traction, double rampTime,
                    double layer);
    void setGravity(const Eigen::Vector3d& g) { settings_.gravity = g; }
    /// Attaches the eigenerosion stage (or detaches it with nullptr). Without it the step has no
    /// fracture work at all.
    void setErosion(std::shared_ptr<EigenErosion<D>> e) { erosion_ = std::move(e); }
    const std::shared_ptr<EigenErosion<D>>& erosion() const { return erosion_; }
    /// Adds a pre-existing crack (2D: polyline; 3D: planar polygon; z ignored in 2D); returns its
    /// id. Its vertices then move with the material.
    int addCrack(const std::vector<Eigen::Vector3d>& vertices);
    const PhantomNodes<D>& phantomNodes() const { return phantom_; }

    // --- time stepping ------------------------------------------------------------------
    /// Largest stable dt: h / max over materials of (wave speed + current max point speed).
    double criticalTimeStep() const;
    /// One explicit step of length dt on nThreads OpenMP threads. Throws ParameterError when dt
    /// exceeds the critical step, SimulationError on a non-finite value or a point off the grid.
    void step(double dt, int nThreads);

    // --- diagnostics --------------------------------------------------------------------
    double kineticEnergy() const;
    double elasticEnergy() const;  ///< sum V_p (c psi+ + psi-) (Eq 32)
    Eigen::Vector3d reaction(int id) const { return velocityConditions_.at(id).reaction; }
    double time() const { return time_; }
    void setTime(double t) { time_ = t; }
    std::int64_t steps() const { return steps_; }
    bool initialized() const { return initialized_; }

    const MaterialPoints<D>& points() const { return points_; }
    MaterialPoints<D>& points() { return points_; }
    const Grid<D>& grid() const { return grid_; }
    const std::vector<ElasticMaterial>& materials() const { return materials_; }
    const SolverSettings& settings() const { return settings_; }
    const std::vector<VelocityCondition>& velocityConditions() const { return velocityConditions_; }

private:
    /// Weights N_Ip and gradients grad N_Ip of one point on its S^D support nodes (Eq 15).
    /// Computed once per step, in P2G, and reused by the stress/force scatter and by G2P.
    struct Stencil {
        static constexpr int NS = D == 2 ? S * S : S * S * S;
        int base[D];
        int remap;  ///< offset of the node indices in Grid::remap, or -1 (no crack near)
        double w[D][S], dw[D][S];
        void compute(const Vec<D>& x, const Grid<D>& g, double lp);
        /// Replaces marked nodes by twins across the cracks, using slot `slot` of Grid::remap.
        void mapAcrossCracks(const Vec<D>& x, Grid<D>& g, const PhantomNodes<D>& ph, int slot);
        /// Calls f(node index, N, grad N) for every support node, in a fixed order.
        template <class F> void forEach(const Grid<D>& g, F&& f) const;
    };

    template <class F> void scatter(int nThreads, F&& perPoint);
    void binPoints(int nThreads);
    void applyVelocityConditions(double t, bool afterForces, double dt);
    void advectCracks(double dt);
    bool nearMarked(const Stencil& st) const;

    SolverSettings settings_;
    double lp_;  ///< particle half-width in cells, 1/(2 ppc)
    MaterialPoints<D> points_;
    std::vector<ElasticMaterial> materials_;
    Grid<D> grid_;
    bool haveDomain_ = false, initialized_ = false;
    Vec<D> domainLo_, domainHi_;
    double massCutoffAbs_ = 0;
    std::shared_ptr<EigenErosion<D>> erosion_;
    PhantomNodes<D> phantom_;
    int markedLo_[D] = {}, markedHi_[D] = {};  ///< box of the marked nodes, node indices
    std::vector<VelocityCondition> velocityConditions_;
    std::vector<TractionCondition> tractions_;
    std::vector<int> order_, stripStart_;  ///< points sorted (stably) by strip
    std::vector<int> stripOf_, stripFill_;
    std::vector<Stencil> stencil_;  ///< stencil_[k] is that of point order_[k] in this step
    double time_ = 0, maxSpeed_ = 0;
    std::int64_t steps_ = 0;
};

using Solver2Linear = Solver<2, LinearKernel>;
using Solver2GIMP = Solver<2, GimpKernel>;
using Solver3Linear = Solver<3, LinearKernel>;
using Solver3GIMP = Solver<3, GimpKernel>;

}  // namespace emp
