#include "Solver.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <sstream>

#include "Errors.hpp"

namespace emp {

namespace {

template <int D> std::string str(const Vec<D>& v)
{
    std::ostringstream s;
    s.precision(8);
    s << "(";
    for (int d = 0; d < D; ++d) s << (d ? ", " : "") << v[d];
    s << ")";
    return s.str();
}

}  // namespace

template <int D, class K>
void Solver<D, K>::Stencil::compute(const Vec<D>& x, const Grid<D>& g, double lp)
{
    for (int d = 0; d < D; ++d) base[d] = K::eval((x[d] - g.origin[d]) * g.invh, lp, w[d], dw[d]);
    remap = -1;
}

// Forced inline (GCC/Clang): called per point in every pass, it must merge with the pass's
// body so that the sums over the nodes stay in registers; left to itself, GCC's inliner keeps
// some instantiations out of line in this large translation unit (about 20% slower).
#if defined(__GNUC__)
#define EMP_ALWAYS_INLINE __attribute__((always_inline)) inline
#else
#define EMP_ALWAYS_INLINE inline
#endif

template <int D, class K>
template <class F>
EMP_ALWAYS_INLINE void Solver<D, K>::Stencil::forEach(const Grid<D>& g, F&& f) const
{
    // Node indices: from the base node, or near a pre-existing crack from the remap table
    // (phantom twins). Gathering them first keeps one copy of f's body, so that the compiler
    // inlines forEach and f into each pass and keeps the pass's sums in registers.
    int node[NS];
    for (int k = 0; k < NS; ++k) {
        if (remap >= 0) {
            node[k] = g.remap[remap + k];
        } else {
            const int i = k % S, j = (k / S) % S;
            node[k] = base[0] + i + (base[1] + j) * g.stride[1];
            if constexpr (D == 3) node[k] += (base[2] + k / (S * S)) * g.stride[2];
        }
    }
    if constexpr (D == 2) {
        for (int j = 0; j < S; ++j)
            for (int i = 0; i < S; ++i)
                f(node[i + S * j], w[0][i] * w[1][j], Vec<2>(dw[0][i] * w[1][j] * g.invh, w[0][i] * dw[1][j] * g.invh));
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

template <int D, class K>
void Solver<D, K>::Stencil::mapAcrossCracks(const Vec<D>& x, Grid<D>& g, const PhantomNodes<D>& ph, int slot)
{
    // Phantom-node rule (Section 3.3.1): a marked node is replaced by its twin when the segment
    // from the point to the node crosses the crack.
    int node[NS];
    bool any = false;
    int k = 0;
    if constexpr (D == 2) {
        for (int j = 0; j < S; ++j)
            for (int i = 0; i < S; ++i, ++k) {
                node[k] = base[0] + i + (base[1] + j) * g.stride[1];
                any = any || ph.marked(node[k]);
            }
    } else {
        for (int kk = 0; kk < S; ++kk)
            for (int j = 0; j < S; ++j)
                for (int i = 0; i < S; ++i, ++k) {
                    node[k] = base[0] + i + (base[1] + j) * g.stride[1] + (base[2] + kk) * g.stride[2];
                    any = any || ph.marked(node[k]);
                }
    }
    if (!any) return;
    for (k = 0; k < NS; ++k)
        if (ph.marked(node[k])) node[k] = ph.map(x, node[k], g.nodePosition(node[k]));
    remap = slot * NS;
    std::copy(node, node + NS, &g.remap[remap]);
}

template <int D, class K> Solver<D, K>::Solver(const SolverSettings& s) : settings_(s)
{
    require(std::isfinite(s.h) && s.h > 0, "h (cell size, m)", s.h, "h > 0");
    require(s.ppc >= 1 && s.ppc <= 64, "ppc (points per cell per direction)", s.ppc, "1 <= ppc <= 64");
    require(s.massCutoff >= 0 && s.massCutoff < 1, "massCutoff (fraction of the mean point mass)",
            s.massCutoff, "0 <= massCutoff < 1");
    require(s.padding >= 1, "padding (cells)", s.padding, "padding >= 1");
    require(s.gravity.allFinite(), "gravity (m/s2)", "non-finite", "finite components");
    lp_ = 0.5 / s.ppc;
}

template <int D, class K>
int Solver<D, K>::addMaterial(double E, double nu, double rho, bool planeStress)
{
    materials_.push_back(ElasticMaterial::make(E, nu, rho, planeStress, D));
    return static_cast<int>(materials_.size()) - 1;
}

template <int D, class K>
int Solver<D, K>::addPoint(const Eigen::Vector3d& x, const Eigen::Vector3d& v, double volume, int material)
{
    const int id = static_cast<int>(points_.size());
    // The messages are built only on failure: this runs once per point of a scene.
    if (!(material >= 0 && material < static_cast<int>(materials_.size())))
        require(false, "material (id)", material,
                "0 <= material < " + std::to_string(materials_.size()) + " (ids returned by addMaterial)");
    if (!(std::isfinite(volume) && volume > 0))
        require(false, "volume of point " + std::to_string(id) + " (m^dim)", volume, "volume > 0");
    if (!x.head<D>().allFinite())
        require(false, "position of point " + std::to_string(id), "non-finite", "finite coordinates");
    if (!v.head<D>().allFinite())
        require(false, "velocity of point " + std::to_string(id), "non-finite", "finite components");
    if (initialized_) {
        const Vec<D> xd = x.head<D>();
        for (int d = 0; d < D; ++d) {
            const int b = K::base((xd[d] - grid_.origin[d]) * grid_.invh);
            if (b < 0 || b > grid_.n[d] - S)
                throw SimulationError("EigenMPM: point " + std::to_string(id) + " at " + str<D>(xd) +
                                      " is outside the grid, which already exists; add points before "
                                      "the first step or give a larger domain");
        }
    }
    points_.add(x.head<D>(), v.head<D>(), materials_[material].rho * volume, volume, material);
    return id;
}

template <int D, class K>
void Solver<D, K>::setDomain(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi)
{
    require(!initialized_, "domain", "set after the grid was built", "set the domain before the first step");
    for (int d = 0; d < D; ++d)
        require(std::isfinite(lo[d]) && std::isfinite(hi[d]) && hi[d] > lo[d],
                "domain extent in direction " + std::to_string(d), hi[d] - lo[d], "hi > lo, finite");
    domainLo_ = lo.head<D>();
    domainHi_ = hi.head<D>();
    haveDomain_ = true;
}

template <int D, class K> void Solver<D, K>::initialize()
{
    if (initialized_) return;
    const double h = settings_.h;
    Vec<D> lo, hi;
    int pad = 0;
    if (haveDomain_) {
        lo = domainLo_;
        hi = domainHi_;
    } else if (points_.size() > 0) {
        lo = hi = points_.x[0];
        for (const auto& x : points_.x) {
            lo = lo.cwiseMin(x);
            hi = hi.cwiseMax(x);
        }
        pad = settings_.padding;
    } else {
        lo.setZero();
        hi.setConstant(h);
        pad = settings_.padding;
    }
    Vec<D> origin;
    std::array<int, D> n;
    for (int d = 0; d < D; ++d) {
        const long first = static_cast<long>(std::floor(lo[d] / h)) - pad;
        const long last = static_cast<long>(std::ceil(hi[d] / h)) + pad;
        origin[d] = first * h;
        n[d] = static_cast<int>(std::max<long>(last - first + 1, S));
    }
    long total = 1;
    for (int d = 0; d < D; ++d) total *= n[d];
    require(total < (1L << 31) / 4, "number of grid nodes", total,
            "< 5.3e8 (give a smaller domain or a larger h)");
    grid_.resize(origin, h, n);
    for (std::size_t p = 0; p < points_.size(); ++p)
        for (int d = 0; d < D; ++d) {
            const int b = K::base((points_.x[p][d] - origin[d]) * grid_.invh);
            if (b < 0 || b > n[d] - S)
                throw SimulationError("EigenMPM: point " + std::to_string(p) + " at " +
                                      str<D>(points_.x[p]) + " lies outside the domain or too close "
                                      "to its edge (the shape function needs nodes around it); "
                                      "enlarge the domain by at least " + std::to_string(S - 1) + " h");
        }
    double meanMass = 0;
    for (double m : points_.mass) meanMass += m;
    if (points_.size() > 0) meanMass /= points_.size();
    massCutoffAbs_ = settings_.massCutoff * meanMass;
    initialized_ = true;
}

template <int D, class K>
int Solver<D, K>::addVelocityCondition(const std::vector<int>& nodes, const std::vector<int>& points,
                                       unsigned mask, const Eigen::Vector3d& velocity, double rampTime)
{
    initialize();
    for (int I : nodes)
        require(I >= 0 && I < grid_.numNodes(), "node index", I,
                "0 <= node < " + std::to_string(grid_.numNodes()));
    for (int p : points)
        require(p >= 0 && p < static_cast<int>(points_.size()), "point id", p,
                "0 <= id < " + std::to_string(points_.size()));
    require(mask != 0 && mask < (1u << D), "components (bit mask)", mask,
            "1 .. " + std::to_string((1u << D) - 1) + " (at least one direction)");
    require(velocity.head<D>().allFinite(), "velocity", "non-finite", "finite components");
    require(std::isfinite(rampTime) && rampTime >= 0, "rampTime (s)", rampTime, "rampTime >= 0");
    VelocityCondition c;
    c.nodes = nodes;
    c.points = points;
    c.mask = mask;
    c.velocity = velocity;
    c.rampTime = rampTime;
    velocityConditions_.push_back(std::move(c));
    return static_cast<int>(velocityConditions_.size()) - 1;
}

template <int D, class K>
void Solver<D, K>::setConditionVelocity(int id, const Eigen::Vector3d& velocity, double rampTime)
{
    require(id >= 0 && id < static_cast<int>(velocityConditions_.size()), "condition id", id, "an existing id");
    require(velocity.head<D>().allFinite(), "velocity", "non-finite", "finite components");
    velocityConditions_[id].velocity = velocity;
    velocityConditions_[id].rampTime = rampTime;
}

template <int D, class K>
int Solver<D, K>::addTraction(const std::vector<int>& points, const Eigen::Vector3d& traction,
                              double rampTime, double layer)
{
    for (int p : points)
        require(p >= 0 && p < static_cast<int>(points_.size()), "point id", p,
                "0 <= id < " + std::to_string(points_.size()));
    require(traction.head<D>().allFinite(), "traction (Pa)", "non-finite", "finite components");
    require(std::isfinite(rampTime) && rampTime >= 0, "rampTime (s)", rampTime, "rampTime >= 0");
    require(std::isfinite(layer) && layer > 0, "layer (boundary layer thickness, m)", layer, "layer > 0");
    tractions_.push_back({points, traction, rampTime, layer});
    return static_cast<int>(tractions_.size()) - 1;
}

template <int D, class K> double Solver<D, K>::criticalTimeStep() const
{
    double c = 0;
    for (const auto& m : materials_) c = std::max(c, m.waveSpeed());
    double vmax = maxSpeed_;
    if (steps_ == 0)
        for (const auto& v : points_.v) vmax = std::max(vmax, v.norm());
    if (c + vmax <= 0) return std::numeric_limits<double>::infinity();
    return settings_.h / (c + vmax);
}

template <int D, class K> void Solver<D, K>::binPoints(int nThreads)
{
    // Counting sort of the point ids by strip along the last axis. Stable, so the order of the
    // contributions to every node is fixed whatever the thread count: results are bitwise
    // independent of it. A point off the grid (moved there by the user, or left there by a
    // step that stopped with an error) would write outside the nodal arrays: refused here.
    const int last = D - 1;
    const int numStrips = (grid_.n[last] - S) / stripWidth + 1;
    const int np = static_cast<int>(points_.size());
    const Grid<D>& g = grid_;
    stripOf_.resize(np);
    int firstOffGrid = INT_MAX;
#pragma omp parallel for schedule(static) num_threads(nThreads) reduction(min : firstOffGrid)
    for (int p = 0; p < np; ++p) {
        int b = 0;
        for (int d = 0; d < D; ++d) {
            b = K::base((points_.x[p][d] - g.origin[d]) * g.invh);
            if (!(b >= 0 && b <= g.n[d] - S)) {
                firstOffGrid = std::min(firstOffGrid, p);
                b = 0;
                break;
            }
        }
        stripOf_[p] = b / stripWidth;  // b is now the base node along the last axis
    }
    if (firstOffGrid != INT_MAX) {
        Vec<D> hiCorner;
        for (int d = 0; d < D; ++d) hiCorner[d] = g.origin[d] + (g.n[d] - 1) * g.h;
        std::ostringstream s;
        s << "EigenMPM: point id " << firstOffGrid << " at " << str<D>(points_.x[firstOffGrid])
          << " is off the grid (nodes span " << str<D>(g.origin) << " to " << str<D>(hiCorner)
          << ") at the start of step " << steps_ + 1 << "; move it back or give a larger domain";
        throw SimulationError(s.str());
    }
    stripStart_.assign(numStrips + 1, 0);
    for (int p = 0; p < np; ++p) ++stripStart_[stripOf_[p] + 1];
    for (int s = 0; s < numStrips; ++s) stripStart_[s + 1] += stripStart_[s];
    order_.resize(np);
    stripFill_.assign(stripStart_.begin(), stripStart_.end() - 1);
    for (int p = 0; p < np; ++p) order_[stripFill_[stripOf_[p]]++] = p;
}

template <int D, class K>
template <class F>
void Solver<D, K>::scatter(int nThreads, F&& perPoint)
{
    // Strips of one colour are at least one strip apart and never write the same node.
    const int numStrips = static_cast<int>(stripStart_.size()) - 1;
    for (int colour = 0; colour < 2; ++colour) {
#pragma omp parallel for schedule(dynamic, 1) num_threads(nThreads)
        for (int s = colour; s < numStrips; s += 2)
            for (int k = stripStart_[s]; k < stripStart_[s + 1]; ++k) perPoint(k);
    }
}

template <int D, class K>
void Solver<D, K>::applyVelocityConditions(double t, bool afterForces, double dt)
{
    for (auto& c : velocityConditions_) {
        if (!afterForces) {
            c.active = c.nodes;
            for (int p : c.points) {
                const int I = grid_.nearestNode(points_.x[p]);
                if (I >= 0) c.active.push_back(I);
            }
            std::sort(c.active.begin(), c.active.end());
            c.active.erase(std::unique(c.active.begin(), c.active.end()), c.active.end());
        }
        const Eigen::Vector3d vbar = c.value(t);
        if (afterForces) c.reaction.setZero();
        auto constrain = [&](int I) {
            for (int d = 0; d < D; ++d) {
                if (!(c.mask & (1u << d))) continue;
                const double m = grid_.mass[I];
                if (afterForces) {
                    // Force that makes the node reach the prescribed momentum; the reaction is
                    // what it adds to the internal and external forces.
                    const double applied = (m * vbar[d] - grid_.momentum[I][d]) / dt;
                    c.reaction[d] += applied - grid_.force[I][d];
                    grid_.force[I][d] = applied;
                } else {
                    grid_.momentum[I][d] = m * vbar[d];
                    grid_.velocity[I][d] = m > 0 ? vbar[d] : 0.0;
                }
            }
        };
        // A condition holds at a location: it applies to the phantom twins of its nodes too.
        for (int I : c.active) {
            constrain(I);
            phantom_.forEachTwin(I, constrain);
        }
    }
}

template <int D, class K> bool Solver<D, K>::nearMarked(const Stencil& st) const
{
    for (int d = 0; d < D; ++d)
        if (st.base[d] > markedHi_[d] || st.base[d] + S - 1 < markedLo_[d]) return false;
    return true;
}

template <int D, class K> int Solver<D, K>::addCrack(const std::vector<Eigen::Vector3d>& vertices)
{
    std::vector<Vec<D>> v;
    for (const auto& p : vertices) v.push_back(p.head<D>());
    return phantom_.addCrack(v);
}

template <int D, class K> void Solver<D, K>::advectCracks(double dt)
{
    // Crack vertices move with the material: the mass-weighted grid velocity around the vertex,
    // sum N (P_I + P_twins) / sum N (m_I + m_twins), i.e. the mean motion of both faces. Weighting
    // by mass keeps it bounded where a vertex sits among nearly empty nodes.
    // A vertex not fully inside the material (a node of its stencil has no mass, or the stencil
    // leaves the grid: the outer end of an edge crack, the ends of a through crack) has no
    // velocity of its own, or one biased towards the material's interior. It moves with the
    // linear velocity field fitted (mass-weighted least squares) to the nodes around the crack,
    // so that a translating or rotating body carries the whole crack rigidly with it.
    const auto& g = grid_;
    auto sample = [&](const Vec<D>& x, double& m, Vec<D>& mom) {
        m = 0;
        mom.setZero();
        for (int d = 0; d < D; ++d) {
            const int b = K::base((x[d] - g.origin[d]) * g.invh);
            if (b < 0 || b > g.n[d] - S) return false;
        }
        Stencil st;
        st.compute(x, g, lp_);
        bool full = true;
        st.forEach(g, [&](int I, double N, const Vec<D>&) {
            double mI = g.mass[I];
            Vec<D> pI = g.momentum[I];
            phantom_.forEachTwin(I, [&](int t) {
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
    for (std::size_t c = 0; c < phantom_.numCracks(); ++c) {
        auto& verts = phantom_.vertices(static_cast<int>(c));
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
            for (int I : phantom_.markedNodes()) {
                if (phantom_.twin(static_cast<int>(c), I) < 0) continue;
                double m = g.mass[I];
                Vec<D> p = g.momentum[I];
                phantom_.forEachTwin(I, [&](int t) {
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

template <int D, class K> void Solver<D, K>::step(double dt, int nThreads)
{
    require(std::isfinite(dt) && dt > 0, "dt (time step, s)", dt, "0 < dt <= critical time step");
    initialize();
    const double dtCrit = criticalTimeStep();
    if (dt > dtCrit) {
        std::ostringstream s;
        s.precision(6);
        s << "EigenMPM: dt = " << dt << " s is above the critical time step; allowed: 0 < dt <= "
          << dtCrit << " s (h / (wave speed + max point speed)); set O.dt = fraction * "
          << "eigenmpm.criticalTimeStep() with a fraction <= 1";
        throw ParameterError(s.str());
    }
    nThreads = std::max(1, nThreads);
    const int np = static_cast<int>(points_.size());
    auto& P = points_;
    auto& g = grid_;
    const double lp = lp_;

    binPoints(nThreads);
    stencil_.resize(np);
    const bool cracks = !phantom_.empty();
    if (cracks) {
        // Marked nodes and their twins for the cracks' current position (Section 3.3.1); uGIMP's
        // wider support marks one more ring of cells.
        g.setTwins(phantom_.update(g, S == 3 ? 1 : 0));
        // Box (in node indices) of the marked nodes: points whose support lies outside it skip
        // the per-node test, so the cost follows the marked region.
        for (int d = 0; d < D; ++d) {
            markedLo_[d] = INT_MAX;
            markedHi_[d] = INT_MIN;
        }
        for (int I : phantom_.markedNodes()) {
            int r = I;
            for (int d = D - 1; d >= 0; --d) {
                const int i = r / g.stride[d];
                r -= i * g.stride[d];
                markedLo_[d] = std::min(markedLo_[d], i);
                markedHi_[d] = std::max(markedHi_[d], i);
            }
        }
        g.remap.resize(static_cast<std::size_t>(np + 1) * Stencil::NS);  // + a scratch slot
    }
    const int nAll = g.totalNodes();
#pragma omp parallel for schedule(static) num_threads(nThreads)
    for (int I = 0; I < nAll; ++I) {
        g.mass[I] = 0;
        g.momentum[I].setZero();
        g.force[I].setZero();
    }

    // (2) P2G: nodal mass (Eq 12) and momentum P^{n-1/2} (Eq 25). The shape functions (15)
    // are evaluated here once per point and kept for stages (5)-(6) and (8).
    scatter(nThreads, [&](int k) {
        const int p = order_[k];
        Stencil& st = stencil_[k];
        st.compute(P.x[p], g, lp);
        if (cracks && nearMarked(st)) st.mapAcrossCracks(P.x[p], g, phantom_, k);
        const double mp = P.mass[p];
        const Vec<D> mv = mp * P.v[p];
        st.forEach(g, [&](int I, double N, const Vec<D>&) {
            g.mass[I] += N * mp;
            g.momentum[I] += N * mv;
        });
    });

    // (3)-(4) Nodal velocity (Eq 26) with the small-mass cut-off, then essential conditions.
    const double cut = massCutoffAbs_;
#pragma omp parallel for schedule(static) num_threads(nThreads)
    for (int I = 0; I < nAll; ++I) {
        // v_I = P_I / m_I is a mass-weighted mean of point velocities, bounded however light the
        // node: no cut-off here, or the gradients in Eq 27 would stop summing to zero and a rigid
        // motion would strain. The cut-off applies where a force is divided by the mass.
        g.invMass[I] = g.mass[I] > cut && g.mass[I] > 0 ? 1.0 / g.mass[I] : 0.0;
        g.velocity[I] = g.mass[I] > 0 ? Vec<D>(g.momentum[I] / g.mass[I]) : Vec<D>::Zero();
    }
    applyVelocityConditions(std::max(time_ - 0.5 * dt, 0.0), false, dt);

    // (5) Strain increment (Eq 27), stress by the spectral split (Eqs 2-7) with g(c) = c,
    // psi+/psi- (3, 4) and history H (22); (6) internal force (13) and body force (14).
    const Vec<D> gravity = settings_.gravity.head<D>();
    auto updateStress = [&](int p, const Stencil& st) {
        Mat<D> L = Mat<D>::Zero();
        if constexpr (K::S == 2) {
            // The linear hat has a kink at the nodes: a point exactly on a node has weight 0 but
            // gradient +-1/h on the next node, which can be empty (velocity unknown, set to 0) at
            // a free face, and a rigid motion would strain. Such a node takes the point's own
            // velocity, so that the gradients still sum to zero. (uGIMP's gradient vanishes with
            // its weight, so it never meets an empty node with a nonzero gradient.)
            const Vec<D> vp = P.v[p];
            st.forEach(g, [&](int I, double, const Vec<D>& grad) {
                L.noalias() += (g.mass[I] > 0 ? g.velocity[I] : vp) * grad.transpose();
            });
        } else {
            st.forEach(g, [&](int I, double, const Vec<D>& grad) { L.noalias() += g.velocity[I] * grad.transpose(); });
        }
        Mat<D>& eps = P.strain[p];
        eps += (0.5 * dt) * (L + L.transpose());
        const ElasticMaterial& m = materials_[P.material[p]];
        const SplitState<D> sp = spectralSplit<D>(eps, m.lambda, m.mu);
        P.stress[p] = P.damage[p] * sp.sigmaPlus + sp.sigmaMinus;
        P.psiPlus[p] = sp.psiPlus;
        P.psiMinus[p] = sp.psiMinus;
        P.history[p] = std::max(P.history[p], sp.psiPlus);
    };
    auto scatterForce = [&](int p, const Stencil& st) {
        const Mat<D> vs = P.volume[p] * P.stress[p];
        const Vec<D> fb = P.mass[p] * gravity;
        st.forEach(g, [&](int I, double N, const Vec<D>& grad) { g.force[I] += N * fb - vs * grad; });
    };
    scatter(nThreads, [&](int k) {
        updateStress(order_[k], stencil_[k]);
        scatterForce(order_[k], stencil_[k]);
    });
    if (erosion_ && erosion_->apply(P, materials_, steps_ + 1, time_ + dt, nThreads) > 0) {
        // (5.iv) Eigenerosion (Eqs 23-24) belongs between the stress update and the internal
        // force, so that an eroded point acts with sigma- alone in this step already. The force
        // is linear in the stress: the eroded points' change of stress is scattered as a
        // correction, serially in the erosion order, instead of a separate pass over all points.
        const auto& eroded = erosion_->lastEroded();
        const auto& before = erosion_->stressBeforeErosion();
        for (std::size_t e = 0; e < eroded.size(); ++e) {
            const int p = eroded[e];
            Stencil st;
            st.compute(P.x[p], g, lp);
            if (cracks) st.mapAcrossCracks(P.x[p], g, phantom_, np);
            const Mat<D> dvs = P.volume[p] * (P.stress[p] - before[e]);
            st.forEach(g, [&](int I, double, const Vec<D>& grad) { g.force[I] -= dvs * grad; });
        }
    }
    // Traction on boundary points (Eq 28); few points, applied serially in a fixed order.
    for (const auto& tc : tractions_) {
        const Vec<D> t = (rampFactor(time_, tc.rampTime) * tc.traction).head<D>();
        for (int p : tc.points) {
            Stencil st;
            st.compute(P.x[p], g, lp);
            if (cracks) st.mapAcrossCracks(P.x[p], g, phantom_, np);
            const Vec<D> f = t * (P.volume[p] / tc.layer);
            st.forEach(g, [&](int I, double N, const Vec<D>&) { g.force[I] += N * f; });
        }
    }

    // (7) Nodal momentum P^{n+1/2} (Eq 29) with the essential conditions and their reactions;
    // the grid then holds the nodal acceleration (for Eq 30) and velocity (for Eq 31).
    applyVelocityConditions(time_ + 0.5 * dt, true, dt);
#pragma omp parallel for schedule(static) num_threads(nThreads)
    for (int I = 0; I < nAll; ++I) {
        g.momentum[I] += dt * g.force[I];
        g.velocity[I] = g.momentum[I] * g.invMass[I];
        g.force[I] *= g.invMass[I];
    }

    // (8) G2P: FLIP velocity update (Eq 30) and position from nodal momentum (Eq 31). Each
    // point writes only itself; the loop runs in the binned order to stream the stencils.
    int firstNonFinite = INT_MAX, firstOffGrid = INT_MAX;
    double vmax2 = 0;
#pragma omp parallel for schedule(static) num_threads(nThreads) \
    reduction(min : firstNonFinite, firstOffGrid) reduction(max : vmax2)
    for (int k = 0; k < np; ++k) {
        const int p = order_[k];
        const Stencil& st = stencil_[k];
        Vec<D> a = Vec<D>::Zero(), vg = Vec<D>::Zero();
        st.forEach(g, [&](int I, double N, const Vec<D>&) {
            a += N * g.force[I];
            vg += N * g.velocity[I];
        });
        P.v[p] += dt * a;
        P.x[p] += dt * vg;
        if (!P.v[p].allFinite() || !P.x[p].allFinite() || !P.stress[p].allFinite()) {
            firstNonFinite = std::min(firstNonFinite, p);
            continue;
        }
        for (int d = 0; d < D; ++d) {
            const int b = K::base((P.x[p][d] - g.origin[d]) * g.invh);
            if (b < 0 || b > g.n[d] - S) firstOffGrid = std::min(firstOffGrid, p);
        }
        vmax2 = std::max(vmax2, P.v[p].squaredNorm());
    }
    if (cracks) advectCracks(dt);
    maxSpeed_ = std::sqrt(vmax2);
    time_ += dt;
    ++steps_;
    if (firstNonFinite != INT_MAX) {
        std::ostringstream s;
        s << "EigenMPM: a non-finite value appeared in step " << steps_ << " (t = " << time_
          << " s) at point id " << firstNonFinite << " (stress, velocity or position is NaN or "
          << "infinite); check the loads, the material constants and dt";
        throw SimulationError(s.str());
    }
    if (firstOffGrid != INT_MAX) {
        Vec<D> hiCorner;
        for (int d = 0; d < D; ++d) hiCorner[d] = g.origin[d] + (g.n[d] - 1) * g.h;
        std::ostringstream s;
        s << "EigenMPM: point id " << firstOffGrid << " left the grid in step " << steps_ << " (t = "
          << time_ << " s): position " << str<D>(P.x[firstOffGrid]) << ", grid nodes span "
          << str<D>(g.origin) << " to " << str<D>(hiCorner)
          << "; give a larger domain (the point is kept, the run stops)";
        throw SimulationError(s.str());
    }
}

template <int D, class K> double Solver<D, K>::kineticEnergy() const
{
    double e = 0;
    for (std::size_t p = 0; p < points_.size(); ++p) e += 0.5 * points_.mass[p] * points_.v[p].squaredNorm();
    return e;
}

template <int D, class K> double Solver<D, K>::elasticEnergy() const
{
    double e = 0;
    for (std::size_t p = 0; p < points_.size(); ++p)
        e += points_.volume[p] * (points_.damage[p] * points_.psiPlus[p] + points_.psiMinus[p]);
    return e;
}

template class Solver<2, LinearKernel>;
template class Solver<2, GimpKernel>;
template class Solver<3, LinearKernel>;
template class Solver<3, GimpKernel>;

}  // namespace emp
