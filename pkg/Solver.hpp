// The explicit MPM/GIMP solver (paper Section 4.1): update-stress-first central difference.
// Dimension and shape function are template parameters; the combinations are listed once, in
// Configurations.hpp. step() is the paper's sequence of stages, each a member function below;
// per-point loops have no virtual call and no allocation. What varies plugs in without editing
// the step: the law per material (Laws.hpp), the kernel's traits (ShapeFunction.hpp), grid
// conditions (GridCondition.hpp), and the scheduling of points over workers (Scheduler.hpp).
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <istream>
#include <ostream>
#include <limits>
#include <memory>
#include <vector>

#include "BodyContact.hpp"
#include "BodyFieldContact.hpp"
#include "BoundaryConditions.hpp"
#include "CrackFaceContact.hpp"
#include "Configurations.hpp"
#include "Distribution.hpp"
#include "EigenErosion.hpp"
#include "ElasticMaterial.hpp"
#include "Grid.hpp"
#include "GridCondition.hpp"
#include "Kinematics.hpp"
#include "MaterialPoints.hpp"
#include "PhantomNodes.hpp"
#include "Scheduler.hpp"
#include "ShapeFunction.hpp"
#include "Stencil.hpp"
#include "VelocityCondition.hpp"

namespace emp {

/// What an archive of Solver::saveState holds: its dimension and kernel, read from its header
/// so that the caller can pick the solver class (the stream is left after the header).
struct StateHeader {
    int version;
    int dim;
    std::string kernel;
};
StateHeader readStateHeader(std::istream& is);

/// Every setting of a solver. No defaults here: the caller (the Python engine, which declares
/// the defaults once, or a test) gives every value, and the constructor validates them.
struct SolverSettings {
    double h = std::numeric_limits<double>::quiet_NaN();  ///< cell size, m
    int ppc = 0;  ///< points per cell per direction (sets the uGIMP half-width)
    Eigen::Vector3d gravity = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());  ///< m/s2
    double massCutoff = std::numeric_limits<double>::quiet_NaN();  ///< nodes lighter than this fraction of the mean point mass are void
    int padding = 0;  ///< cells added around the points when the grid is sized automatically
    Transfer transfer = Transfer::unset;              ///< FLIP (the paper's) or APIC (Kinematics.hpp)
    StressUpdate stressUpdate = StressUpdate::unset;  ///< smallStrain (the paper's) or corotational
    /// Columns of the scheduler along the first axis, in cells (0: none): the order of the
    /// contributions to the nodes, which a decomposition in two directions needs (Scheduler.hpp).
    int columnCells = 0;
};

template <int D, class Kernel> class Solver {
public:
    static_assert(D == 2 || D == 3, "EigenMPM runs in 2D or 3D");
    static constexpr int dim = D;
    static constexpr int S = Kernel::S;

    explicit Solver(const SolverSettings& s);

    // --- set-up -------------------------------------------------------------------------
    /// Adds a material with the law of index `law` in RegisteredLaws (lawIndex(name)).
    int addMaterial(double E, double nu, double rho, bool planeStress, int law);
    /// Appends a point; returns its id. Velocity in m/s, volume in m^D (2D: area x thickness).
    int addPoint(const Eigen::Vector3d& x, const Eigen::Vector3d& v, double volume, int material);
    /// Room for `more` points about to be added (addPoints in bulk): optional, it only saves
    /// the arrays' step-by-step growth and the freed buffers it leaves in the heap.
    void reservePoints(std::size_t more) { points_.reserveFor(more); }
    /// Grid covering the box [lo, hi] (snapped outwards to multiples of h). Without it the grid
    /// covers the points' bounding box plus `padding` cells, when the first step runs.
    void setDomain(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
    /// Builds the grid now if it does not exist yet (node positions are needed for BC regions).
    void initialize();
    /// A velocity condition (VelocityCondition.hpp); returns its id for reaction(id).
    int addVelocityCondition(const std::vector<int>& nodes, const std::vector<int>& points,
                             unsigned mask, const Eigen::Vector3d& velocity, double rampTime);
    void setConditionVelocity(int id, const Eigen::Vector3d& velocity, double rampTime);
    /// Any grid condition, applied at its points of the step after the ones added before it.
    void addCondition(std::shared_ptr<GridCondition<D>> c);
    int addTraction(const std::vector<int>& points, const Eigen::Vector3d& traction, double rampTime,
                    double layer);
    void setGravity(const Eigen::Vector3d& g);
    /// Attaches the eigenerosion stage (or detaches it with nullptr). Without it the step has no
    /// fracture work at all.
    void setErosion(std::shared_ptr<EigenErosion<D>> e) { erosion_ = std::move(e); }
    const std::shared_ptr<EigenErosion<D>>& erosion() const { return erosion_; }
    /// Attaches contact with rigid bodies (BodyContact.hpp), or detaches it with nullptr. It acts
    /// after the forces, before the other grid conditions; its work adds to externalWork().
    void setContact(std::shared_ptr<BodyContact<D>> c) { contact_ = std::move(c); }
    const std::shared_ptr<BodyContact<D>>& contact() const { return contact_; }
    /// Contact between the faces of the pre-existing cracks (CrackFaceContact.hpp), with Coulomb
    /// friction mu; without it (the paper's model) the faces pass through each other.
    void setCrackContact(bool on, double friction);
    /// Whether a step may run as a wavefront over the strips (pipelineLoop, doc/performance.md
    /// "Session 52"): on by default; off runs every step pass by pass. Bitwise the same results
    /// either way; a switch for comparisons and tests, not part of the saved state.
    void setPipelined(bool on) { pipelined_ = on; }
    bool pipelined() const { return pipelined_; }
    /// Whether the last step ran as a wavefront (a scene it serves: pipelineable), and on how
    /// many workers (1 or 2; 0 after a step pass by pass).
    bool lastStepPipelined() const { return lastStepPipelined_; }
    int lastStepWorkers() const { return lastStepPipelined_ ? workers_ : 0; }
    /// The crack-face contact, or nullptr when it is off.
    const std::shared_ptr<CrackFaceContact<D>>& crackContact() const { return crackContact_; }
    /// Adds a pre-existing crack (2D: polyline; 3D: planar polygon; z ignored in 2D); returns its
    /// id. Its vertices then move with the material.
    int addCrack(const std::vector<Eigen::Vector3d>& vertices);
    const PhantomNodes<D>& phantomNodes() const { return phantom_; }
    /// Puts points first .. first + count - 1 in body `body` (0 to 63; every point starts in
    /// body 0). Bodies in one grid do not bond: where their points reach the same nodes, each has
    /// its own velocity field there, and contact (BodyFieldContact.hpp) keeps them from passing
    /// through each other, with Coulomb friction bodyFriction(), and lets them separate. Not
    /// with pre-existing cracks (ParameterError).
    void setPointBodies(int first, int count, int body);
    int pointBody(int p) const { return points_.bodies ? points_.body[p] : 0; }
    void setBodyFriction(double friction);
    double bodyFriction() const { return bodyContact_.friction; }
    /// Field pairs in contact between bodies after the forces in the last step.
    int bodyContactPairs() const { return bodyContact_.pairsInContact; }

    /// Runs this solver as one rank of a scene distributed over transport->size() processes
    /// (Distribution.hpp, doc/parallel.md). Every rank builds the same scene and calls this
    /// before the first step; the first step then keeps this rank's points. The results are
    /// bitwise those of one process; the diagnostics (energies, momenta, reactions, work) are
    /// sums over the ranks, and every rank must call them. Refused (ParameterError) with
    /// crack-face contact, several bodies, contact, conditions other than velocity conditions
    /// on nodes, or after the first step unless the solver is a rank's part loaded from its
    /// archive (distributedPart()), which needs the same rank of the same number of ranks.
    /// rankColumns > 1 splits the ranks in two directions (SolverSettings::columnCells > 0; the
    /// results are bitwise those of one process with the same columnCells): rankColumns
    /// columns along the first axis, size / rankColumns rows along the last (doc/parallel.md,
    /// "Decomposition in two directions"). A rank's part resumes with its archive's columns.
    void distribute(std::shared_ptr<Transport> transport, int rankColumns = 1);
    /// The same, with the points distributed from the start, so that no rank ever holds the
    /// whole scene (doc/parallel.md, "Memory"): called before any point is added. Each rank
    /// then adds only its share of the points, with the ids one process gives them
    /// (holdPoints); the first step chooses the ranges as distribute() does and sends every
    /// point to its rank. The points carry their reference positions (MaterialPoints::reference).
    /// The grid, the mass cut-off and the critical time step are those of one process: every
    /// rank must call initialize() (and what calls it) together. Results are bitwise those of
    /// distribute().
    void distributeSetup(std::shared_ptr<Transport> transport, int rankColumns = 1);
    /// Set-up of a run distributed at set-up: the `count` points added next are this rank's
    /// share of `total` new points of the whole scene, numbered from numGlobalPoints() + offset on.
    void holdPoints(int offset, int count, int total);
    /// The points of the whole scene: every rank's (a distributed run), or this solver's.
    int numGlobalPoints() const { return dist_ ? globalPoints_ : static_cast<int>(points_.size()); }
    /// The distribution, or nullptr in a single-process run.
    const Distribution<D>* distribution() const { return dist_.get(); }
    /// Whether this solver is one rank's part of a distributed run, loaded from its archive and
    /// not yet distributed again: distribute() with the same number of ranks resumes it, and it
    /// refuses to step before.
    bool distributedPart() const { return points_.distributed && !dist_; }
    /// Load balance of a distributed run (Distribution::rebalance): before every `period`-th
    /// step the ranges of strips are chosen again when the rank that holds most points holds
    /// more than `tolerance` (>= 1) times the mean; period 0: never. The results do not change.
    void setRebalance(double tolerance, int period);
    /// How many times the ranges changed in this process's run.
    int rebalances() const { return rebalances_; }

    // --- time stepping ------------------------------------------------------------------
    /// APIC: sets point p's affine velocity (its velocity gradient, 1/s) for the next transfer,
    /// e.g. the initial velocity field's gradient (builds the grid if needed). Throws
    /// ParameterError with the FLIP transfer.
    void setVelocityGradient(int p, const Mat<D>& C);
    /// APIC: the affine velocity C_p = B_p D_p^-1 a point carries at its current position.
    Mat<D> velocityGradient(int p) const;

    /// Largest stable dt: h / max over materials of (wave speed + current max point speed).
    double criticalTimeStep() const;
    /// One explicit step of length dt on nThreads OpenMP threads. Throws ParameterError when dt
    /// exceeds the critical step, SimulationError on a non-finite value or a point off the grid.
    void step(double dt, int nThreads);

    // --- state (restart) ----------------------------------------------------------------
    /// Writes everything the continuation needs (SolverState.cpp): settings, domain and grid,
    /// materials (with their law by name), points and all their fields, velocity conditions,
    /// tractions, cracks at their current position, the erosion stage and its diagnostics, time
    /// and counters. Throws SimulationError when a grid condition cannot be saved (one added
    /// with addCondition that is not a VelocityCondition).
    void saveState(std::ostream& os) const;
    /// A solver restored from saveState's output; continuing it gives bitwise the results of
    /// the solver that was saved. Throws SimulationError, naming what is wrong, for an archive of
    /// another format, version or configuration, or a damaged one.
    static std::shared_ptr<Solver> loadState(std::istream& is);

    // --- diagnostics --------------------------------------------------------------------
    double kineticEnergy() const;  ///< sum m v^2 / 2 of the point velocities (v^{n+1/2} after a step)
    double elasticEnergy() const;  ///< sum V_p (c psi+ + psi-) (Eq 32), at t^n of the last step
    /// Kinetic energy at the time level of elasticEnergy (t^n of the last step): sum m_p
    /// v^{n-1/2}.v^{n+1/2} / 2, plus APIC's affine part sum m_p tr(C_old D_p C_new^T) / 2; the
    /// leapfrog's own energy, which a linear oscillator conserves exactly. 0 before a step.
    double kineticEnergyAtStep() const { return kineticAtStep_; }
    /// Work done on the points up to the last step by the velocity conditions (their reaction
    /// forces), the tractions, gravity and contact, J; each step adds f . (v^{n-1/2} + v^{n+1/2}) dt / 2 at
    /// the nodes.
    double externalWork() const;
    /// Total linear momentum sum m_p v_p (3 components; z = 0 in 2D).
    Eigen::Vector3d linearMomentum() const;
    /// Total angular momentum about the origin: sum x_p x m_p v_p, plus APIC's affine part
    /// m_p eps:(B_p^T) (Kinematics.hpp); in 2D only z is non-zero.
    Eigen::Vector3d angularMomentum() const;
    /// kineticEnergy, elasticEnergy, linearMomentum and angularMomentum from one pass over the
    /// points (a record of all four reads the points once, not four times); the four functions
    /// return its sums. Each is summed in 8 partial sums (point p in partial p mod 8) added in a
    /// fixed order: the same bits in every lane width and thread count, and within round-off of
    /// a plain sum in point order (tests/cpp/test_diagnostics.cpp).
    struct Diagnostics {
        double kinetic = 0, elastic = 0;
        Eigen::Vector3d momentum = Eigen::Vector3d::Zero(), angularMomentum = Eigen::Vector3d::Zero();
    };
    Diagnostics diagnostics() const;
    Eigen::Vector3d reaction(int id) const { return velocityConditions_.at(id)->reaction; }
    double time() const { return time_; }
    void setTime(double t) { time_ = t; }
    std::int64_t steps() const { return steps_; }
    bool initialized() const { return initialized_; }

    const MaterialPoints<D>& points() const { return points_; }
    MaterialPoints<D>& points() { return points_; }
    const Grid<D>& grid() const { return grid_; }
    const std::vector<ElasticMaterial>& materials() const { return materials_; }
    /// Point p's Cauchy stress (not stored: MaterialPoints::stressOf).
    Mat<D> stressOf(std::size_t p) const { return points_.stressOf(p, materials_); }
    /// The stresses as the stress pass makes them, for tests of stressOf and of the pass's
    /// vectorised laws: f(ids, n, sigma) for each run of n points ids (sigma[i] that of ids[i]),
    /// from the pass's threads (each point once a step); an empty f stops it.
    using StressObserver = std::function<void(const int* ids, int n, const PointTensor<D>* sigma)>;
    void observeStresses(StressObserver f) { stressObserver_ = std::move(f); }
    const SolverSettings& settings() const { return settings_; }
    /// With APIC and the co-rotational update together, G2P updates F (F <- (I + dt C_p) F, the
    /// gradient of the points' motion through the affine fit C_p = B_p D_p^-1 it has just
    /// summed; Kinematics.hpp) and the stress pass takes F as it is, without velocity gradients. After a
    /// step, F (so stressOf and strainOf) is then that of the state the step reached, the one the next
    /// step's forces start from. The internal force is then the transpose of that update
    /// (affineGradients).
    bool deformationInG2P() const
    {
        return settings_.transfer == Transfer::apic && settings_.stressUpdate == StressUpdate::corotational;
    }
    const std::vector<TractionCondition>& tractions() const { return tractions_; }
    /// The velocity conditions by id (reaction(id)), and every grid condition in order.
    const std::vector<std::shared_ptr<VelocityCondition<D>>>& velocityConditions() const { return velocityConditions_; }
    const std::vector<std::shared_ptr<GridCondition<D>>>& conditions() const { return conditions_; }
    /// Nodes lighter than this (kg) get no acceleration (massCutoff x mean point mass).
    double massCutoffAbsolute() const { return massCutoffAbs_; }
    /// Particle half-width in cells, 1/(2 ppc) (uGIMP, Eq 16 generalised).
    double halfWidth() const { return lp_; }

private:
    using St = Stencil<D, Kernel>;

    // The stages of step(), in order (paper Section 4.1).
    void checkTimeStep(double dt);
    void distributePoints();
    /// Throws ParameterError when rankColumns_ does not divide `ranks` or needs columns.
    void checkRankColumns(int ranks) const;
    /// initialize()'s sums over the points of a run distributed at set-up, as one process forms them.
    void initializeHeld(Vec<D>& lo, Vec<D>& hi, double& meanMass);
    /// Throws ParameterError for what a distributed run does not have yet (distribute()).
    void checkDistributable() const;
    void schedulePoints(int nThreads);
    void markCrackedNodes();
    void markBodyNodes();
    void markedBox();
    void clearGrid(int nThreads);
    void particleToGrid(int nThreads);
    void bodyGradients();
    void nodalVelocity(int nThreads);
    void applyConditionsAfterVelocity(double dt);
    void stressAndInternalForce(double dt, int nThreads);
    /// deformationInG2P: the stresses before P2G (slotStress_), whose force P2G scatters.
    void stressBeforeTransfer(double dt, int nThreads);
    /// The stress passes' start: the check's flag cleared, stepLaw_ chosen.
    void startStressPass();
    /// A run's stresses checked (stressNonFinite_) and shown to the observer (observeStresses).
    void checkStresses(const int* ids, int n, const PointTensor<D>* sigma);
    void erode(double dt, int nThreads);
    void tractionForces();
    void applyConditionsAfterForces(double dt);
    void updateGrid(double dt, int nThreads);
    /// One node's nodal velocity (nodalVelocity) and update (updateGrid): the passes' and the
    /// wavefront's (pipelineLoop) numbers from one place.
    void velocityAt(int I, double cut);
    void updateAt(int I, double dt);
    void gridToParticle(double dt, int nThreads);
    void accumulateExternalWork(double dt);
    /// The step as a wavefront over the strips (doc/performance.md, "Session 52"): each pass's
    /// work for one strip, set by particleToGrid, stressAndInternalForce and gridToParticle in
    /// turn, each calling the next, the last running pipelineLoop.
    struct StripPasses {
        double dt = 0;
        int threads = 1;
        std::function<void(int, int)> p2g, stress;  ///< the slots [begin, end) of one strip
        std::function<void(int)> g2p;              ///< strip s, its checks kept per strip
    };
    bool pipelineable(int nThreads) const;
    void pipelineLoop();
    StripPasses* strips_ = nullptr;  ///< set during a wavefront step
    bool pipelined_ = true, lastStepPipelined_ = false;
    int workers_ = 0;
    /// A worker's ring of its strips' stencils during a wavefront step (stripStencils_ + k is
    /// slot k's stencil for the strip it is on), or null: the passes' stencil_.
    static thread_local St* stripStencils_;
    /// During a wavefront step with erosion: the history at which a point is a source
    /// (EigenErosion::sourceHistory; infinite otherwise), and whether the law met one in the
    /// strip its worker is on (lawOfRun).
    double sourceHistory_ = std::numeric_limits<double>::infinity();
    static thread_local bool stripSource_;
    /// Where slot k's stencil is this step: stencils() + k (the worker's ring, or stencil_).
    St* stencils() { return stripStencils_ ? stripStencils_ : stencil_.data(); }
    std::vector<St> ring_;
    void transportCracks(double dt);

    // Per-point pieces of the fused stress/force pass, which runs in runs of stressRun points.
    static constexpr int stressRun = 16;
    /// P2G's runs of points whose stencils are computed together (Stencil::computeRun).
    static constexpr int stencilRun = 32;
    /// What the passes' loops over points read and write (the points, the binned order, the
    /// stencils, the nodal arrays), as plain pointers (PointsView). Made in the function that runs
    /// a loop, they stay in registers there; read through the containers, each is loaded again
    /// after every store of an SSE or AVX vector (which may alias any object).
    struct PassArrays {
        PointsView<D> P;
        const int* order;
        St* stencil;
        double* mass;
        Vec<D>* momentum;
        Vec<D>* velocity;
        Vec<D>* force;
        double* offset[D];     ///< APIC: offset_'s array of each direction (offset[d][k]; else null)
        double* scale[D];      ///< APIC + co-rotational: the frames' r (scale[d][k]; else null)
        double* massMomentum;  ///< Grid::massMomentum (P2G's sums)
    };
    PassArrays passArrays()
    {
        PassArrays a{points_.view(), schedule_.order().data(), stencils(), grid_.mass.data(),
                     grid_.momentum.data(), grid_.velocity.data(), grid_.force.data(), {}, {},
                     grid_.massMomentum.data()};
        const std::size_t n = stencil_.size();
        const bool scales = !offset_.empty() && offset_.size() > D * n;
        for (int d = 0; d < D; ++d) {
            a.offset[d] = offset_.empty() ? nullptr : offset_.data() + d * n;
            a.scale[d] = scales ? offset_.data() + (D + d) * n : nullptr;
        }
        return a;
    }
    /// Eq 27's velocity gradient at point p, from the nodal masses and velocities of A (a
    /// PassArrays, or any A with A.mass, A.velocity and the points' velocities A.P.v).
    template <class A> Mat<D> velocityGradient(const A& a, int p, const St& st) const;
    Mat<D> velocityGradient(int p, const St& st) const;
    /// The strain increment of point p (small strain); invh = 1 / h.
    void updateStrain(const PassArrays& a, int p, const St& st, double dt, double invh);
    /// The law at point p: its stress into sigma; psi+, psi- and history stored.
    void lawAt(int p, PointTensor<D>& sigma);
    /// The law at the n <= stressRun points ids (lawAt for each, or lawOfRun2 / lawOfRun3): the
    /// stress of point ids[i] into sigma[i] (the run's, not stored: MaterialPoints::stressOf).
    void lawOfRun(const int* ids, int n, PointTensor<D>* sigma);
    /// A run's lanes of the law: the damage c and the material's Lame constants of the n points
    /// ids in (lawInputs), then each point's energy c psi+ + psi- and history max(H, psi+)
    /// (Eq 22) out (storeEnergies).
    void lawInputs(const int* ids, int n, double* c, double* lambda, double* mu) const;
    double storeEnergies(int p, double c, double psiPlus, double psiMinus);  ///< returns the new history
    /// The law at n points at once, through the law's pointwise 2D response (Law.hpp).
    template <class Law> void lawOfRun2(const int* ids, int n, PointTensor<D>* sigma);
    /// The same in 3D (response3); the points it calls not ordinary through lawAt.
    template <class Law> void lawOfRun3(const int* ids, int n, PointTensor<D>* sigma);
    /// The co-rotational update's stress of point p from its deformation gradient (Kinematics.hpp).
    void corotationalStress(int p, PointTensor<D>& sigma);
    /// The co-rotational update of the n <= stressRun points ids with stencils st (point by
    /// point: F, then corotationalStress; or corotationalOfRun2, corotationalOfRun3). J[i] gets
    /// det F of point ids[i], as Eigen's determinant() of its new F gives it (the force pass's
    /// volume, scatterInternalForce); sigma[i] its stress.
    void corotationalOfRun(const int* ids, const St* st, int n, double dt, double* J, PointTensor<D>* sigma);
    /// The same for n 2D points at once, on plain numbers (Kinematics.hpp, Plain2) and the law's
    /// pointwise response: bitwise the per-point update.
    /// (`moved`: F as G2P left it, deformationInG2P; else F <- (I - dt L)^-1 F first.)
    template <class Law, bool moved>
    void corotationalOfRun2(const int* ids, const St* st, int n, double dt, double* J, PointTensor<D>* sigma);
    /// The same for n 3D points: the algebra (F, polar decomposition, Cauchy stress) in
    /// vectorised loops on plain numbers (Kinematics.hpp, Plain3), the law through its response3
    /// where the points share one (else point by point). Bitwise the per-point update.
    template <bool moved>
    void corotationalOfRun3(const int* ids, const St* st, int n, double dt, double* J, PointTensor<D>* sigma);
    /// When the n points ids share a law with the pointwise response of dimension D (Law.hpp,
    /// response2 or response3): f(law) and true; otherwise false.
    template <class F> bool withSharedPointwiseLaw(const int* ids, int n, F&& f);
    /// f_I += N_I m_p b - V sigma_p grad N_I for the point in slot k (sigma_p: the law's in this
    /// pass); V is the current volume J V_p with the co-rotational update (J: det F from
    /// corotationalOfRun), else V_p (J unused).
    template <bool withGravity, bool corotational>
    void scatterInternalForce(const PassArrays& a, int k, const PointTensor<D>& sigma, const Vec<D>& gravity, double J);
    /// f_I += N_I m_p b - vs grad N_I for point p with stencil st (vs: its stress times volume;
    /// scatterInternalForce; Stencil::forEachProjected), dv = st.dw. (Passed as an argument: read
    /// as st.dw here, GCC made the 3D default force pass 21 instructions a point longer.)
    template <bool withGravity>
    void scatterForce(const PassArrays& a, int p, const St& st, const double (*dv)[S], const Mat<D>& vs, const Vec<D>& gravity);
    // The internal force where G2P moves F (deformationInG2P) is -V sigma D_p^-1 (x_I - x_p) N_I
    // instead of -V sigma grad N_I, scattered by P2G (particleToGrid). Its power on any nodal
    // velocities v_I is -V sigma : C_p with G2P's C_p = sum_I N_I v_I (x_I - x_p)^T D_p^-1: the
    // force and the update of F are one operator and its transpose (as MLS-MPM's, Hu et al.
    // 2018), so the stress does work only through the deformation it follows. (With -V sigma
    // grad N_I, the velocity modes the affine fit does not see were pushed by stresses they did
    // not strain: John-Shah's beam at the paper's resolution eroded some 15 000 points after its
    // notch crack started; doc/stability.md.)
    /// The stencil of one point computed on its own (serial stages: erosion, tractions).
    St stencilOf(int p);
    /// Maps point p's support onto the twins of this step (across the cracks, or its body's)
    /// in slot `slot` of Grid::remap.
    /// In a step, after P2G: point p's stencil from P2G (in `slot` when it is >= -1, else
    /// found by Scheduler::slotOf), else stencilOf(p) in `scratch`. Only until G2P moves the
    /// points.
    const St& stepStencil(int p, St& scratch, int slot = -2);
    void mapSupport(St& st, int p, int slot);
    /// P2G's run of the points order[begin .. end): mapSupport for each flagged in near (from
    /// Stencil::computeRun's Box), in its own slot.
    void mapRun(int begin, int end, const int* near);
    /// APIC's moment matrix diagonal of point p at its current position (Stencil::momentDiagonal).
    Vec<D> momentDiagonalAt(int p) const;
    /// f(I) for every node this process works on: all of them, or a distributed run's planes.
    template <class F> void forEachWorkNode(int nThreads, F&& f);
    /// Adds a serial stage's force f to node I; key orders it in a distributed run (NodeRecord).
    /// Inline on one process (the sum itself, no call per node); addDistributedNodeForce otherwise.
    void addNodeForce(int I, const Vec<D>& f, std::int64_t key0, std::int64_t key1)
    {
        if (!dist_) {
            grid_.force[I] += f;
            return;
        }
        addDistributedNodeForce(I, f, key0, key1);
    }
    void addDistributedNodeForce(int I, const Vec<D>& f, std::int64_t key0, std::int64_t key1);
    /// f(point, position in the list) for every point of traction condition t on this process.
    template <class F> void forEachTractionPoint(std::size_t t, F&& f) const;
    /// The node range [lo, hi) a distributed run's rank owns (sums over nodes count it once).
    void ownedNodes(int& lo, int& hi) const;

    SolverSettings settings_;
    double lp_;  ///< particle half-width in cells, 1/(2 ppc)
    MaterialPoints<D> points_;
    std::vector<ElasticMaterial> materials_;
    int stepLaw_ = -1;  ///< in the stress pass: the law of every material, or -1 when they differ
    Grid<D> grid_;
    bool haveDomain_ = false, initialized_ = false;
    Vec<D> domainLo_, domainHi_;
    double massCutoffAbs_ = 0;
    std::shared_ptr<EigenErosion<D>> erosion_;
    std::shared_ptr<BodyContact<D>> contact_;
    std::shared_ptr<CrackFaceContact<D>> crackContact_;
    /// The points' supports for the conditions (GridState::support).
    class Support : public PointSupport<D> {
    public:
        explicit Support(Solver* s) : s_(s) {}
        void forEachNode(int p, const std::function<void(int, double)>& f) const override
        {
            const St st = s_->stencilOf(p);
            st.forEach(s_->grid_, [&](int I, double N, const Vec<D>&) { f(I, N); });
        }
        double halfWidth() const override { return s_->lp_ * s_->settings_.h; }
        /// From this step's binning (the points have not moved since): the strips that can hold
        /// a point of those rows, their sorted runs merged.
        void pointsInRows(int lo, int hi, std::vector<int>& ids) const override;

    private:
        Solver* s_;
    };
    PhantomNodes<D> phantom_;
    int markedLo_[D] = {}, markedHi_[D] = {};  ///< box of the marked nodes, node indices
    /// How supports map onto twins in this step: 0 not at all, 1 across cracks, 2 by body.
    int mapping_ = 0;
    BodyFieldContact<D> bodyContact_;
    std::vector<std::uint64_t> bodyReach_;  ///< per regular node: a bit per body whose points reach it
    std::vector<std::shared_ptr<VelocityCondition<D>>> velocityConditions_;
    std::vector<std::shared_ptr<GridCondition<D>>> conditions_;
    std::vector<TractionCondition> tractions_;
    Scheduler<D> schedule_;
    std::vector<St> stencil_;  ///< stencil_[k] is that of point schedule_.order()[k] in this step
    /// APIC: the offsets b[d] of P2G's frame (Stencil::AffineFrame) of the point in slot k, at
    /// offset_[d * n + k] for n points (one array per direction, which computeRun's lanes write
    /// as they are), read by G2P (the point has not moved since); empty with FLIP. With the
    /// co-rotational update too (deformationInG2P), the frames' r[d] follow, at
    /// offset_[(D + d) * n + k], for G2P's C_p.
    std::vector<double> offset_;
    /// deformationInG2P: V sigma, the stress of the point in slot k times its current volume
    /// V = J V_0 (stressBeforeTransfer, then erosion), for P2G's force; empty otherwise.
    /// slotStride numbers a slot: V sigma's symmetric part (2D xx, xy, yy; 3D xx, yy, zz, xy, xz,
    /// yz), the products P2G took of a slot holding sigma and V until session 51 (toSlot,
    /// slotMatrix): 8 bytes and D (D + 1) / 2 products a point fewer, the same numbers.
    std::vector<double> slotStress_;
    static constexpr int slotStride = D * (D + 1) / 2;
    /// Stores V sigma's symmetric part in a slot of slotStress_ (3D: V times 0.5 (a_ij + a_ji)
    /// off the diagonal).
    static void toSlot(const PointTensor<D>& sigma, double V, double* slot)
    {
        if constexpr (D == 2) {
            slot[0] = V * sigma.xx, slot[1] = V * sigma.xy, slot[2] = V * sigma.yy;
        } else {
            for (int d = 0; d < 3; ++d) slot[d] = V * sigma(d, d);
            slot[3] = V * (0.5 * (sigma(0, 1) + sigma(1, 0)));
            slot[4] = V * (0.5 * (sigma(0, 2) + sigma(2, 0)));
            slot[5] = V * (0.5 * (sigma(1, 2) + sigma(2, 1)));
        }
    }
    /// V sigma from a slot of slotStress_.
    static Mat<D> slotMatrix(const double* slot)
    {
        Mat<D> m;
        if constexpr (D == 2)
            m << slot[0], slot[1], slot[1], slot[2];
        else
            m << slot[0], slot[3], slot[4], slot[3], slot[1], slot[5], slot[4], slot[5], slot[2];
        return m;
    }
    std::shared_ptr<Distribution<D>> dist_;
    GhostPoints<D> ghosts_;
    std::vector<std::uint64_t> rowMarks_;  ///< Support::pointsInRows' bitmap by point id (zero between calls)
    std::vector<int> tractionSlots_;  ///< this step's slot of each traction point (tractionForces' order)
    std::vector<int> twinRegular_;  ///< the regular node of each crack twin (distributed)
    bool heldSetup_ = false;        ///< distributed at set-up (distributeSetup)
    int globalPoints_ = 0;          ///< the whole scene's points (distributed)
    int nextId_ = 0, heldEnd_ = 0;  ///< ids of the points holdPoints announced
    /// A rank's part loaded from an archive (loadState): its rank, the ranks and their strips.
    int resumeRank_ = 0, resumeRanks_ = 1;
    std::vector<int> resumeStrips_, resumeColumns_;
    int rankColumns_ = 1;  ///< columns of ranks along the first axis (distribute)
    double rebalanceTolerance_ = 1.25;
    int rebalancePeriod_ = 100, rebalances_ = 0;
    std::vector<NodeRecord<D>> recordsLeft_, recordsRight_;
    std::vector<std::vector<std::pair<int, int>>> tractionLocal_;  ///< per traction: (point, position) here
    std::vector<double> workBefore_;  ///< velocity conditions' work before this step (distributed)
    double workAtStart_[2] = {0, 0};  ///< traction and gravity work before this step
    double time_ = 0, maxSpeed_ = 0;
    /// Set (to 1) by the stress pass of a step when a point's stress is not finite: G2P's check
    /// then names the point. (Checked where the stress is in the cache: G2P reading every point's
    /// stress again for its check cost the 2D step 4 %, doc/performance.md "Session 38".)
    int stressNonFinite_ = 0;
    StressObserver stressObserver_;  ///< observeStresses
    double kineticAtStep_ = 0, tractionWork_ = 0, gravityWork_ = 0, contactWork_ = 0;
    std::int64_t steps_ = 0;
};

}  // namespace emp
