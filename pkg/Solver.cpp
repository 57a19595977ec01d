#include "Solver.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <climits>
#include <cstring>
#include <cmath>
#include <limits>
#include <mutex>
#include <sstream>
#include <type_traits>

#include "CrackTransport.hpp"
#include "Errors.hpp"
#include "Lanes.hpp"
#include "Laws.hpp"

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

// =============================================================================================
// One explicit step (paper Section 4.1, update-stress-first central difference). Each stage is
// a member function below, in this order. The stress update and the internal force share one
// pass over the points (they are separate functions, fused in the pass because the stencil is
// then read once: measured in bench/bench_block); erosion corrects the force it already
// scattered for the points it erodes.
// With APIC and the co-rotational update together (deformationInG2P), G2P of the last step has
// moved F already, so the stresses are known before P2G: they are made first (stressBeforeTransfer),
// erosion follows, and P2G scatters the internal and body forces with the mass and momentum, through
// the same affine sums (MLS-MPM's fused transfer, Hu et al. 2018): one scatter a step instead of two.
// =============================================================================================
template <int D, class K> void Solver<D, K>::step(double dt, int nThreads)
{
    nThreads = std::max(1, nThreads);
    checkTimeStep(dt);                     // dt <= h / (c + v_max)
    distributePoints();                    //     a distributed run's points: partition, migration
    schedulePoints(nThreads);              // binning and colouring (Scheduler)
    markCrackedNodes();                    // phantom nodes for the cracks' position (3.3.1)
    markBodyNodes();                       //     or a field per body where bodies meet
    lastStepPipelined_ = pipelineable(nThreads);
    if (lastStepPipelined_) {
        // The same stages as below, as a wavefront over the strips (pipelineLoop): (1), (2),
        // the conditions, (3), (5), the grid update and (6) follow each other a few strips
        // apart, each strip's stencils in its worker's ring instead of stencil_.
        // (kept after a step with sources: the next has them too, and may need the overflow)
        if (!stencil_.empty() && !(erosion_ && erosion_->searchedLastStep())) std::vector<St>().swap(stencil_);
        StripPasses passes;
        passes.dt = dt;
        passes.threads = nThreads;
        strips_ = &passes;
        try {
            clearGrid(nThreads);
            startStressPass();
            particleToGrid(nThreads);  // (which runs the others: StripPasses)
        } catch (...) {
            strips_ = nullptr;
            throw;
        }
        strips_ = nullptr;
        transportCracks(dt);
        return;
    }
    stencil_.resize(points_.size());
    const bool fused = deformationInG2P();
    if (fused) {
        stressBeforeTransfer(dt, nThreads);// (3) with APIC + co-rotational: the stresses from F
        erode(dt, nThreads);               // (4) eigenerosion, Eqs 23-24, 33, before the force
    }
    clearGrid(nThreads);
    particleToGrid(nThreads);              // (1) nodal mass and momentum, Eqs 12, 25 (fused: and (5))
    bodyGradients();                       //     the bodies' normals at the nodes they share
    nodalVelocity(nThreads);               // (2) nodal velocity, Eq 26
    applyConditionsAfterVelocity(dt);      //     essential conditions (GridCondition)
    if (!fused) {
        stressAndInternalForce(dt, nThreads);  // (3) strain increment, split, history, Eqs 27, 2-7, 21-22
                                               // (5) internal and body force, Eqs 13-14
        erode(dt, nThreads);                   // (4) eigenerosion, Eqs 23-24, 33
    }
    tractionForces();                      // (5) traction, Eq 28
    if (dist_) dist_->applyRecords(recordsLeft_, recordsRight_, {grid_.force.data()->data(), D});
    applyConditionsAfterForces(dt);        //     conditions on the forces, reactions
    updateGrid(dt, nThreads);              // (5) nodal momentum, Eq 29
    accumulateExternalWork(dt);            //     work of tractions and gravity (diagnostics)
    gridToParticle(dt, nThreads);          // (6) FLIP or APIC velocity and position, Eqs 30-31
    transportCracks(dt);                   //     crack vertices move with the material
}

template <int D, class K> thread_local typename Solver<D, K>::St* Solver<D, K>::stripStencils_ = nullptr;
template <int D, class K> thread_local bool Solver<D, K>::stripSource_ = false;

template <int D, class K> bool Solver<D, K>::pipelineable(int nThreads) const
{
    // The scenes the wavefront serves (pipelineLoop); the others run pass by pass, with the same
    // results. What is left out has a stage over the whole grid or all points between P2G and
    // G2P (tractions, the crack's and the bodies' mapping and contact, a distributed run's
    // exchanges, conditions on points), or other passes (APIC, the co-rotational update, 3D, the
    // scheduler's columns, the baseline's per-point P2G). Erosion is served: pipelineLoop holds
    // the grid update back from the rows a source could reach.
    if (!pipelined_ || D != 2 || nThreads > 2 || !K::laneEvaluation || laneIsa() == LaneIsa::baseline) return false;
    if (dist_ || mapping_ || points_.bodies || !tractions_.empty() || contact_ || crackContact_ ||
        !phantom_.empty() || grid_.totalNodes() != grid_.numNodes() || schedule_.numColumns() > 1)
        return false;
    if (settings_.transfer != Transfer::flip || settings_.stressUpdate != StressUpdate::smallStrain) return false;
    int lo, hi;
    for (const auto& c : conditions_)  // (conditions on nodes named before the step: their rows are known)
        if (!c->nodeRange(lo, hi)) return false;
    return schedule_.stripStart().size() > 1;
}

template <int D, class K> void Solver<D, K>::pipelineLoop()
{
    // The step as a wavefront over the strips: P2G, the nodal velocity (rows), the conditions,
    // the stress pass, the grid update (rows) and G2P follow each other a few strips apart, so
    // that a strip's points and stencils are used again while they are in the caches (the
    // passes stream all points three times, and from about 1e5 2D points on the data no longer
    // fits the last-level cache: doc/performance.md, "Session 52").
    //
    // Strip s holds the points whose base node row lies in [W s, W s + W): they reach the node
    // rows [W s, W s + reach]. A node row gets contributions from two neighbouring strips; the
    // passes run the even strips first (Scheduler::scatterPhase), so the wavefront takes P2G and
    // the stress pass in the order 0, 2, 1, 4, 3, 6, 5, ...: each node receives the same
    // contributions in the same order, and every result is bitwise the passes'. A row's nodal
    // velocity is taken once no later strip reaches it; the conditions (on node lists) once
    // every row they touch is final, before any strip reads those rows; the grid update once
    // the row's forces are final; a strip's G2P once its rows are updated.
    //
    // Two workers: strips [0, h) from h - 1 down (stage j: h - 2 - 2j, then h - 1 - 2j) and
    // [h, NS) from h up (h even), so that both start at the node rows they share, W h ...
    // W h + S - 2, which the upper worker owns. Six flags order the work on those rows as above.
    //
    // Eigenerosion needs every point's history before it can decide (EigenErosion::apply), and
    // then corrects the forces of the rows near the points it erodes. The law notes a source in
    // the strip's stress stage (lawOfRun, as EigenErosion::isSource tests); a node row is updated
    // only once every strip from Ebelow rows below it to Eabove rows above it has had its stress
    // stage and none held a source, where these cover what a source reaches: the candidates
    // within kappa and their supports (the corrections), and the points within 2 kappa whose
    // histories and positions the search reads (G2P moves a strip's points only after its rows
    // are updated). Once a source is seen, no further row is updated and no G2P starts; after the
    // last stress stage the whole erosion stage runs (the passes' erode, the same candidates, the
    // same corrections in the same order), and the rest follows. With no source in the step,
    // apply()'s own scan is skipped (noSources). A held-back strip keeps its ring slot, and P2G
    // must not wait for it: once a source is seen, a strip whose slot is held writes its stencils
    // to stencil_'s slots instead (the overflow, allocated then), and every strip gets to its
    // stress stage.
    auto& g = grid_;
    const double dt = strips_->dt;
    const auto& start = schedule_.stripStart();
    const int NS = static_cast<int>(start.size()) - 1;
    const int rows = g.n[D - 1], rowSize = g.stride[D - 1];
    constexpr int W = Scheduler<D>::stripWidth, S = K::S, reach = W + S - 2;
    struct Reset {  // (the passes read stencil_ again however this ends, an exception included)
        Solver& s;
        ~Reset()
        {
            stripStencils_ = nullptr;
            s.sourceHistory_ = std::numeric_limits<double>::infinity();
        }
    } reset{*this};
    int condLo = rows, condHi = -1;  // the rows the conditions touch
    for (const auto& c : conditions_) {
        int lo, hi;
        if (c->nodeRange(lo, hi) && lo <= hi) condLo = std::min(condLo, lo / rowSize), condHi = std::max(condHi, hi / rowSize);
    }
    int h = NS;
    if (strips_->threads >= 2 && NS >= 8) {  // the boundary at half the points, even, 2 .. NS - 2
        h = 2;
        for (int c = 4; c <= NS - 2; c += 2)
            if (std::abs(start[c] - start[NS] / 2) < std::abs(start[h] - start[NS] / 2)) h = c;
        // (conditions on both sides of the boundary, or on the shared rows: one worker)
        if (condHi >= 0 && condLo < W * h + S - 1 && condHi >= W * h - S) h = NS;
    }
    const bool two = h < NS, condLower = condHi >= 0 && condHi < W * h;
    workers_ = two ? 2 : 1;
    // Each worker's ring of R strips' stencils: a strip's slot is reused once its G2P is done.
    // The strips from the conditions' lowest row to their highest wait for them (no strip that
    // reads a condition's rows goes on before every row it touches is final), so the ring holds
    // that many and a margin; conditions at both ends of a scene make it hold every strip.
    // Erosion holds the update back Eabove / Ebelow rows more (below), and the ring that many
    // strips more.
    const bool eroding = erosion_ != nullptr;
    // How far a source reaches, in base rows (Kr = ceil(kappa / h); two points within a distance
    // d have base rows at most floor(d / h) + 1 apart): a row r gets corrections from sources
    // with base rows in [r - Kr - S, r + Kr + 1] (candidates within kappa, their supports); and
    // G2P of strip s, once rows [W s, W s + reach] are updated, moves points that must lie
    // farther than 2 kappa + h (the search's reach, and a step's move) from every source: base
    // rows [W s - 2 Kr - 2, W s + W + 2 Kr + 1] free. So a row is out of reach once no source
    // lies Eabove rows above it or Ebelow below it.
    const int kappaRows = eroding ? static_cast<int>(std::ceil(std::min(erosion_->settings().kappa * g.invh, double(rows)))) : 0;
    const int Eabove = eroding ? std::max(kappaRows + 1, 2 * kappaRows + 1 + W - reach) : 0;
    const int Ebelow = eroding ? std::max(kappaRows + S, 2 * kappaRows + 2) : 0;
    const int R = std::min(NS, std::max(16, condHi >= 0 ? (condHi - condLo) / W + 10 : 0) +
                                   (std::max(Eabove, Ebelow) + W - 1) / W);
    int maxStrip = 0;
    for (int s = 0; s < NS; ++s) maxStrip = std::max(maxStrip, start[s + 1] - start[s]);
    if (ring_.size() < static_cast<std::size_t>((two ? 2 : 1) * R * maxStrip)) ring_.resize((two ? 2 : 1) * R * maxStrip);
    const double cut = massCutoffAbs_;
    const auto velocityRows = [&](int lo, int hi) {
        for (int I = lo * rowSize; I < hi * rowSize; ++I) velocityAt(I, cut);
    };
    const auto updateRows = [&](int lo, int hi) {
        for (int I = lo * rowSize; I < hi * rowSize; ++I) updateAt(I, dt);
    };
    // Flags: 0 upper P2G(h) done, 1 lower P2G(h - 1), 2 upper velocity of the shared rows,
    // 3 upper stress(h), 4 lower stress(h - 1), 5 upper update of the shared rows; `failed`
    // stops the other worker when one throws.
    std::atomic<int> flag[6];
    for (auto& f : flag) f.store(0);
    std::atomic<bool> failed{false};
    const auto set = [&](int i) { flag[i].store(1, std::memory_order_release); };
    // A worker with nothing to do waits for the other: a pause, and every 64th time the rest of
    // its time slice (should the two threads share a core).
    const auto idle = [](int& spins) {
        if (++spins % 64 == 0)
            std::this_thread::yield();
        else
            __builtin_ia32_pause();
    };
    const auto is = [&](int i) { return !two || flag[i].load(std::memory_order_acquire) != 0; };
    // Erosion: a source seen in a stress stage; each worker's stress stages done (published after
    // its strips' sources); workers through all their stress stages; the erosion stage done (or
    // known to have nothing to do); G2P calls under way (the erosion stage waits for none).
    std::atomic<bool> sourceSeen{false}, settled{!eroding};
    std::atomic<int> stressUp{0}, stressDown{0}, stressFinished{0}, inG2P{0};
    // The law notes a source in its worker's stripSource_ (lawOfRun, as EigenErosion::isSource
    // tests: history >= sourceHistory_, intact); after a strip's stress stage it is published.
    // (A flag left set by a step that stopped with an error would only make the next one search
    // for sources in vain: apply() then finds none, as noSources says.)
    sourceHistory_ = eroding ? erosion_->sourceHistory() : std::numeric_limits<double>::infinity();
    const auto sourcesOf = [&]() {
        if (stripSource_) sourceSeen.store(true);
        stripSource_ = false;
    };
    // After a worker's last stress stage: the last worker through runs the erosion stage, once no
    // G2P is under way (a G2P that starts after a source was seen steps back: runG2P).
    const auto stressFinishedBy = [&]() {
        if (!eroding || stressFinished.fetch_add(1) + 1 < workers_) return;
        if (sourceSeen.load()) {
            int spins = 0;
            while (inG2P.load() != 0)
                if (failed.load(std::memory_order_relaxed)) return;
                else idle(spins);
            erode(dt, 1);
        }
        settled.store(true);
    };
    // The overflow: stencil_ by slot, allocated by the first strip that needs it. (A mutex, not
    // std::call_once, whose callable's symbols the Python module would export: test_isa.py.)
    std::mutex overflowMutex;
    const auto overflowing = [&]() { return eroding && sourceSeen.load() && !settled.load(); };
    const auto overflow = [&]() {
        const std::lock_guard<std::mutex> lock(overflowMutex);
        if (stencil_.size() < points_.size()) stencil_.resize(points_.size());
        return stencil_.data();
    };
    const auto runG2P = [&](int s) {
        inG2P.fetch_add(1);
        const bool go = settled.load() || !sourceSeen.load();
        if (go) strips_->g2p(s);
        inG2P.fetch_sub(1);
        return go;
    };
    bool velCond = condHi < 0, forceCond = condHi < 0;
    struct Ring {
        St* base;
        int R, maxStrip;
        const int* start;
        std::vector<int> holder;  // the strip in each slot, or -1
        std::vector<St*> at;      // where strip s's stencils are (stripStencils_ for it)
        bool free(int s) const { return holder[s % R] == -1; }
        void take(int s, St* overflow)  // its slot, or (held) the overflow
        {
            if (free(s))
                holder[s % R] = s, at[s] = base + (s % R) * maxStrip - start[s];
            else
                at[s] = overflow;
            use(s);
        }
        void use(int s) { stripStencils_ = at[s]; }
        void release(int s)
        {
            if (holder[s % R] == s) holder[s % R] = -1;
        }
    };
    // The upward worker: strips [a, NS), node rows [W a, rows); below `gate` the rows it shares
    // with the lower worker (a > 0).
    const auto upward = [&](int worker, int a, bool owner) {  // (owner: applies the conditions)
        Ring ring{ring_.data() + worker * R * maxStrip, R, maxStrip, start.data(), std::vector<int>(R, -1),
                  std::vector<St*>(NS, nullptr)};
        const int nb = NS - a, stages = nb / 2 + 1;
        const auto stage = [&](const std::function<void(int, int)>& f, int m, bool p2g) {
            for (const int s : {a + 2 * m, a + 2 * m - 1}) {
                if (s < a || s >= NS) continue;
                p2g ? ring.take(s, ring.free(s) ? nullptr : overflow()) : ring.use(s);
                f(start[s], start[s + 1]);
                if (!p2g) sourcesOf();
                if (s == a) set(p2g ? 0 : 3);
            }
        };
        const auto final = [&](int m) {  // rows [W a, final) no later strip of this worker reaches
            if (m == 0) return W * a;
            const int q = std::min(a + 2 * (m - 1), NS - 1);
            return q == NS - 1 ? rows : (q + 1) * W;
        };
        const auto stageFree = [&](int m) {
            for (const int s : {a + 2 * m, a + 2 * m - 1})
                if (s >= a && s < NS && !ring.free(s) && !overflowing()) return false;
            return true;
        };
        const int gate = a > 0 ? W * a + S - 1 : W * a;
        int mP = 0, mS = 0, vel = W * a, force = W * a, upd = W * a, next = a, spins = 0;
        // Erosion: the rows [W a, clear()) that no source can reach, as far as known now.
        const auto clear = [&]() {
            if (settled.load()) return rows;
            const int done = mS == 0 ? a : std::min(NS, a + 2 * mS - 1);  // strips [a, done) stressed
            int hi = done == NS ? rows : W * done - Eabove;
            if (a > 0) {  // (the lower worker's strips [low, h) stressed: rows from W low + Ebelow)
                const int low = std::max(0, h - 2 * stressDown.load());
                if (low > 0 && W * low + Ebelow > W * a) hi = W * a;
            }
            return sourceSeen.load() ? std::min(hi, upd) : hi;
        };
        while (next < NS) {
            if (failed.load(std::memory_order_relaxed)) return;
            bool moved = false;
            if (mP < stages && stageFree(mP)) {
                stage(strips_->p2g, mP, true);
                ++mP;
                moved = true;
            }
            const int fv = final(mP);
            if (fv > vel && (vel >= gate || is(1))) {
                velocityRows(vel, fv);
                if (vel < gate && fv >= gate) set(2);
                vel = fv;
                moved = true;
            }
            if (owner && !velCond && vel > condHi) {
                applyConditionsAfterVelocity(dt);
                velCond = true;
            }
            while (mS < mP) {
                const int need = W * std::min(a + 2 * mS, NS - 1) + reach;  // the last row the stage reads
                if (!(vel == rows || vel > need) || !(!owner || velCond || need < condLo)) break;
                stage(strips_->stress, mS, false);
                ++mS;
                stressUp.store(mS);
                if (mS == stages) stressFinishedBy();
                force = final(mS);
                moved = true;
            }
            const int open = eroding ? std::min(force, clear()) : force;  // (final and out of erosion's reach)
            if (owner && velCond && !forceCond && open > condHi) {
                applyConditionsAfterForces(dt);
                forceCond = true;
            }
            int upTo = owner && !forceCond ? std::min(open, condLo) : open;
            if (upd < gate && !is(4)) upTo = upd;
            if (upTo > upd) {
                updateRows(upd, upTo);
                if (upd < gate && upTo >= gate) set(5);
                upd = upTo;
                moved = true;
            }
            while (next < NS && (upd == rows || upd > W * next + reach)) {
                ring.use(next);
                if (!runG2P(next)) break;
                ring.release(next);
                ++next;
                moved = true;
            }
            if (!moved) {
                if (!two)  // (one worker waits on nothing: no progress would be a flaw here)
                    throw std::logic_error("EigenMPM: internal error: the wavefront step stalled at strip " + std::to_string(next));
                idle(spins);
            }
        }
    };
    // The downward worker: strips [0, h) from h - 1 down, node rows [0, W h).
    const auto downward = [&]() {
        Ring ring{ring_.data(), R, maxStrip, start.data(), std::vector<int>(R, -1), std::vector<St*>(NS, nullptr)};
        const int stages = h / 2;
        int spins = 0;
        const auto wait = [&](int i) {
            while (!is(i))
                if (failed.load(std::memory_order_relaxed)) return false;
                else idle(spins);
            return true;
        };
        const auto stage = [&](const std::function<void(int, int)>& f, int j, bool p2g) {
            for (const int s : {h - 2 - 2 * j, h - 1 - 2 * j}) {
                if (s == h - 1 && !wait(p2g ? 0 : 3)) return false;  // (the upper strip first)
                p2g ? ring.take(s, ring.free(s) ? nullptr : overflow()) : ring.use(s);
                f(start[s], start[s + 1]);
                if (!p2g) sourcesOf();
                if (s == h - 1) set(p2g ? 1 : 4);
            }
            return true;
        };
        const auto low = [&](int j) {  // own rows [low, W h) no later strip reaches, after stages 0 .. j - 1
            if (j == 0) return W * h;
            const int lowest = h - 2 * j;
            return lowest <= 0 ? 0 : W * lowest + S - 1;
        };
        int jP = 0, jS = 0, vel = W * h, force = W * h, upd = W * h, next = h - 1;
        // Erosion: the rows [clear(), W h) that no source can reach, as far as known now.
        const auto clear = [&]() {
            if (settled.load()) return 0;
            const int lowest = h - 2 * jS;  // strips [lowest, h) stressed
            int lo = lowest <= 0 ? 0 : W * lowest + Ebelow;
            const int m = stressUp.load();  // (the upper worker's strips [h, done) stressed: rows below W done - Eabove)
            const int done = m == 0 ? h : std::min(NS, h + 2 * m - 1);
            if (done < NS && W * done - Eabove < W * h) lo = W * h;
            return sourceSeen.load() ? std::max(lo, upd) : lo;
        };
        while (next >= 0) {
            if (failed.load(std::memory_order_relaxed)) return;
            bool moved = false;
            if (jP < stages && ((ring.free(h - 2 - 2 * jP) && ring.free(h - 1 - 2 * jP)) || overflowing())) {
                if (!stage(strips_->p2g, jP, true)) return;
                ++jP;
                moved = true;
            }
            if (low(jP) < vel) {
                velocityRows(low(jP), vel);
                vel = low(jP);
                moved = true;
            }
            if (condLower && !velCond && vel <= condLo) {
                applyConditionsAfterVelocity(dt);
                velCond = true;
            }
            while (jS < jP) {
                const int first = W * (h - 2 - 2 * jS);  // the lowest row the stage reads
                if (vel > first || (jS == 0 && !is(2)) || (condLower && !velCond && first <= condHi)) break;
                if (!stage(strips_->stress, jS, false)) return;
                ++jS;
                stressDown.store(jS);
                if (jS == stages) stressFinishedBy();
                force = low(jS);
                moved = true;
            }
            const int open = eroding ? std::max(force, clear()) : force;  // (final and out of erosion's reach)
            if (condLower && velCond && !forceCond && open <= condLo) {
                applyConditionsAfterForces(dt);
                forceCond = true;
            }
            const int downTo = condLower && !forceCond ? std::max(open, condHi + 1) : open;
            if (downTo < upd) {
                updateRows(downTo, upd);
                upd = downTo;
                moved = true;
            }
            while (next >= 0 && upd <= W * next && (next < h - 1 || is(5))) {
                ring.use(next);
                if (!runG2P(next)) break;
                ring.release(next);
                --next;
                moved = true;
            }
            if (!moved) idle(spins);
        }
    };
    if (!two) {
        upward(0, 0, true);
    } else {
        std::exception_ptr error[2];
#pragma omp parallel num_threads(2)
        {
            const int t = omp_get_thread_num();
            try {
                if (omp_get_num_threads() < 2) {  // (a team of one: the whole sweep, one worker)
                    workers_ = 1;
                    upward(0, 0, true);
                } else if (t == 0) {
                    downward();
                } else {
                    upward(1, h, !condLower);
                }
            } catch (...) {
                error[t] = std::current_exception();
                failed.store(true);
            }
            stripStencils_ = nullptr;
        }
        for (const auto& e : error)
            if (e) std::rethrow_exception(e);
    }
    stripStencils_ = nullptr;  // (the master thread's, before the diagnostics)
    if (eroding && !sourceSeen.load()) erosion_->noSources();
    accumulateExternalWork(dt);
}

template <int D, class K> void Solver<D, K>::checkTimeStep(double dt)
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
}

template <int D, class K> template <class F> void Solver<D, K>::forEachWorkNode(int nThreads, F&& f)
{
    // A distributed run's own planes, or all of them; each worker the rows of its strips.
    const int lo = dist_ ? dist_->planeLo() : 0, hi = dist_ ? dist_->planeHi() : grid_.n[D - 1];
    if (dist_ && dist_->rankColumns() > 1) {  // and of them the node columns of its tiles
        const int a = dist_->columnLo(), b = dist_->columnHi(), n0 = grid_.n[0];
        schedule_.forEachNodeOfRows(lo, hi, grid_.stride[D - 1], nThreads, [&](int I) {
            const int i0 = I % n0;
            if (i0 >= a && i0 < b) f(I);
        });
    } else {
        schedule_.forEachNodeOfRows(lo, hi, grid_.stride[D - 1], nThreads, f);
    }
    if (grid_.totalNodes() > grid_.numNodes())  // the cracks' twins
        Scheduler<D>::forEachNodeIn(grid_.numNodes(), grid_.totalNodes(), nThreads, f);
}

template <int D, class K> template <class F> void Solver<D, K>::forEachTractionPoint(std::size_t t, F&& f) const
{
    if (!dist_) {
        const auto& points = tractions_[t].points;
        for (std::size_t k = 0; k < points.size(); ++k) f(points[k], static_cast<int>(k));
        return;
    }
    for (const auto& [p, k] : tractionLocal_[t]) f(p, k);
}

template <int D, class K> void Solver<D, K>::schedulePoints(int nThreads)
{
    // A point off the grid (moved there by the user, or left there by a step that stopped with
    // an error) would write outside the nodal arrays: refused here.
    const int off = schedule_.template bin<K>(points_.x, grid_, nThreads);
    if (dist_ && dist_->rankColumns() > 1) {  // (ScatterChain's phases)
        const auto deferred = dist_->deferredColumns();
        schedule_.setSeparatePhases(true, deferred[0], deferred[1]);
    }
    if (off >= 0) {
        const auto& g = grid_;
        Vec<D> hiCorner;
        for (int d = 0; d < D; ++d) hiCorner[d] = g.origin[d] + (g.n[d] - 1) * g.h;
        std::ostringstream s;
        s << "EigenMPM: point id " << off << " at " << str<D>(points_.x[off])
          << " is off the grid (nodes span " << str<D>(g.origin) << " to " << str<D>(hiCorner)
          << ") at the start of step " << steps_ + 1 << "; move it back or give a larger domain";
        throw SimulationError(s.str());
    }
    if (settings_.transfer == Transfer::apic)
        offset_.resize((deformationInG2P() ? 2 : 1) * D * points_.size());
    else if (!offset_.empty())
        std::vector<double>().swap(offset_);
}

template <int D, class K> void Solver<D, K>::markCrackedNodes()
{
    mapping_ = 0;
    if (phantom_.empty()) return;
    auto& g = grid_;
    // Marked nodes and their twins for the cracks' current position (Section 3.3.1), as many
    // rings of cells around the cut cells as the kernel's support reaches.
    g.setTwins(phantom_.update(g, K::crackRings));
    mapping_ = 1;
    markedBox();
    if (dist_) {  // the regular node of each twin (a shared plane's serial contributions)
        twinRegular_.assign(phantom_.numTwins(), -1);
        for (int I : phantom_.markedNodes()) phantom_.forEachTwin(I, [&](int t) { twinRegular_[t - g.numNodes()] = I; });
    }
}

template <int D, class K> void Solver<D, K>::markedBox()
{
    auto& g = grid_;
    // Box (in node indices) of the marked nodes: points whose support lies outside it skip the
    // per-node test, so the cost follows the marked region.
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
    g.remap.resize(static_cast<std::size_t>(points_.size() + 1) * St::NS);  // + a scratch slot
}

template <int D, class K> void Solver<D, K>::clearGrid(int nThreads)
{
    auto& g = grid_;
    constexpr int W = Grid<D>::sumsWidth;
    double* mm = g.massMomentum.data();
    forEachWorkNode(nThreads, [&](int I) {
        if constexpr (W > 0) {  // (3D: P2G's sums, which nodalVelocity copies into mass and momentum)
            for (int c = 0; c < W; ++c) mm[static_cast<std::size_t>(I) * W + c] = 0;
        } else {
            g.mass[I] = 0;
            g.momentum[I].setZero();
        }
        g.force[I].setZero();
    });
}

template <int D, class K> void Solver<D, K>::particleToGrid(int nThreads)
{
    // Nodal mass (Eq 12) and momentum P^{n-1/2} (Eq 25). The shape functions (15) are evaluated
    // here once per point and kept for the stress/force pass and G2P.
    auto& g = grid_;
    const int mapping = mapping_;
    const HalfWidth half(lp_);  // (its reciprocal once, not per point)
    // One instantiation per transfer, so that FLIP's is the paper's loop alone (the inliner
    // then treats it as before the APIC option existed: bench_block checksums and speed). Both
    // are forced inline into the Scheduler's loop: GCC kept APIC's out of line, which cost 2D
    // APIC 9 % more instructions.
    // `frame` is the point's APIC frame when its run computed it (inRuns), or null.
    // With APIC + co-rotational (`force`: deformationInG2P), the point's internal and body
    // forces too: f_I += N_I (m_p b - V sigma_p D_p^-1 (x_I - x_p)), V sigma_p as
    // stressBeforeTransfer left it in the point's slot. That is an affine field in the same
    // cell offsets u as the momentum's: N_I (m_p b + G u) with G = -V sigma diag(r),
    // r = 1 / (h du) from the point's frame (0 where du is not positive). Its power on any nodal
    // velocities is -V sigma : C_p with G2P's C_p: the force is the transpose of G2P's update of
    // F (Kinematics.hpp).
    const Vec<D> gravity = settings_.gravity.head<D>();
    const auto body = [&](auto apic, auto computed, auto force) {
        return [&](const PassArrays& A, int k, const typename St::AffineFrame* frame) EMP_LAMBDA_INLINE {
            const auto& P = A.P;
            const int p = A.order[k];
            St& st = A.stencil[k];
            if constexpr (!decltype(computed)::value) {
                st.compute(P.x[p], g, half);
                if (mapping && St::overlaps(P.x[p], g, markedLo_, markedHi_)) mapSupport(st, p, k);
            }  // (else the run's supports are mapped before it scatters: inRuns)
            const double mp = P.mass(p);
            const Vec<D> mv = mp * P.v[p];
            // 3D: node I's mass and momentum sums, one 4-lane vector (Grid::massMomentum).
            constexpr int W = Grid<D>::sumsWidth;
            const auto sums = [&](int I) EMP_LAMBDA_INLINE { return &A.massMomentum[static_cast<std::size_t>(I) * W]; };
            const auto add = [&](int I, double m, const Vec<D>& q) EMP_LAMBDA_INLINE {
                if constexpr (W > 0) {
                    double* r = sums(I);
                    r[0] += m;
                    for (int d = 0; d < D; ++d) r[1 + d] += q[d];
                } else {
                    A.mass[I] += m;
                    A.momentum[I] += q;
                }
            };
            if constexpr (!decltype(apic)::value) {
                if (st.regular()) {
                    if constexpr (W > 0) {  // (the same sums, node by node in 4 lanes: Stencil::scatterRowsOf)
                        double a[D + 1] = {mp};
                        for (int d = 0; d < D; ++d) a[1 + d] = mv[d];
                        st.scatterRowsOf(g, a, sums);
                    } else {  // (the same sums by rows: Stencil::forEachRow)
                        st.forEachRow(g, [&](int I0, const double* N) EMP_LAMBDA_INLINE {
                            double* m = &A.mass[I0];
                            double* q = A.momentum[I0].data();
                            for (int i = 0; i < S; ++i) m[i] += N[i] * mp;
                            for (int e = 0; e < S * D; ++e) q[e] += N[e / D] * mv[e % D];
                        });
                    }
                    return;
                }
                st.forEach(g, [&](int I, double N, const Vec<D>&) { add(I, N * mp, N * mv); });
            } else {
                // APIC: m_I v_I += N m_p (v_p + C_p (x_I - x_p)), C_p = B_p D_p^-1 at this position.
                // In cells (u = (x_I - x_p) / h, D_p = h^2 diag(du)): C_p (x_I - x_p) = Cu u with
                // Cu = h C_p = B_p diag(h du)^-1. Cu replaces B_p until G2P, which needs it for
                // the kinetic energy and then stores the new B_p. (u and 1 / (h du) from the
                // point's frame: Stencil::affineFrameAlong.)
                const typename St::AffineFrame f = frame ? *frame : st.affineFrame(P.x[p], g);
                if (!frame) {  // (G2P reads the offsets, and r with F; inRuns stores those of a run)
                    for (int d = 0; d < D; ++d) A.offset[d][k] = f.b[d];
                    if (A.scale[0])
                        for (int d = 0; d < D; ++d) A.scale[d][k] = f.r[d];
                }
                double u[D][S];
                for (int d = 0; d < D; ++d)
                    for (int i = 0; i < S; ++i) u[d][i] = f.b[d] + i;
                Mat<D>& Cu = P.affineVelocity[p];
                typename Lane3::V c[3];  // (3D: Cu's columns, for scatterRowsAffineOf)
                St::scaleAffine(Cu, f.r, c);
                Vec<D> fb;
                Mat<D> G;
                if constexpr (decltype(force)::value) {
                    fb = mp * gravity;  // (0 + x is x: no separate form without gravity)
                    const Mat<D> vs = slotMatrix(&slotStress_[static_cast<std::size_t>(k) * slotStride]);
                    for (int d = 0; d < D; ++d) G.col(d) = -f.r[d] * vs.col(d);
                }
                if (st.regular()) {
                    if constexpr (W > 0) {
                        st.scatterRowsAffineOf(g, u, mv, mp, c, sums);
                    } else {
                        st.forEachRowAffine(g, u, mv, mp, Cu, [&](int I0, const double* N, const double* Nt) EMP_LAMBDA_INLINE {
                            double* m = &A.mass[I0];
                            double* q = A.momentum[I0].data();
                            for (int i = 0; i < S; ++i) m[i] += N[i] * mp;
                            for (int e = 0; e < S * D; ++e) q[e] += Nt[e];
                        });
                    }
                    // The force in a second sum of the same form (one sum of both fields, sharing
                    // the rows' weights, was 2 % fewer instructions but 8 % slower in 2D:
                    // doc/performance.md, "Session 50").
                    if constexpr (decltype(force)::value)
                        st.forEachRowAffine(g, u, fb, 1.0, G, [&](int I0, const double*, const double* Nt) EMP_LAMBDA_INLINE {
                            double* t = A.force[I0].data();
                            for (int e = 0; e < S * D; ++e) t[e] += Nt[e];
                        });
                    return;
                }
                st.forEachAffine(g, u, mv, Mat<D>(mp * Cu), [&](int I, double N, const Vec<D>& m) { add(I, N * mp, N * m); });
                if constexpr (decltype(force)::value)
                    st.forEachAffine(g, u, fb, G, [&](int I, double N, const Vec<D>& t) { A.force[I] += N * t; });
            }
        };
    };
    std::vector<NodeField> fields = Grid<D>::sumsWidth > 0
                                        ? std::vector<NodeField>{{g.massMomentum.data(), Grid<D>::sumsWidth}}
                                        : std::vector<NodeField>{{g.mass.data(), 1}, {g.momentum.data()->data(), D}};
    if (deformationInG2P()) fields.push_back({g.force.data()->data(), D});
    std::function<void(int)> between;
    if (dist_) between = [&](int k) { dist_->afterPhase(k, schedule_.numPhases(), g, fields); };
    // With vectors wider than the baseline's (pkg/Lanes.hpp), the stencils of a run of points
    // are computed first, one point per lane (Stencil::computeRun), then the run scatters point
    // by point: the same stencils, and the same order of the contributions to each node.
    // With APIC, the run's lanes find each point's frame too (its divisions 4 or 8 at a time).
    // Only the runs of the strips whose points can reach the marked box along the last axis
    // test for it (Scheduler::slotsReaching: bin's strips are of the base nodes computeRun finds).
    const std::pair<int, int> nearSlots = mapping ? schedule_.template slotsReaching<K>(markedLo_[D - 1], markedHi_[D - 1])
                                                  : std::pair<int, int>{0, 0};
    const auto inRuns = [&](auto apic, auto force) {
        const auto point = body(apic, std::true_type{}, force);
        return [&, point](int begin, int end) EMP_LAMBDA_INLINE {
            const auto& order = schedule_.order();
            const auto x = [&](int i) -> const Vec<D>& { return points_.x[order[begin + i]]; };
            typename St::template AffineRun<stencilRun> frames;
            const std::size_t n = stencil_.size();
            // (G2P's C_p: deformationInG2P. 2D: computeRun stores r there too, 1.5 % of the step
            // faster than a memcpy after it; 3D: 1 % slower, so the memcpy stays.)
            const bool scales = offset_.size() > D * n;
            if constexpr (decltype(apic)::value) {
                for (int d = 0; d < D; ++d) frames.b[d] = &offset_[d * n + begin];
                if constexpr (D == 2)
                    if (scales)
                        for (int d = 0; d < D; ++d) frames.rOut[d] = &offset_[(D + d) * n + begin];
            }
            // Near a crack (or bodies in one grid), which points' supports may touch a marked
            // node, from the run's base nodes (Stencil::Box); those are mapped before the run
            // scatters (mapRun: no call in the scatter's loop).
            int near[stencilRun];
            typename St::Box box{markedLo_, markedHi_, near, 0};
            typename St::Box* const nearBox = begin < nearSlots.second && end > nearSlots.first ? &box : nullptr;
            if constexpr (decltype(apic)::value) {
                St::template computeRun<stencilRun>(end - begin, x, g, half, &stencil_[begin], frames, nearBox);
                if constexpr (D == 3)
                    if (scales)
                        for (int d = 0; d < D; ++d)
                            std::memcpy(&offset_[(D + d) * n + begin], frames.r[d], (end - begin) * sizeof(double));
            } else
                St::template computeRun<stencilRun>(end - begin, x, g, half, stencils() + begin, nearBox);
            if (box.any) mapRun(begin, end, near);
            withLaneIsa([&]() EMP_LAMBDA_INLINE {  // (the rows' loops in the lanes' width)
                const PassArrays A = passArrays();
                for (int k = begin; k < end; ++k) {
                    if constexpr (decltype(apic)::value) {
                        const typename St::AffineFrame f = frames.frame(k - begin);
                        point(A, k, &f);
                    } else {
                        point(A, k, nullptr);
                    }
                }
            });
        };
    };
    const auto scatter = [&](auto apic, auto force) {
        if constexpr (K::laneEvaluation)
            if (laneIsa() != LaneIsa::baseline) return schedule_.scatterRuns(nThreads, stencilRun, inRuns(apic, force), between);
        const auto point = body(apic, std::false_type{}, force);
        schedule_.scatter(nThreads, [&](int k) EMP_LAMBDA_INLINE { point(passArrays(), k, nullptr); }, between);
    };
    if constexpr (K::laneEvaluation)
        if (strips_) {  // (a wavefront step: FLIP's runs, strip by strip; pipelineable)
            const auto runs = inRuns(std::false_type{}, std::false_type{});
            strips_->p2g = [&](int begin, int end) {
                for (int k = begin; k < end; k += stencilRun) runs(k, std::min(k + stencilRun, end));
            };
            stressAndInternalForce(strips_->dt, strips_->threads);
            return;
        }
    if (deformationInG2P())
        scatter(std::true_type{}, std::true_type{});
    else if (settings_.transfer == Transfer::apic)
        scatter(std::true_type{}, std::false_type{});
    else
        scatter(std::false_type{}, std::false_type{});
    if (dist_) dist_->finishScatter(g, fields);
}

template <int D, class K> EMP_ALWAYS_INLINE void Solver<D, K>::velocityAt(int I, double cut)
{
    auto& g = grid_;
    constexpr int W = Grid<D>::sumsWidth;
    if constexpr (W > 0) {  // (3D: P2G's sums, Grid::massMomentum)
        const double* r = g.massMomentum.data() + static_cast<std::size_t>(I) * W;
        g.mass[I] = r[0];
        for (int d = 0; d < D; ++d) g.momentum[I][d] = r[1 + d];
    }
    g.invMass[I] = g.mass[I] > cut && g.mass[I] > 0 ? 1.0 / g.mass[I] : 0.0;
    g.velocity[I] = g.mass[I] > 0 ? Vec<D>(g.momentum[I] / g.mass[I]) : Vec<D>::Zero();
}

template <int D, class K> void Solver<D, K>::nodalVelocity(int nThreads)
{
    // v_I = P_I / m_I is a mass-weighted mean of point velocities, bounded however light the
    // node: no cut-off here, or the gradients in Eq 27 would stop summing to zero and a rigid
    // motion would strain. The cut-off applies where a force is divided by the mass (invMass).
    const double cut = massCutoffAbs_;
    forEachWorkNode(nThreads, [&](int I) { velocityAt(I, cut); });
}

template <int D, class K> void Solver<D, K>::applyConditionsAfterVelocity(double dt)
{
    GridState<D> s{grid_, points_, phantom_, std::max(time_ - 0.5 * dt, 0.0), dt};
    if (dist_)  // conditions on points: the nodes of this rank's points and of its neighbours'
        for (auto& c : velocityConditions_) {
            if (c->points.empty()) continue;
            c->pointNodes.clear();
            for (int id : c->points) {
                const int p = dist_->localIndex(points_, id);
                const int I = p >= 0 ? grid_.nearestNode(points_.x[p]) : -1;
                if (I >= 0) c->pointNodes.push_back(I);
            }
            dist_->shareNodes(grid_, c->pointNodes);
            c->pointNodesGiven = true;
        }
    if (crackContact_ && !phantom_.empty()) crackContact_->afterNodalVelocity(s);
    if (mapping_ == 2) bodyContact_.template apply<false>(grid_, phantom_, dt);
    for (auto& c : conditions_) c->afterNodalVelocity(s);
}

// Forced inline (see Stencil.hpp): the per-point pieces must merge into the pass's loop; as
// out-of-line calls they cost one call per point and keep the sums out of registers.
template <int D, class K>
template <class A>
EMP_ALWAYS_INLINE Mat<D> Solver<D, K>::velocityGradient(const A& a, int p, const St& st) const
{
    // Velocity gradient L = sum v_I grad N_I (Eq 27).
    const auto& g = grid_;
    if constexpr (K::gradientJumpsAtNodes) {
        // A point exactly on a node has weight 0 there but gradient +-1/h on the next node, which
        // can be empty (velocity unknown, set to 0) at a free face, and a rigid motion would
        // strain. Such a node takes the point's own velocity, so that the gradients still sum
        // to zero. (A C1 kernel's gradient vanishes with its weight: it never meets that case.)
        const Vec<D> vp = a.P.v[p];
        return st.gradientOf(g, [&](int I) { return a.mass[I] > 0 ? a.velocity[I] : vp; });
    } else {
        return st.gradientOf(g, [&](int I) -> const Vec<D>& { return a.velocity[I]; });
    }
}

template <int D, class K> EMP_ALWAYS_INLINE Mat<D> Solver<D, K>::velocityGradient(int p, const St& st) const
{
    const struct {
        const double* mass;
        const Vec<D>* velocity;
        struct {
            const Vec<D>* v;
        } P;
    } a{grid_.mass.data(), grid_.velocity.data(), {points_.v.data()}};
    return velocityGradient(a, p, st);
}

template <int D, class K>
EMP_ALWAYS_INLINE void Solver<D, K>::updateStrain(const PassArrays& a, int p, const St& st, double dt, double invh)
{
    auto& eps = a.P.strain[p];
    if constexpr (D == 2 && !K::gradientJumpsAtNodes) {
        // The strain increment of the 2D branch below in 4-lane vectors, the same operations on
        // each component: L = c / h, column by column ({L00, L10, L01, L11}), plus its
        // transpose's lanes ({L00, L01, L10, L11}), times dt / 2 (L10 + L01 and L01 + L10 are the
        // same sum). (As a 2 x 2 matrix and then Sym2, GCC took L's lanes apart through the
        // stack: about 20 instructions a point.)
        typedef Lane3::V V4;
        V4 c;
        st.velocitySums2(grid_, [&](int I) EMP_LAMBDA_INLINE -> const Vec<D>& { return a.velocity[I]; }, c);
        const V4 L = invh * c;
        const V4 d = (0.5 * dt) * (L + __builtin_shufflevector(L, L, 0, 2, 1, 3));
        eps.xx += d[0];
        eps.xy += d[1];
        eps.yy += d[3];
    } else {
        const Mat<D> L = velocityGradient(a, p, st);
        if constexpr (D == 2)
            eps += Mat<D>((0.5 * dt) * (L + L.transpose()));  // strain increment (Eq 27; symmetric: Sym2)
        else
            eps += (0.5 * dt) * (L + L.transpose());
    }
}

template <int D, class K> EMP_ALWAYS_INLINE void Solver<D, K>::lawAt(int p, PointTensor<D>& sigma)
{
    // The material's law (a compile-time policy, one switch per point): sigma = c sigma+ + sigma-
    // (Eq 7 with g(c) = c), psi+/psi- (Eqs 3-4) and the history H = max psi+ (Eq 22).
    auto& P = points_;
    const ElasticMaterial& m = materials_[P.material[p]];
    withLaw(m.law, [&](auto law) {
        const LawResponse<D> r = decltype(law)::template response<D>(full(P.strain[p]), m);
        store(sigma, P.damage[p] * r.sigmaPlus + r.sigmaMinus);
        P.energy[p] = P.damage[p] * r.psiPlus + r.psiMinus;
        P.history[p] = std::max(P.history[p], r.psiPlus);
    });
}

template <int D, class K> EMP_ALWAYS_INLINE void Solver<D, K>::lawOfRun(const int* ids, int n, PointTensor<D>* sigma)
{
    // The law for a run of points. In 2D, when the run's points share a law with the pointwise
    // response (Law.hpp, response2), the law runs as one vectorised loop over the run: each lane
    // takes one point through the same operations, so the results are bitwise those of lawAt,
    // while the points' square roots and divisions go through the processor side by side.
    if constexpr (D == 2) {
        if (withSharedPointwiseLaw(ids, n, [&](auto l) { lawOfRun2<decltype(l)>(ids, n, sigma); })) return;
    } else {
        if (withSharedPointwiseLaw(ids, n, [&](auto l) { lawOfRun3<decltype(l)>(ids, n, sigma); })) return;
    }
    for (int i = 0; i < n; ++i) lawAt(ids[i], sigma[i]);
    if (D == 2 && sourceHistory_ < std::numeric_limits<double>::infinity())  // (as lawOfRun2 notes them)
        for (int i = 0; i < n; ++i)
            if (erosion_->isSource(points_.history[ids[i]], points_.damage[ids[i]])) stripSource_ = true;
}

template <int D, class K>
template <class F>
EMP_ALWAYS_INLINE bool Solver<D, K>::withSharedPointwiseLaw(const int* ids, int n, F&& f)
{
    // With one law for all materials (set by the pass, stepLaw_) there is nothing to check.
    const int law = stepLaw_ >= 0 ? stepLaw_ : materials_[points_.material[ids[0]]].law;
    bool same = true;
    if (stepLaw_ < 0)
        for (int i = 1; i < n; ++i) same = same && materials_[points_.material[ids[i]]].law == law;
    bool done = false;
    if (same)
        withLaw(law, [&](auto l) {
            if constexpr (hasPointwiseResponse<D, decltype(l)>) {
                f(l);
                done = true;
            }
        });
    return done;
}

template <int D, class K>
EMP_ALWAYS_INLINE void Solver<D, K>::lawInputs(const int* ids, int n, double* c, double* lambda, double* mu) const
{
    const auto& P = points_;
    for (int i = 0; i < n; ++i) c[i] = P.damage[ids[i]];
    if (materials_.size() == 1) {  // (the usual scene: no material to look up per point)
        const double l = materials_[0].lambda, m = materials_[0].mu;
        for (int i = 0; i < n; ++i) lambda[i] = l, mu[i] = m;
        return;
    }
    for (int i = 0; i < n; ++i) {
        const ElasticMaterial& m = materials_[P.material[ids[i]]];
        lambda[i] = m.lambda;
        mu[i] = m.mu;
    }
}

template <int D, class K>
EMP_ALWAYS_INLINE double Solver<D, K>::storeEnergies(int p, double c, double psiPlus, double psiMinus)
{
    points_.energy[p] = c * psiPlus + psiMinus;
    return points_.history[p] = std::max(points_.history[p], psiPlus);  // Eq 22
}

template <int D, class K>
template <class Law>
EMP_ALWAYS_INLINE void Solver<D, K>::lawOfRun2(const int* ids, int n, PointTensor<D>* out)
{
    auto& P = points_;
    alignas(64) double e[4][stressRun], c[stressRun], lambda[stressRun], mu[stressRun];
    alignas(64) double sigma[4][stressRun], psiPlus[stressRun], psiMinus[stressRun];
    for (int i = 0; i < n; ++i) {  // the run's points in structure-of-arrays form
        const int p = ids[i];
        const Sym2& E = P.strain[p];
        e[0][i] = E(0, 0);
        e[1][i] = E(0, 1);
        e[2][i] = E(1, 0);
        e[3][i] = E(1, 1);
    }
    lawInputs(ids, n, c, lambda, mu);
    forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
        Law::response2(e[0][i], e[1][i], e[2][i], e[3][i], c[i], lambda[i], mu[i], sigma[0][i], sigma[1][i],
                       sigma[2][i], sigma[3][i], psiPlus[i], psiMinus[i]);
    });
    // (A wavefront step with erosion: whether a point became or is a source, EigenErosion::isSource,
    // while its history and damage are at hand; sourceHistory_ is infinite otherwise.)
    const double hs = sourceHistory_;
    bool source = false;
    for (int i = 0; i < n; ++i) {
        const int p = ids[i];
        out[i] = Sym2::of(sigma[0][i], sigma[1][i], sigma[2][i], sigma[3][i]);
        source |= (storeEnergies(p, c[i], psiPlus[i], psiMinus[i]) >= hs) & (c[i] > 0);
    }
    if (source) stripSource_ = true;
}

template <int D, class K>
template <class Law>
EMP_ALWAYS_INLINE void Solver<D, K>::lawOfRun3(const int* ids, int n, PointTensor<D>* out)
{
    // lawOfRun2 in 3D: the run's symmetric strains (lower triangles) through the law's response3
    // in one vectorised loop; a point it calls not ordinary (Law.hpp) through lawAt, which gives
    // it bitwise what the loop gives the others.
    if constexpr (D == 3) {
        auto& P = points_;
        alignas(64) double e[6][stressRun], c[stressRun], lambda[stressRun], mu[stressRun];
        alignas(64) double sigma[6][stressRun], psiPlus[stressRun], psiMinus[stressRun];
        alignas(64) double ordinary[stressRun];  // (1 or 0: a bool array is not vectorised)
        for (int i = 0; i < n; ++i) {  // the run's points in structure-of-arrays form
            const int p = ids[i];
            const Mat<3>& E = P.strain[p];
            e[0][i] = E(0, 0);
            e[1][i] = E(1, 1);
            e[2][i] = E(2, 2);
            e[3][i] = E(1, 0);
            e[4][i] = E(2, 0);
            e[5][i] = E(2, 1);
        }
        lawInputs(ids, n, c, lambda, mu);
        forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
            bool ok;
            Law::response3(e[0][i], e[1][i], e[2][i], e[3][i], e[4][i], e[5][i], c[i], lambda[i], mu[i], sigma[0][i],
                           sigma[1][i], sigma[2][i], sigma[3][i], sigma[4][i], sigma[5][i], psiPlus[i], psiMinus[i], ok);
            ordinary[i] = ok ? 1.0 : 0.0;
        });
        for (int i = 0; i < n; ++i) {
            const int p = ids[i];
            if (ordinary[i] != 1.0) {
                lawAt(p, out[i]);
                continue;
            }
            Mat<3>& S = out[i];
            S(0, 0) = sigma[0][i];
            S(1, 1) = sigma[1][i];
            S(2, 2) = sigma[2][i];
            S(1, 0) = S(0, 1) = sigma[3][i];
            S(2, 0) = S(0, 2) = sigma[4][i];
            S(2, 1) = S(1, 2) = sigma[5][i];
            storeEnergies(p, c[i], psiPlus[i], psiMinus[i]);
        }
    }
}

template <int D, class K> EMP_ALWAYS_INLINE void Solver<D, K>::corotationalStress(int p, PointTensor<D>& sigma)
{
    // F = R U; the law and its split on eps = U - I (Eq 7, 3-4, 22 unchanged in the co-rotated
    // frame); the stress rotated back (Kinematics.hpp). A degenerate F (inverted or collapsed
    // point) gives a NaN stress, which the step's check reports with the point's id.
    auto& P = points_;
    Mat<D> R, U;
    if (!polarDecomposition(P.deformationGradient[p], R, U)) {
        sigma.setConstant(std::numeric_limits<double>::quiet_NaN());
        return;
    }
    const Mat<D> eps = U - Mat<D>::Identity();  // (not stored: MaterialPoints::strainOf)
    const ElasticMaterial& m = materials_[P.material[p]];
    withLaw(m.law, [&](auto law) {
        const LawResponse<D> r = decltype(law)::template response<D>(eps, m);
        sigma = cauchyStress<D>(R, U, P.damage[p] * r.sigmaPlus + r.sigmaMinus);
        P.energy[p] = P.damage[p] * r.psiPlus + r.psiMinus;
        P.history[p] = std::max(P.history[p], r.psiPlus);
    });
}

template <int D, class K>
EMP_ALWAYS_INLINE void Solver<D, K>::corotationalOfRun(const int* ids, const St* st, int n, double dt, double* J,
                                                        PointTensor<D>* sigma)
{
    // As lawOfRun: in 2D, a run whose points share a law with the pointwise response goes
    // through the whole update (deformation gradient, polar decomposition, law, Cauchy stress) as
    // one vectorised loop; otherwise point by point.
    if constexpr (D == 2) {
        const bool moved = deformationInG2P();
        if (withSharedPointwiseLaw(ids, n, [&](auto l) {
                moved ? corotationalOfRun2<decltype(l), true>(ids, st, n, dt, J, sigma)
                      : corotationalOfRun2<decltype(l), false>(ids, st, n, dt, J, sigma);
            }))
            return;
    } else {
        deformationInG2P() ? corotationalOfRun3<true>(ids, st, n, dt, J, sigma) : corotationalOfRun3<false>(ids, st, n, dt, J, sigma);
        return;
    }
    // Point by point: the run's velocity gradients first (one tight loop of stencil sums, as in
    // the small-strain pass), then each point's update. L is the gradient at the points' new
    // positions of the velocity that brought them there, so the motion's gradient is
    // (I - dt L)^-1 (Kinematics.hpp): exact for any field the transfer carries, a rigid rotation
    // included.
    // With APIC, G2P has updated F already (deformationInG2P).
    const bool moved = deformationInG2P();
    Mat<D> L[stressRun];
    if (!moved)
        for (int i = 0; i < n; ++i) L[i] = velocityGradient(ids[i], st[i]);
    for (int i = 0; i < n; ++i) {
        Mat<D>& F = points_.deformationGradient[ids[i]];
        if (!moved) F = (Mat<D>::Identity() - dt * L[i]).inverse() * F;
        J[i] = F.determinant();
        corotationalStress(ids[i], sigma[i]);
    }
}

template <int D, class K>
template <class Law, bool moved>
EMP_ALWAYS_INLINE void Solver<D, K>::corotationalOfRun2(const int* ids, const St* st, int n, double dt, double* J,
                                                         PointTensor<D>* out)
{
    // corotationalOfRun's point-by-point update for n points, each lane one point through the
    // same operations: the velocity gradients first (stencil sums, point by point), then the
    // algebra, whose divisions and square roots go through the processor side by side.
    auto& P = points_;
    alignas(64) double l[4][stressRun], f[4][stressRun], c[stressRun], lambda[stressRun], mu[stressRun];
    alignas(64) double sigma[4][stressRun], psiPlus[stressRun], psiMinus[stressRun];
    alignas(64) double ok[stressRun];
    withLaneIsa([&]() EMP_LAMBDA_INLINE {  // (the gradients' 4-lane sums in the lanes' width)
        const PassArrays a = passArrays();
        for (int i = 0; i < n; ++i) {
            const int p = ids[i];
            if constexpr (!moved) {  // (else F as G2P left it: no gradients here)
                if constexpr (!K::gradientJumpsAtNodes) {
                    // L's columns from the 4-lane sums, each lane stored where it goes (as a 2 x 2
                    // matrix GCC took the lanes apart through the stack; updateStrain): L = c / h,
                    // the operations of velocityGradient.
                    Lane3::V c;
                    st[i].velocitySums2(grid_, [&](int I) EMP_LAMBDA_INLINE -> const Vec<D>& { return a.velocity[I]; }, c);
                    const Lane3::V L = grid_.invh * c;  // {L00, L10, L01, L11}
                    l[0][i] = L[0], l[1][i] = L[2], l[2][i] = L[1], l[3][i] = L[3];
                } else {
                    const Mat<D> L = velocityGradient(a, p, st[i]);
                    l[0][i] = L(0, 0), l[1][i] = L(0, 1), l[2][i] = L(1, 0), l[3][i] = L(1, 1);
                }
            }
            const Mat<D>& F = a.P.deformationGradient[p];
            f[0][i] = F(0, 0), f[1][i] = F(0, 1), f[2][i] = F(1, 0), f[3][i] = F(1, 1);
        }
    });
    lawInputs(ids, n, c, lambda, mu);
    // In three loops over the run (F and its polar decomposition; the law; the Cauchy stress)
    // rather than one: a lane's chain of divisions and square roots through all of it was too
    // long for the processor to start the next vector of points while one waited (2D, both
    // options: 1.29 -> 1.25 times the default's step, although 888 instead of 873 instructions a
    // point-step; doc/performance.md, "Session 43"). The same operations per lane.
    alignas(64) double u[4][stressRun], rc[stressRun], rs[stressRun], s[4][stressRun];
    forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
        Plain2 F{f[0][i], f[1][i], f[2][i], f[3][i]};
        if constexpr (!moved) {
            F = deformationUpdate2(dt, {l[0][i], l[1][i], l[2][i], l[3][i]}, F);
            f[0][i] = F.xx, f[1][i] = F.xy, f[2][i] = F.yx, f[3][i] = F.yy;
        }
        J[i] = F.xx * F.yy - F.yx * F.xy;  // (Eigen's 2 x 2 determinant)
        Plain2 U;
        ok[i] = polarDecomposition2(F, rc[i], rs[i], U) ? 1.0 : 0.0;
        u[0][i] = U.xx, u[1][i] = U.xy, u[2][i] = U.yx, u[3][i] = U.yy;
    });
    forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
        const double exx = u[0][i] - 1.0, exy = u[1][i] - 0.0, eyx = u[2][i] - 0.0, eyy = u[3][i] - 1.0;
        Law::response2(exx, exy, eyx, eyy, c[i], lambda[i], mu[i], s[0][i], s[1][i], s[2][i], s[3][i], psiPlus[i], psiMinus[i]);
    });
    forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
        const Plain2 t = cauchyStress2(rc[i], rs[i], {u[0][i], u[1][i], u[2][i], u[3][i]}, {s[0][i], s[1][i], s[2][i], s[3][i]});
        sigma[0][i] = t.xx, sigma[1][i] = t.xy, sigma[2][i] = t.yx, sigma[3][i] = t.yy;
    });
    for (int i = 0; i < n; ++i) {
        const int p = ids[i];
        if constexpr (!moved) P.deformationGradient[p] << f[0][i], f[1][i], f[2][i], f[3][i];
        if (ok[i] == 0) {  // a degenerate F: NaN stress, reported by the step's check (corotationalStress)
            out[i].setConstant(std::numeric_limits<double>::quiet_NaN());
            continue;
        }
        out[i] = Sym2::of(sigma[0][i], sigma[1][i], sigma[2][i], sigma[3][i]);
        storeEnergies(p, c[i], psiPlus[i], psiMinus[i]);
    }
}

template <int D, class K>
template <bool moved>
EMP_NOINLINE void Solver<D, K>::corotationalOfRun3(const int* ids, const St* st, int n, double dt, double* J,
                                                   PointTensor<D>* out)
{
    // corotationalOfRun's point-by-point update for n 3D points, its algebra lane by lane as in
    // corotationalOfRun2. The polar decomposition's Newton iteration runs over all lanes until the last
    // has converged; a lane that has converged (or was refused) keeps its value. The 3D law runs as in
    // lawOfRun3 where the run's points share a law with response3. Out of line, so that its size does
    // not change what GCC inlines into the default 3D stress pass (forcing the 3D polar decomposition
    // inline there had cost the default pass 7 % more instructions). All of it is compiled once per
    // lane width (withLaneIsa, pkg/Lanes.hpp), so that GCC vectorises the lanes' loops in the width the
    // processor has; the arrays stay local to each copy (captured by reference, GCC would not vectorise
    // the loops for fear of aliasing).
    if constexpr (D == 3) withLaneIsa([&]() EMP_LAMBDA_INLINE {
        auto& P = points_;
        constexpr int R = stressRun;
        alignas(64) double f[9][R], x[9][R], y[9][R], u[9][R], r[9][R], sig[9][R], state[R];
        alignas(64) lanes9::V4 sums[R][3];  // (the velocity gradient's Lane3 sums, point by point)
        const auto load = [](const double (*a)[R], int i) EMP_LAMBDA_INLINE {
            Plain3 m;
            forEntries([&](auto k) EMP_LAMBDA_INLINE { m.a[k / 3][k % 3] = a[k][i]; });
            return m;
        };
        const auto store = [](double (*a)[R], int i, const Plain3& m) EMP_LAMBDA_INLINE {
            forEntries([&](auto k) EMP_LAMBDA_INLINE { a[k][i] = m.a[k / 3][k % 3]; });
        };
        if constexpr (!moved) {  // (moved: F as G2P left it, no gradient; nor the pass's arrays, out of line)
            const PassArrays a = passArrays();
            for (int i = 0; i < n; ++i) {
                if constexpr (!K::gradientJumpsAtNodes) {
                    // L(row, column) = c_column[row] / h from the Lane3 sums, the operations of
                    // velocityGradient; four points' sums go into the lanes by one transpose per
                    // column, below.
                    Lane3 c[3];
                    st[i].velocitySums3(grid_, [&](int I) EMP_LAMBDA_INLINE -> const Vec<D>& { return a.velocity[I]; },
                                        c[0], c[1], c[2]);
                    for (int d = 0; d < 3; ++d) sums[i][d] = c[d].v;
                } else {
                    const Mat<3> L = velocityGradient(a, ids[i], st[i]);
                    for (int k = 0; k < 9; ++k) r[k][i] = L(k / 3, k % 3);
                }
            }
        }
        const int i4 = n - n % 4;
        if constexpr (!moved && !K::gradientJumpsAtNodes) {
            const lanes9::V4 invh{grid_.invh, grid_.invh, grid_.invh, grid_.invh};
            for (int i = 0; i < i4; i += 4)
                for (int col = 0; col < 3; ++col) {
                    const lanes9::V4 rows[4] = {sums[i][col], sums[i + 1][col], sums[i + 2][col], sums[i + 3][col]};
                    lanes9::V4 t[4];
                    lanes9::transpose4(rows, t);
                    for (int row = 0; row < 3; ++row) {
                        const lanes9::V4 l = invh * t[row];
                        __builtin_memcpy(&r[3 * row + col][i], &l, sizeof l);
                    }
                }
            for (int i = i4; i < n; ++i)
                for (int k = 0; k < 9; ++k) r[k][i] = grid_.invh * sums[i][k % 3][k / 3];
        }
        // The points' F into the lanes, four points at a time (matricesToLanes3: a copy).
        const auto matrix = [&](int i) EMP_LAMBDA_INLINE { return P.deformationGradient[ids[i]].data(); };
        for (int i = 0; i < i4; i += 4) {
            const double* const m[4] = {matrix(i), matrix(i + 1), matrix(i + 2), matrix(i + 3)};
            matricesToLanes3(m, f, i);
        }
        for (int i = i4; i < n; ++i)
            for (int k = 0; k < 9; ++k) f[k][i] = P.deformationGradient[ids[i]](k / 3, k % 3);
        // F <- (I - dt L)^-1 F (unless G2P has updated it); the Newton iteration starts from F
        // (state 1: iterating, 0: refused).
        const auto start = [&](int i, const Plain3& F) EMP_LAMBDA_INLINE {
            store(x, i, F);
            J[i] = determinant3(F);
            state[i] = J[i] > 0 ? 1.0 : 0.0;
        };
        if constexpr (moved)
            for (int i = 0; i < n; ++i) start(i, load(f, i));
        else
            for (int i = 0; i < n; ++i) {
                Plain3 A = load(r, i);
                forEntries([&](auto k) EMP_LAMBDA_INLINE { A.a[k / 3][k % 3] = (k % 4 == 0 ? 1.0 : 0.0) - dt * A.a[k / 3][k % 3]; });
                const Plain3 F = product3(inverse3<false>(A), load(f, i));
                store(f, i, F);
                start(i, F);
            }
        // polarDecomposition's iteration (state 2: converged; 1 after 40 iterations: refused).
        // One iteration takes the lanes still iterating one Newton step from `from` into `to`
        // (the others copied), in one loop that GCC vectorises: it needs the result in another
        // array than the input (an in-place selection is a conditional store, "control flow in
        // loop") and no `omp simd` (which keeps the per-lane Plain3 values in memory, "no
        // vectype"). The iterations alternate between x and y.
        const auto iterate = [&](const double (&from)[9][R], double (&to)[9][R]) EMP_LAMBDA_INLINE {
            for (int i = 0; i < n; ++i) {
                const Plain3 X = load(from, i), next = polarNewton3(X);
                const double change = polarChange3(X, next), s = state[i];
                forEntries([&](auto k) EMP_LAMBDA_INLINE { to[k][i] = s == 1.0 ? next.a[k / 3][k % 3] : X.a[k / 3][k % 3]; });
                state[i] = s == 1.0 ? (change < polarSettle ? 2.0 : 1.0) : s;
            }
            double iterating = 0;
            for (int i = 0; i < n; ++i) iterating += state[i] == 1.0 ? 1.0 : 0.0;
            return iterating > 0;
        };
        for (int it = 0; it < 40; it += 2) {
            if (!iterate(x, y)) {
                std::memcpy(x, y, sizeof x);
                break;
            }
            if (!iterate(y, x)) break;
        }
        // The settling step gives R; U = sym(R^T F).
        for (int i = 0; i < n; ++i) {
            const Plain3 Rot = polarNewton3(load(x, i));
            store(r, i, Rot);
            store(u, i, stretch3(Rot, load(f, i)));
        }
        // The law at eps = U - I: point by point, or, where the run's points share a law with
        // the pointwise 3D response, as lawOfRun3 does (bitwise the same).
        const auto lawAtLane = [&](int i, int p, const Mat<3>& eps) {
            const ElasticMaterial& m = materials_[P.material[p]];
            withLaw(m.law, [&](auto law) {
                const LawResponse<3> resp = decltype(law)::template response<3>(eps, m);
                const Mat<3> s = P.damage[p] * resp.sigmaPlus + resp.sigmaMinus;
                for (int k = 0; k < 9; ++k) sig[k][i] = s(k / 3, k % 3);
                P.energy[p] = P.damage[p] * resp.psiPlus + resp.psiMinus;
                P.history[p] = std::max(P.history[p], resp.psiPlus);
            });
        };
        const auto strainOf = [&](int i) {
            Mat<3> eps;
            for (int k = 0; k < 9; ++k) eps(k / 3, k % 3) = u[k][i] - (k % 4 == 0 ? 1.0 : 0.0);
            return eps;
        };
        if constexpr (!moved) {
            for (int i = 0; i < i4; i += 4) {  // (F back, as it came: lanesToMatrices3)
                double* const m[4] = {matrix(i), matrix(i + 1), matrix(i + 2), matrix(i + 3)};
                lanesToMatrices3(f, i, m);
            }
            for (int i = i4; i < n; ++i)
                for (int k = 0; k < 9; ++k) P.deformationGradient[ids[i]](k / 3, k % 3) = f[k][i];
        }
        for (int i = 0; i < n; ++i)
            if (state[i] != 2.0)  // (a degenerate F: its lane's Cauchy stress is not used)
                for (int k = 0; k < 9; ++k) sig[k][i] = 0;
        const bool shared = withSharedPointwiseLaw(ids, n, [&](auto law) {
            using Law = decltype(law);
            // The lanes' arrays reuse x and y (free after the iteration): strains, then stresses.
            alignas(64) double c[R], lambda[R], mu[R], psiPlus[R], psiMinus[R], ordinary[R];
            lawInputs(ids, n, c, lambda, mu);
            for (int i = 0; i < n; ++i) {
                const int at[6] = {0, 4, 8, 3, 6, 7};  // the lower triangle
                for (int k = 0; k < 6; ++k) x[k][i] = u[at[k]][i] - (k < 3 ? 1.0 : 0.0);
            }
            // (forLanes: GCC keeps this lambda out of the lanes' copies of the enclosing one, so
            // the loop takes its width from forLanes.)
            forLanes(n, [&](int i) EMP_LAMBDA_INLINE {
                bool ok;
                Law::response3(x[0][i], x[1][i], x[2][i], x[3][i], x[4][i], x[5][i], c[i], lambda[i], mu[i], y[0][i],
                               y[1][i], y[2][i], y[3][i], y[4][i], y[5][i], psiPlus[i], psiMinus[i], ok);
                ordinary[i] = ok ? 1.0 : 0.0;
            });
            for (int i = 0; i < n; ++i) {
                if (state[i] != 2.0) continue;
                const int p = ids[i];
                if (ordinary[i] != 1.0) {
                    lawAtLane(i, p, strainOf(i));
                    continue;
                }
                const int row[6] = {0, 1, 2, 1, 2, 2}, col[6] = {0, 1, 2, 0, 0, 1};
                for (int k = 0; k < 6; ++k) sig[3 * row[k] + col[k]][i] = sig[3 * col[k] + row[k]][i] = y[k][i];
                storeEnergies(p, c[i], psiPlus[i], psiMinus[i]);
            }
        });
        if (!shared)
            for (int i = 0; i < n; ++i)
                if (state[i] == 2.0) lawAtLane(i, ids[i], strainOf(i));
        for (int i = 0; i < n; ++i) store(sig, i, cauchyStress3(load(r, i), load(u, i), load(sig, i)));
        for (int i = 0; i < i4; i += 4) {
            double* const m[4] = {out[i].data(), out[i + 1].data(), out[i + 2].data(), out[i + 3].data()};
            lanesToMatrices3(sig, i, m);
        }
        for (int i = i4; i < n; ++i)
            for (int k = 0; k < 9; ++k) out[i](k / 3, k % 3) = sig[k][i];
        for (int i = 0; i < n; ++i)
            if (state[i] != 2.0)  // a degenerate F: NaN stress, reported by the step's check
                out[i].setConstant(std::numeric_limits<double>::quiet_NaN());
    });
}

template <int D, class K>
template <bool withGravity, bool corotational>
EMP_ALWAYS_INLINE void Solver<D, K>::scatterInternalForce(const PassArrays& a, int k, const PointTensor<D>& sigma,
                                                           const Vec<D>& gravity, double J)
{
    // f_I += N_I m_p b - V_p sigma_p grad N_I (Eqs 13-14). Without gravity the body force term
    // is left out (the same sums: f + (0 - x) is f - x in floating point). The co-rotational
    // update's volume is the current one, J V_p (V_p sigma = V_0 tau, Kinematics.hpp).
    const auto& P = a.P;
    const int p = a.order[k];
    const St& st = a.stencil[k];
    const double volume = corotational ? P.volume[p] * J : P.volume[p];
    const Mat<D> vs = volume * full(sigma);
    scatterForce<withGravity>(a, p, st, st.dw, vs, gravity);
}

template <int D, class K>
template <bool withGravity>
EMP_ALWAYS_INLINE void Solver<D, K>::scatterForce(const PassArrays& a, int p, const St& st, const double (*dv)[S], const Mat<D>& vs,
                                                   const Vec<D>& gravity)
{
    const auto& g = grid_;
    const auto& P = a.P;
    if (st.regular()) {  // (the same sums by rows: Stencil::forEachRowProjected)
        const Vec<D> fb = withGravity ? Vec<D>(P.mass(p) * gravity) : Vec<D>::Zero();
        st.forEachRowProjected(g, vs, dv, [&](int I0, const double* N, const double* t) EMP_LAMBDA_INLINE {
            double* f = a.force[I0].data();
            for (int e = 0; e < S * D; ++e) {
                if constexpr (withGravity)
                    f[e] += N[e / D] * fb[e % D] - t[e];
                else
                    f[e] -= t[e];
            }
        });
        return;
    }
    if constexpr (withGravity) {
        const Vec<D> fb = P.mass(p) * gravity;
        st.forEachProjected(g, vs, dv, [&](int I, double N, const Vec<D>& vsGrad) { a.force[I] += N * fb - vsGrad; });
    } else {
        st.forEachProjected(g, vs, dv, [&](int I, double, const Vec<D>& vsGrad) { a.force[I] -= vsGrad; });
    }
}

template <int D, class K> void Solver<D, K>::startStressPass()
{
    stressNonFinite_ = 0;
    stepLaw_ = materials_.empty() ? -1 : materials_[0].law;
    for (const ElasticMaterial& m : materials_)
        if (m.law != stepLaw_) stepLaw_ = -1;
}

template <int D, class K>
EMP_ALWAYS_INLINE void Solver<D, K>::checkStresses(const int* ids, int n, const PointTensor<D>* sigma)
{
    // A run's stresses checked: their sum is finite unless one is not (G2P's check reports the
    // point; a sum that overflowed with every value finite is told apart there). In two sums
    // (even and odd points), so that the additions form two chains of half the length.
    double even = 0, odd = 0;
    int i = 0;
    for (; i + 1 < n; i += 2) {
        even += sumOf(sigma[i]);
        odd += sumOf(sigma[i + 1]);
    }
    if (i < n) even += sumOf(sigma[i]);
    if (!std::isfinite(even + odd)) __atomic_store_n(&stressNonFinite_, 1, __ATOMIC_RELAXED);
    if (stressObserver_) stressObserver_(ids, n, sigma);
}

template <int D, class K> void Solver<D, K>::stressAndInternalForce(double dt, int nThreads)
{
    // In runs of stressRun points of each strip (Scheduler::scatterStrips): the strains of a run,
    // its law (lawOfRun), then its forces. The run's stencils stay in the L1 cache between the
    // loops, and so do its stresses, which are not stored (MaterialPoints::stressOf gives them
    // again).
    const Vec<D> gravity = settings_.gravity.head<D>();
    const auto& order = schedule_.order();
    const std::vector<NodeField> fields{{grid_.force.data()->data(), D}};
    std::function<void(int)> between;
    if (dist_) between = [&](int k) { dist_->afterPhase(k, schedule_.numPhases(), grid_, fields); };
    const auto pass = [&](auto withGravity, auto corotational) {
        // A run's update (its strains and law, or the co-rotational update) runs before the
        // forces of the run before it: the update's lanes wait on long chains of divisions and
        // square roots, and the previous run's scatter, which does not need their results, fills
        // that time. Each node still receives the forces run by run, in slot order.
        const auto update = [&](int begin, int end, double* J, PointTensor<D>* sigma) EMP_LAMBDA_INLINE {
            if constexpr (decltype(corotational)::value) {
                corotationalOfRun(&order[begin], &stencil_[begin], end - begin, dt, J, sigma);
            } else {
                const auto strains = [&]() EMP_LAMBDA_INLINE {
                    const PassArrays a = passArrays();
                    const double step = dt, invh = grid_.invh;  // (locals: in registers)
                    for (int k = begin; k < end; ++k) updateStrain(a, a.order[k], a.stencil[k], step, invh);
                };
                withLaneIsa(strains);  // (the gradients' 4-lane sums in the lanes' width)
                lawOfRun(&order[begin], end - begin, sigma);
            }
            checkStresses(&order[begin], end - begin, sigma);
        };
        const auto forces = [&](int begin, int end, const double* J, const PointTensor<D>* sigma) EMP_LAMBDA_INLINE {
            withLaneIsa([&]() EMP_LAMBDA_INLINE {  // (the rows' loops in the lanes' width)
                const PassArrays a = passArrays();
                for (int k = begin; k < end; ++k)
                    scatterInternalForce<decltype(withGravity)::value, decltype(corotational)::value>(
                        a, k, sigma[k - begin], gravity, decltype(corotational)::value ? J[k - begin] : 0.0);
            });
        };
        const auto strip = [&](int stripBegin, int stripEnd) {
            double J[2][stressRun];  // (the co-rotational update's det F, for the current volume)
            PointTensor<D> sigma[2][stressRun];
            int previous = -1, now = 0;
            for (int begin = stripBegin; begin < stripEnd; begin += stressRun, now ^= 1) {
                update(begin, std::min(begin + stressRun, stripEnd), J[now], sigma[now]);
                if (previous >= 0) forces(previous, begin, J[now ^ 1], sigma[now ^ 1]);
                previous = begin;
            }
            if (previous >= 0) forces(previous, stripEnd, J[now ^ 1], sigma[now ^ 1]);
        };
        if (strips_) {  // (a wavefront step)
            strips_->stress = strip;
            gridToParticle(strips_->dt, strips_->threads);
            return;
        }
        schedule_.scatterStrips(nThreads, strip, between);
    };
    if (!strips_) startStressPass();  // (a wavefront step started it before P2G)
    // Two forms: the small-strain update's and the co-rotational one's (the current volume).
    // (With APIC too, the stresses are made before P2G, which scatters their force:
    // stressBeforeTransfer.)
    const auto withForm = [&](auto withGravity) {
        if (settings_.stressUpdate == StressUpdate::corotational)
            pass(withGravity, std::true_type{});
        else
            pass(withGravity, std::false_type{});
    };
    gravity.isZero(0.0) ? withForm(std::false_type{}) : withForm(std::true_type{});
    if (dist_) dist_->finishScatter(grid_, fields);
}

template <int D, class K> void Solver<D, K>::stressBeforeTransfer(double dt, int nThreads)
{
    // APIC with the co-rotational update (deformationInG2P): every point's stress from the F that
    // G2P left (corotationalOfRun: polar decomposition, law, Cauchy stress), in runs of stressRun
    // slots, times the current volume J V_0 (V sigma = V_0 tau, Kinematics.hpp), kept by slot
    // for P2G, which scatters their force. Nothing here reads the grid; blocks of slots that do
    // not depend on the thread count (Scheduler::gather).
    startStressPass();
    const auto& order = schedule_.order();
    const std::size_t n = order.size();
    slotStress_.resize(n * slotStride);
    schedule_.gather(
        nThreads, 0,
        [&](int begin, int end, int&) {
            double J[stressRun];
            PointTensor<D> sigma[stressRun];  // (zeroed once a block, not once a run: a memset)
            for (int b = begin; b < end; b += stressRun) {
                const int e = std::min(b + stressRun, end);
                corotationalOfRun(&order[b], &stencil_[b], e - b, dt, J, sigma);
                checkStresses(&order[b], e - b, sigma);
                for (int k = b; k < e; ++k)
                    toSlot(sigma[k - b], points_.volume[order[k]] * J[k - b], &slotStress_[static_cast<std::size_t>(k) * slotStride]);
            }
        },
        [](int&, int) {});
}

template <int D, class K> typename Solver<D, K>::St Solver<D, K>::stencilOf(int p)
{
    St st;
    st.compute(points_.x[p], grid_, lp_);
    // As in P2G: a support outside the box of the marked nodes has no node to map.
    if (mapping_ && St::overlaps(points_.x[p], grid_, markedLo_, markedHi_)) mapSupport(st, p, static_cast<int>(points_.size()));
    return st;
}

template <int D, class K>
const typename Solver<D, K>::St& Solver<D, K>::stepStencil(int p, St& scratch, int slot)
{
    // P2G's stencil of p (the same numbers as stencilOf: the points have not moved since, and
    // its remap slot is p's own), in slot `slot` or found in p's tile by its id; stencilOf where
    // p was not binned.
    // (In a wavefront step, stencil_ holds only the overflow's strips: pipelineLoop.)
    const int k = slot >= -1 ? slot : schedule_.slotOf(p);
    if (!strips_ && k >= 0 && static_cast<std::size_t>(k) < stencil_.size()) return stencil_[k];
    scratch = stencilOf(p);
    return scratch;
}

template <int D, class K> void Solver<D, K>::erode(double dt, int nThreads)
{
    // Eigenerosion (Eqs 23-24) belongs between the stress update and the internal force, so that
    // an eroded point acts with sigma- alone in this step already. The force is linear in the
    // stress: the eroded points' change of stress is scattered as a correction, serially in the
    // erosion order, instead of a separate pass over all points.
    if (!erosion_) return;
    if (dist_) dist_->ghosts(points_, grid_, erosion_->settings().kappa, ghosts_);
    const Support rows(this);
    if (erosion_->apply(points_, materials_, steps_ + 1, time_ + dt, nThreads, dist_ ? &ghosts_ : nullptr,
                        dist_ ? &dist_->transport() : nullptr, &rows, &grid_) == 0)
        return;
    const auto& eroded = erosion_->lastEroded();
    if (deformationInG2P()) {
        // Before P2G (stressBeforeTransfer): the eroded points' stresses are replaced in their
        // slots, and P2G scatters the force of the stresses as they now are.
        for (const int p : eroded) {
            // (V as stressBeforeTransfer took it: V_0 times corotationalOfRun's J, Eigen's
            // determinant of the same F.)
            double* slot = &slotStress_[static_cast<std::size_t>(schedule_.slotOf(p)) * slotStride];
            const double V = points_.volume[p] * points_.deformationGradient[p].determinant();
            toSlot(PointTensor<D>(points_.stressOf(p, materials_)), V, slot);
        }
        return;
    }
    const auto& before = erosion_->stressBeforeErosion();
    auto& g = grid_;
    const bool corotational = settings_.stressUpdate == StressUpdate::corotational;
    for (std::size_t e = 0; e < eroded.size(); ++e) {
        const int p = eroded[e];
        St scratch;
        const St& st = stepStencil(p, scratch);
        double volume = points_.volume[p];
        if (corotational) volume *= points_.deformationGradient[p].determinant();
        // sigma- now (c = 0; the co-rotational update's rotated back), less the stress the force used
        const Mat<D> dvs = volume * (points_.stressOf(p, materials_) - before[e]);
        const std::int64_t id = dist_ ? points_.globalId[p] : p;
        st.forEachProjected(g, dvs, [&](int I, double, const Vec<D>& dvsGrad) { addNodeForce(I, -dvsGrad, 0, id); });
    }
}

template <int D, class K> void Solver<D, K>::tractionForces()
{
    // Traction on boundary points (Eq 28); few points, applied serially in a fixed order.
    // A layer's points are mostly consecutive ids, and a tile holds its points in id order: the
    // slot after the last one found is tried before the search in p's tile (Scheduler::slotOf).
    auto& g = grid_;
    const auto& order = schedule_.order();
    tractionSlots_.clear();
    int next = -1;
    for (std::size_t c = 0; c < tractions_.size(); ++c) {
        const auto& tc = tractions_[c];
        const Vec<D> t = (rampFactor(time_, tc.rampTime) * tc.traction).head<D>();
        forEachTractionPoint(c, [&](int p, int k) {
            const bool follows = next >= 0 && next < static_cast<int>(order.size()) && order[next] == p;
            const int slot = follows ? next : schedule_.slotOf(p);
            next = slot >= 0 ? slot + 1 : -1;
            tractionSlots_.push_back(slot);  // (for accumulateExternalWork)
            St scratch;
            const St& st = stepStencil(p, scratch, slot);
            const Vec<D> f = t * (points_.volume[p] / tc.layer);
            st.forEach(g, [&](int I, double N, const Vec<D>&) { addNodeForce(I, N * f, 1 + static_cast<std::int64_t>(c), k); });
        });
    }
}

template <int D, class K> void Solver<D, K>::Support::pointsInRows(int lo, int hi, std::vector<int>& ids) const
{
    // A point of cell row c (along the last axis) has its base node in [c - (S - 1), c]: strip
    // s holds the bases [s w, (s + 1) w). The tiles of strips s0 .. s1 are one range of slots.
    // Their points are marked by id in a bitmap and read back in increasing id order: linear in
    // the rows' points (merging the tiles' sorted runs one after another grew with the square
    // of the number of strips). Not thread-safe: the bitmap is the solver's.
    const auto& sc = s_->schedule_;
    const auto& start = sc.tileStart();
    const int nc = sc.numColumns(), strips = (static_cast<int>(start.size()) - 1) / nc;
    constexpr int w = Scheduler<D>::stripWidth;
    ids.clear();
    if (strips <= 0 || hi < lo) return;
    const int s0 = std::max(lo - (K::S - 1), 0) / w, s1 = std::min(std::max(hi, 0) / w, strips - 1);
    if (s1 < s0) return;
    const int* order = sc.order().data();
    const int first = start[static_cast<std::size_t>(s0) * nc], last = start[static_cast<std::size_t>(s1 + 1) * nc];
    if (first >= last) return;
    auto& marks = s_->rowMarks_;
    const std::size_t words = (static_cast<std::size_t>(sc.size()) + 63) / 64;
    if (marks.size() != words) marks.assign(words, 0);
    int lowest = INT_MAX, highest = -1;
    for (int k = first; k < last; ++k) {
        const int p = order[k];
        marks[p >> 6] |= std::uint64_t(1) << (p & 63);
        lowest = std::min(lowest, p);
        highest = std::max(highest, p);
    }
    for (int word = lowest >> 6; word <= highest >> 6; ++word) {
        std::uint64_t m = marks[word];
        marks[word] = 0;
        for (; m; m &= m - 1) ids.push_back(word * 64 + __builtin_ctzll(m));
    }
}

template <int D, class K> void Solver<D, K>::applyConditionsAfterForces(double dt)
{
    const Support support(this);
    GridState<D> s{grid_, points_, phantom_, time_ + 0.5 * dt, dt, &support};
    ownedNodes(s.ownedLo, s.ownedHi);
    if (dist_ && dist_->rankColumns() > 1) {
        s.ownedColumnLo = dist_->ownedColumnLo();
        s.ownedColumnHi = dist_->ownedColumnHi();
    }
    if (dist_) {
        workBefore_.clear();
        for (const auto& c : velocityConditions_) workBefore_.push_back(c->work);
    }
    if (contact_) {
        contact_->afterForces(s);
        contactWork_ += contact_->work;
    }
    if (crackContact_ && !phantom_.empty()) crackContact_->afterForces(s);
    bodyContact_.pairsInContact = mapping_ == 2 ? bodyContact_.template apply<true>(grid_, phantom_, dt) : 0;
    for (auto& c : conditions_) c->afterForces(s);
}

template <int D, class K> void Solver<D, K>::setCrackContact(bool on, double friction)
{
    require(std::isfinite(friction) && friction >= 0, "crackFriction", friction, "0 <= crackFriction < inf");
    if (!on) {
        crackContact_.reset();
        return;
    }
    if (!crackContact_) crackContact_ = std::make_shared<CrackFaceContact<D>>();
    crackContact_->friction = friction;
}

template <int D, class K> EMP_ALWAYS_INLINE void Solver<D, K>::updateAt(int I, double dt)
{
    auto& g = grid_;
    g.momentum[I] += dt * g.force[I];
    g.velocity[I] = g.momentum[I] * g.invMass[I];
    g.force[I] *= g.invMass[I];
}

template <int D, class K> void Solver<D, K>::updateGrid(double dt, int nThreads)
{
    // Nodal momentum P^{n+1/2} = P^{n-1/2} + dt f (Eq 29); the grid then holds the nodal
    // acceleration (for Eq 30) in `force` and the velocity (for Eq 31) in `velocity`.
    forEachWorkNode(nThreads, [&](int I) { updateAt(I, dt); });
}

template <int D, class K> void Solver<D, K>::accumulateExternalWork(double dt)
{
    // f . (v^{n-1/2} + v^{n+1/2}) dt / 2 at the nodes, with v^{n-1/2} = v^{n+1/2} - dt a (the grid
    // holds v^{n+1/2} and a now); the velocity conditions add theirs in afterForces. Serial and
    // in a fixed order; only tractions and a non-zero gravity cost anything.
    const auto& g = grid_;
    workAtStart_[0] = tractionWork_;
    workAtStart_[1] = gravityWork_;
    std::size_t next = 0;
    for (std::size_t c = 0; c < tractions_.size(); ++c) {
        const auto& tc = tractions_[c];
        const Vec<D> t = (rampFactor(time_, tc.rampTime) * tc.traction).head<D>();
        forEachTractionPoint(c, [&](int p, int) {
            St scratch;  // (the points in tractionForces' order: their slots from there)
            const St& st = stepStencil(p, scratch, next < tractionSlots_.size() ? tractionSlots_[next] : -2);
            ++next;
            const Vec<D> f = t * (points_.volume[p] / tc.layer);
            st.forEach(g, [&](int I, double N, const Vec<D>&) {
                tractionWork_ += dt * N * f.dot(g.velocity[I] - 0.5 * dt * g.force[I]);
            });
        });
    }
    const Vec<D> gravity = settings_.gravity.head<D>();
    int lo, hi;
    ownedNodes(lo, hi);
    const auto gravityOn = [&](int I) { gravityWork_ += dt * g.mass[I] * gravity.dot(g.velocity[I] - 0.5 * dt * g.force[I]); };
    if (!gravity.isZero(0.0)) {
        if (dist_ && dist_->rankColumns() > 1) {  // (the owned node columns of those planes)
            for (int I = lo; I < hi; ++I)
                if (I % g.n[0] >= dist_->ownedColumnLo() && I % g.n[0] < dist_->ownedColumnHi()) gravityOn(I);
        } else {
            for (int I = lo; I < hi; ++I) gravityOn(I);
        }
        if (dist_)  // the twins of the owned nodes
            for (int t = g.numNodes(); t < g.totalNodes(); ++t) {
                const int I = twinRegular_[t - g.numNodes()];
                if (I >= lo && I < hi && (dist_->rankColumns() == 1 ||
                                          (I % g.n[0] >= dist_->ownedColumnLo() && I % g.n[0] < dist_->ownedColumnHi())))
                    gravityOn(t);
            }
    }
}

template <int D, class K> void Solver<D, K>::gridToParticle(double dt, int nThreads)
{
    // FLIP velocity update (Eq 30) and position from nodal momentum (Eq 31). Each point writes
    // only itself; the loop runs in the binned order to stream the stencils. The checks of the
    // new state cost no branch per point: the loop keeps the bounding box of the positions and
    // a sum of every value checked (a non-finite value makes it non-finite), a D-vector of
    // sums without a sum across its components per point (only its finiteness is read); the
    // stresses were checked likewise by the stress pass (stressNonFinite_). Only when either is
    // out of bounds does a second, serial scan find the first point at fault.
    struct Check {
        Vec<D> lo = Vec<D>::Constant(std::numeric_limits<double>::infinity());
        Vec<D> hi = Vec<D>::Constant(-std::numeric_limits<double>::infinity());
        Vec<D> sum = Vec<D>::Zero();
        double vmax2 = 0, kinetic = 0;
    };
    auto& P0 = points_;
    const auto& g = grid_;
    // The new velocity and position of point p, and the checks (both transfers).
    const auto finish = [&](const PassArrays& A, int p, const Vec<D>& v, const Vec<D>& vg, Check& acc) EMP_LAMBDA_INLINE {
        const auto& P = A.P;
        const Vec<D> x = P.x[p] + dt * vg;
        P.v[p] = v;
        P.x[p] = x;
        acc.lo = acc.lo.cwiseMin(x);
        acc.hi = acc.hi.cwiseMax(x);
        acc.sum += v + x;  // (the stresses: checked by the stress pass, stressNonFinite_)
        acc.vmax2 = std::max(acc.vmax2, v.squaredNorm());
    };
    const auto flip = [&](const PassArrays& A, int k, Check& acc) EMP_LAMBDA_INLINE {
        const auto& P = A.P;
        const int p = A.order[k];
        Vec<D> a = Vec<D>::Zero(), vg = Vec<D>::Zero();
        const St& st = A.stencil[k];
        if constexpr (D == 3) {  // (the same sums in 4-lane vectors: Lane3)
            Lane3 a3 = Lane3::zero(), v3 = Lane3::zero();
            if (st.regular())
                st.forEachRow(g, [&](int I0, const double* N) EMP_LAMBDA_INLINE {
                    for (int i = 0; i < S; ++i) {
                        a3 += N[i] * Lane3::load(A.force[I0 + i]);
                        v3 += N[i] * Lane3::load(A.velocity[I0 + i]);
                    }
                });
            else
                st.forEach(g, [&](int I, double N, const Vec<D>&) {
                    a3 += N * Lane3::load(A.force[I]);
                    v3 += N * Lane3::load(A.velocity[I]);
                });
            a = a3.vec();
            vg = v3.vec();
        } else if (st.regular()) {
            if constexpr (S == 3) {  // (the same products summed by columns, in vectors: Stencil::columnSums2)
                st.columnSums2(g, A.force, A.velocity, a, vg);
            } else {  // (the nodes' addresses from each row's first)
                st.forEachRow(g, [&](int I0, const double* N) EMP_LAMBDA_INLINE {
                    for (int i = 0; i < S; ++i) {
                        a += N[i] * A.force[I0 + i];
                        vg += N[i] * A.velocity[I0 + i];
                    }
                });
            }
        } else {
            st.forEach(g, [&](int I, double N, const Vec<D>&) {
                a += N * A.force[I];
                vg += N * A.velocity[I];
            });
        }
        const Vec<D> v = P.v[p] + dt * a;
        acc.kinetic += 0.5 * P.mass(p) * P.v[p].dot(v);
        finish(A, p, v, vg, acc);
    };
    // APIC: v_p = sum N v_I and B_p = sum N v_I (x_I - x_p)^T (Kinematics.hpp). Forced inline
    // into the loop. With the co-rotational update (`moveF`), F too (deformationInG2P).
    const auto apicWith = [&](auto moveF) { return [&](const PassArrays& A, int k, Check& acc) EMP_LAMBDA_INLINE {
        const auto& P = A.P;
        const int p = A.order[k];
        const St& st = A.stencil[k];
        Vec<D> vg;
        Mat<D> Bu;  // B_p / h
        // Offsets in cells, from P2G's frame (the same numbers as cellOffsets).
        const auto sums = [&]() EMP_LAMBDA_INLINE {
            double u[D][S];
            for (int d = 0; d < D; ++d)
                for (int i = 0; i < S; ++i) u[d][i] = A.offset[d][k] + i;
            st.affineSums(g, u, [&](int I) -> const Vec<D>& { return A.velocity[I]; }, vg, Bu);
        };
        if constexpr (S == 3) {  // (on a regular support: Stencil::affineColumnSums2, affineRowSums3)
            if (!st.regular())
                sums();
            else if constexpr (D == 2)
                st.affineColumnSums2(g, A.offset[0][k], A.offset[1][k], A.velocity, vg, Bu);
            else
                st.affineRowSums3(g, A.offset[0][k], A.offset[1][k], A.offset[2][k], A.velocity, vg, Bu);
        } else {
            sums();
        }
        // m tr(C_old D C^T) / 2 at this position (C = B D^-1): tr(C_old B^T) = tr(Cu Bu^T) with
        // P2G's Cu = h C_old.
        double affine = 0;
        for (int d = 0; d < D; ++d) affine += P.affineVelocity[p].col(d).dot(Bu.col(d));
        acc.kinetic += 0.5 * P.mass(p) * (P.v[p].dot(vg) + affine);
        P.affineVelocity[p] = g.h * Bu;
        if constexpr (decltype(moveF)::value) {
            // The points move by x <- x + dt sum N v_I; C_p = B_p D_p^-1 at the position the sums
            // were taken at (Bu diag(r), r = 1 / (h du) from P2G's frame there, kept in
            // PassArrays::scale) is that motion's gradient divided by dt for any affine field of
            // v_I, and its least-squares fit otherwise: F <- (I + dt C_p) F.
            Mat<D> Cdt;
            for (int d = 0; d < D; ++d) Cdt.col(d) = (dt * A.scale[d][k]) * Bu.col(d);
            Mat<D>& F = P.deformationGradient[p];
            F += Cdt * F;
        }
        finish(A, p, vg, vg, acc);
    }; };
    const auto combine = [](Check& total, const Check& part) {
        total.lo = total.lo.cwiseMin(part.lo);
        total.hi = total.hi.cwiseMax(part.hi);
        total.sum += part.sum;
        total.vmax2 = std::max(total.vmax2, part.vmax2);
        total.kinetic += part.kinetic;
    };
    // Each block of points inside withLaneIsa (the sums in the lanes' width; 3D: Lane3).
    const auto inLanes = [&](const auto& point) {
        return [&](int begin, int end, Check& acc) {
            const auto block = [&]() EMP_LAMBDA_INLINE {
                Check local = acc;  // (in registers: the caller's is in memory)
                const PassArrays A = passArrays();
                for (int k = begin; k < end; ++k) point(A, k, local);
                acc = local;
            };
            withLaneIsa(block);
        };
    };
    Check c;
    if (strips_) {
        // A wavefront step: the checks strip by strip, folded in strip order, as the passes'
        // Scheduler::gather does: the same sums, bitwise (one and two workers too).
        const auto& start = schedule_.stripStart();
        std::vector<Check> parts(start.size() - 1);
        const auto block = inLanes(flip);
        strips_->g2p = [&](int s) {
            Check acc{};
            block(start[s], start[s + 1], acc);
            parts[s] = acc;
        };
        pipelineLoop();
        for (const Check& part : parts) combine(c, part);
    } else
        c = deformationInG2P()                       ? schedule_.gather(nThreads, Check{}, inLanes(apicWith(std::true_type{})), combine)
              : settings_.transfer == Transfer::apic ? schedule_.gather(nThreads, Check{}, inLanes(apicWith(std::false_type{})), combine)
                                                     : schedule_.gather(nThreads, Check{}, inLanes(flip), combine);
    const auto offGrid = [&](const Vec<D>& x) {
        for (int d = 0; d < D; ++d) {
            const int b = K::base((x[d] - g.origin[d]) * g.invh);  // monotone in x
            if (!(b >= 0 && b <= g.n[d] - S)) return true;
        }
        return false;
    };
    double nonFinite = !c.sum.allFinite() || stressNonFinite_, off = P0.size() > 0 && (offGrid(c.lo) || offGrid(c.hi));
    if (dist_) {
        // Every rank learns of a fault anywhere (and stops with it); the diagnostics are summed.
        std::vector<double> sum{c.kinetic, tractionWork_ - workAtStart_[0], gravityWork_ - workAtStart_[1]};
        for (std::size_t i = 0; i < velocityConditions_.size(); ++i) {
            const auto& vc = *velocityConditions_[i];
            for (int d = 0; d < 3; ++d) sum.push_back(vc.reaction[d]);
            sum.push_back(vc.work - workBefore_[i]);
        }
        std::vector<double> max{nonFinite, off, c.vmax2};
        dist_->transport().sum(sum.data(), static_cast<int>(sum.size()));
        dist_->transport().max(max.data(), static_cast<int>(max.size()));
        c.kinetic = sum[0];
        tractionWork_ = workAtStart_[0] + sum[1];
        gravityWork_ = workAtStart_[1] + sum[2];
        for (std::size_t i = 0; i < velocityConditions_.size(); ++i) {
            auto& vc = *velocityConditions_[i];
            for (int d = 0; d < 3; ++d) vc.reaction[d] = sum[3 + 4 * i + d];
            vc.work = workBefore_[i] + sum[3 + 4 * i + 3];
        }
        nonFinite = max[0];
        off = max[1];
        c.vmax2 = max[2];
    }
    kineticAtStep_ = c.kinetic;
    maxSpeed_ = std::sqrt(c.vmax2);
    time_ += dt;
    ++steps_;
    const auto id = [&](int p) { return dist_ ? points_.globalId[p] : p; };  // the single-process id
    if (nonFinite > 0) {
        int first = INT_MAX;
        for (std::size_t p = 0; p < P0.size() && first == INT_MAX; ++p)
            if (!P0.v[p].allFinite() || !P0.x[p].allFinite() || !P0.stressOf(p, materials_).allFinite()) first = static_cast<int>(p);
        if (dist_ && first == INT_MAX)
            throw SimulationError("EigenMPM: a non-finite value appeared in step " + std::to_string(steps_) +
                                  " on another rank (its message names the point)");
        if (first != INT_MAX) {  // (else the sum overflowed: every value is finite)
            std::ostringstream s;
            s << "EigenMPM: a non-finite value appeared in step " << steps_ << " (t = " << time_
              << " s) at point id " << id(first) << " (stress, velocity or position is NaN or "
              << "infinite); check the loads, the material constants and dt";
            throw SimulationError(s.str());
        }
    }
    if (dist_ && off > 0 && !(P0.size() > 0 && (offGrid(c.lo) || offGrid(c.hi))))
        throw SimulationError("EigenMPM: a point left the grid in step " + std::to_string(steps_) +
                              " on another rank (its message names the point)");
    if (off > 0) {  // (no point: the box is empty)
        int first = 0;
        while (!offGrid(P0.x[first])) ++first;  // the box's corner is one point's coordinate
        Vec<D> hiCorner;
        for (int d = 0; d < D; ++d) hiCorner[d] = g.origin[d] + (g.n[d] - 1) * g.h;
        std::ostringstream s;
        s << "EigenMPM: point id " << id(first) << " left the grid in step " << steps_ << " (t = "
          << time_ << " s): position " << str<D>(P0.x[first]) << ", grid nodes span "
          << str<D>(g.origin) << " to " << str<D>(hiCorner)
          << "; give a larger domain (the point is kept, the run stops)";
        throw SimulationError(s.str());
    }
}

// =============================================================================================
// Set-up
// =============================================================================================
template <int D, class K> Solver<D, K>::Solver(const SolverSettings& s) : settings_(s)
{
    require(std::isfinite(s.h) && s.h > 0, "h (cell size, m)", s.h, "h > 0");
    require(s.ppc >= 1 && s.ppc <= 64, "ppc (points per cell per direction)", s.ppc, "1 <= ppc <= 64");
    require(s.massCutoff >= 0 && s.massCutoff < 1, "massCutoff (fraction of the mean point mass)",
            s.massCutoff, "0 <= massCutoff < 1");
    require(s.padding >= 1, "padding (cells)", s.padding, "padding >= 1");
    require(s.columnCells == 0 || (s.columnCells >= K::S - 1 && s.columnCells <= 1 << 20), "columnCells", s.columnCells,
            "0 (no columns) or " + std::to_string(K::S - 1) + " to 2^20 cells for this shape function");
    require(s.gravity.allFinite(), "gravity (m/s2)", "non-finite or not set", "finite components");
    require(s.transfer != Transfer::unset, "transfer", "not set", "'FLIP' or 'APIC'");
    require(s.stressUpdate != StressUpdate::unset, "stressUpdate", "not set", "'smallStrain' or 'corotational'");
    if (s.transfer == Transfer::apic && !K::affineTransfer)
        require(false, "transfer", std::string("'APIC' with shape '") + K::name + "'",
                "'FLIP' with this shape; APIC needs a shape whose moment matrix stays invertible (uGIMP)");
    lp_ = 0.5 / s.ppc;
    points_.affine = s.transfer == Transfer::apic;
    points_.deformation = s.stressUpdate == StressUpdate::corotational;
    schedule_.setColumns(s.columnCells);
}

template <int D, class K>
int Solver<D, K>::addMaterial(double E, double nu, double rho, bool planeStress, int law)
{
    materials_.push_back(ElasticMaterial::make(E, nu, rho, planeStress, D, law));
    points_.density.push_back(materials_.back().rho);
    return static_cast<int>(materials_.size()) - 1;
}

template <int D, class K>
int Solver<D, K>::addPoint(const Eigen::Vector3d& x, const Eigen::Vector3d& v, double volume, int material)
{
    const bool held = dist_ && heldSetup_ && !dist_->partitioned();
    const int id = held ? nextId_ : static_cast<int>(points_.size());
    if (dist_ && !held) require(false, "point", "added to a distributed run", "points added before distribute()");
    if (held && id >= heldEnd_)
        require(false, "point", "added beyond the share holdPoints() announced", "holdPoints() before each share");
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
    points_.add(x.head<D>(), v.head<D>(), volume, material);  // (mass rho V: MaterialPoints::mass)
    if (held) {
        points_.globalId.push_back(id);
        ++nextId_;
    }
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
    const bool held = dist_ && heldSetup_;  // (a run distributed at set-up: every rank is here)
    double meanMass = 0;
    if (held) initializeHeld(lo, hi, meanMass);
    if (haveDomain_) {
        lo = domainLo_;
        hi = domainHi_;
    } else if (held && globalPoints_ > 0) {
        pad = settings_.padding;
    } else if (!held && points_.size() > 0) {
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
    // The first point outside, by its one-process id (in a run distributed at set-up the ranks
    // agree on it, so that every rank stops with the same message).
    double outside = -1;
    Vec<D> where = Vec<D>::Zero();
    for (std::size_t p = 0; p < points_.size() && outside < 0; ++p)
        for (int d = 0; d < D; ++d) {
            const int b = K::base((points_.x[p][d] - origin[d]) * grid_.invh);
            if (b < 0 || b > n[d] - S) {
                outside = held ? points_.globalId[p] : static_cast<double>(p);
                where = points_.x[p];
                break;
            }
        }
    if (held) {
        double first = outside < 0 ? -static_cast<double>(INT_MAX) : -outside;  // the smallest id: max of -id
        dist_->transport().max(&first, 1);
        const bool mine = outside >= 0 && -first == outside;
        outside = first == -static_cast<double>(INT_MAX) ? -1 : -first;
        if (!mine) where.setZero();
        dist_->transport().sum(where.data(), D);  // (only its rank adds it)
    }
    if (outside >= 0)
        throw SimulationError("EigenMPM: point " + std::to_string(static_cast<long>(outside)) + " at " + str<D>(where) +
                              " lies outside the domain or too close "
                              "to its edge (the shape function needs nodes around it); "
                              "enlarge the domain by at least " + std::to_string(S - 1) + " h");
    if (!held) {
        for (std::size_t p = 0; p < points_.size(); ++p) meanMass += points_.mass(p);
        if (points_.size() > 0) meanMass /= points_.size();
    }
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
        require(p >= 0 && p < numGlobalPoints(), "point id", p, "0 <= id < " + std::to_string(numGlobalPoints()));
    require(mask != 0 && mask < (1u << D), "components (bit mask)", mask,
            "1 .. " + std::to_string((1u << D) - 1) + " (at least one direction)");
    require(velocity.head<D>().allFinite(), "velocity", "non-finite", "finite components");
    require(std::isfinite(rampTime) && rampTime >= 0, "rampTime (s)", rampTime, "rampTime >= 0");
    auto c = std::make_shared<VelocityCondition<D>>();
    c->nodes = nodes;
    c->points = points;
    c->mask = mask;
    c->velocity = velocity;
    c->rampTime = rampTime;
    velocityConditions_.push_back(c);
    conditions_.push_back(c);
    return static_cast<int>(velocityConditions_.size()) - 1;
}

template <int D, class K>
void Solver<D, K>::setConditionVelocity(int id, const Eigen::Vector3d& velocity, double rampTime)
{
    require(id >= 0 && id < static_cast<int>(velocityConditions_.size()), "condition id", id, "an existing id");
    require(velocity.head<D>().allFinite(), "velocity", "non-finite", "finite components");
    velocityConditions_[id]->velocity = velocity;
    velocityConditions_[id]->rampTime = rampTime;
}

template <int D, class K> void Solver<D, K>::addCondition(std::shared_ptr<GridCondition<D>> c)
{
    require(c != nullptr, "grid condition", "null", "a condition object");
    conditions_.push_back(std::move(c));
}

template <int D, class K> void Solver<D, K>::setGravity(const Eigen::Vector3d& g)
{
    require(g.allFinite(), "gravity (m/s2)", "non-finite", "finite components");
    settings_.gravity = g;
}

template <int D, class K>
int Solver<D, K>::addTraction(const std::vector<int>& points, const Eigen::Vector3d& traction,
                              double rampTime, double layer)
{
    for (int p : points)
        require(p >= 0 && p < numGlobalPoints(), "point id", p, "0 <= id < " + std::to_string(numGlobalPoints()));
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
    if (steps_ == 0) {
        for (const auto& v : points_.v) vmax = std::max(vmax, v.norm());
        if (dist_ && heldSetup_) dist_->transport().max(&vmax, 1);  // (every rank is here)
    }
    if (c + vmax <= 0) return std::numeric_limits<double>::infinity();
    return settings_.h / (c + vmax);
}

template <int D, class K> int Solver<D, K>::addCrack(const std::vector<Eigen::Vector3d>& vertices)
{
    require(!dist_ || (heldSetup_ && !dist_->partitioned()), "crack", "added to a distributed run after its set-up",
            "cracks before the first step (doc/parallel.md)");
    require(!points_.bodies, "crack", "in an engine with several bodies",
            "cracks only in an engine whose points are all in body 0 (a crack and bodies in one grid "
            "both use the phantom twins; use one engine per cracked body)");
    std::vector<Vec<D>> v;
    for (const auto& p : vertices) v.push_back(p.head<D>());
    return phantom_.addCrack(v);
}

// =============================================================================================
// Diagnostics
// =============================================================================================
namespace {

/// A sum over points of a distributed run: over all ranks (every rank calls it).
template <int D, class V> V overRanks(const std::shared_ptr<Distribution<D>>& dist, V v)
{
    if (!dist) return v;
    if constexpr (std::is_same<V, double>::value)
        dist->transport().sum(&v, 1);
    else
        dist->transport().sum(v.data(), static_cast<int>(v.size()));
    return v;
}

}  // namespace

namespace {

/// The diagnostics' sums over the points (kinetic and elastic energy, linear and angular
/// momentum) in kSumLanes partial sums: point p adds its terms to partial p mod kSumLanes, and
/// the partials are added in one fixed order at the end (sumOfLanes). The loop over the
/// partials is vectorised in the lanes' width (withLaneIsa: 8 points at a time in AVX-512, two
/// vectors of 4 in AVX2, four of 2 in the baseline); every width makes the same operations in
/// the same order per partial, so the sums are the same bits in every width, and they do not
/// depend on the thread count (one thread sums). A plain loop (one sum in point order) differs
/// from them at round-off only; tests/cpp/test_diagnostics.cpp keeps it as the reference.
/// (One scalar sum per quantity waited on its additions' latency: 2.2-2.4 ns a point whether
/// the points were in the L2 or not; PlotRecorder calls this at every record, doc/performance.md
/// "Session 36".)
constexpr int kSumLanes = 8;

template <int D> struct PointSums {
    double kinetic[kSumLanes] = {}, elastic[kSumLanes] = {}, momentum[D][kSumLanes] = {}, angular[3][kSumLanes] = {};
};

/// Adds the terms of points begin ... begin + n - 1 (n <= kSumLanes) to partials 0 ... n - 1.
/// x_p x v_p, plus APIC's affine part eps_abc B_cb (apic), is a point's angular momentum over its
/// mass; in 2D only its z component (x and y stay +0). `rho`: the one material's density (one),
/// else read per point.
template <int D, bool apic, bool one, int N>
EMP_ALWAYS_INLINE void addPointTerms(const MaterialPoints<D>& P, std::size_t begin, int n, double rho, PointSums<D>& s)
{
    const Vec<D>* x = P.x.data() + begin;
    const Vec<D>* v = P.v.data() + begin;
    const double* volume = P.volume.data() + begin;
    const double* energy = P.energy.data() + begin;
    const std::int32_t* material = P.material.data() + begin;
    const double* density = P.density.data();
    const Mat<D>* B = apic ? P.affineVelocity.data() + begin : nullptr;
    for (int j = 0; j < (N > 0 ? N : n); ++j) {
        const double m = (one ? rho : density[material[j]]) * volume[j];
        double vv = v[j][0] * v[j][0] + v[j][1] * v[j][1];
        if constexpr (D == 3) vv += v[j][2] * v[j][2];
        s.kinetic[j] += 0.5 * m * vv;
        s.elastic[j] += volume[j] * energy[j];
        for (int d = 0; d < D; ++d) s.momentum[d][j] += m * v[j][d];
        double lz = x[j][0] * v[j][1] - x[j][1] * v[j][0];
        if constexpr (apic) lz += B[j](1, 0) - B[j](0, 1);
        s.angular[2][j] += m * lz;
        if constexpr (D == 3) {
            double lx = x[j][1] * v[j][2] - x[j][2] * v[j][1], ly = x[j][2] * v[j][0] - x[j][0] * v[j][2];
            if constexpr (apic) {
                lx += B[j](2, 1) - B[j](1, 2);
                ly += B[j](0, 2) - B[j](2, 0);
            }
            s.angular[0][j] += m * lx;
            s.angular[1][j] += m * ly;
        }
    }
}

template <int D, bool apic, bool one> PointSums<D> pointSums(const MaterialPoints<D>& P, double rho)
{
    PointSums<D> s;
    const std::size_t n = P.size(), full = n - n % kSumLanes;
    withLaneIsa([&]() EMP_LAMBDA_INLINE {
        PointSums<D> local;  // (in registers)
        for (std::size_t b = 0; b < full; b += kSumLanes) addPointTerms<D, apic, one, kSumLanes>(P, b, kSumLanes, rho, local);
        addPointTerms<D, apic, one, 0>(P, full, static_cast<int>(n - full), rho, local);
        s = local;
    });
    return s;
}

EMP_ALWAYS_INLINE double sumOfLanes(const double (&a)[kSumLanes])
{
    static_assert(kSumLanes == 8, "the fixed order below adds eight partials");
    return ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
}

}  // namespace

template <int D, class K> double Solver<D, K>::externalWork() const
{
    double w = tractionWork_ + gravityWork_ + contactWork_;
    for (const auto& c : velocityConditions_) w += c->work;
    return w;
}

template <int D, class K> typename Solver<D, K>::Diagnostics Solver<D, K>::diagnostics() const
{
    // The four sums from one pass over the points (pointSums).
    const auto& P = points_;
    const bool one = materials_.size() <= 1;  // (then every point's material is 0: the same product)
    const double rho = one && !P.density.empty() ? P.density[0] : 0.0;
    const bool apic = settings_.transfer == Transfer::apic;
    const PointSums<D> s = apic ? (one ? pointSums<D, true, true>(P, rho) : pointSums<D, true, false>(P, rho))
                                : (one ? pointSums<D, false, true>(P, rho) : pointSums<D, false, false>(P, rho));
    Eigen::Vector3d momentum = Eigen::Vector3d::Zero(), angular = Eigen::Vector3d::Zero();
    for (int d = 0; d < D; ++d) momentum[d] = sumOfLanes(s.momentum[d]);
    for (int d = 0; d < 3; ++d) angular[d] = sumOfLanes(s.angular[d]);
    Diagnostics out;  // (one sum over the ranks each)
    out.kinetic = overRanks(dist_, sumOfLanes(s.kinetic));
    out.elastic = overRanks(dist_, sumOfLanes(s.elastic));
    out.momentum = overRanks(dist_, momentum);
    out.angularMomentum = overRanks(dist_, angular);
    return out;
}

// The four alone: diagnostics()'s sums (the same bits; in a distributed run every rank calls them).
template <int D, class K> double Solver<D, K>::kineticEnergy() const { return diagnostics().kinetic; }
template <int D, class K> double Solver<D, K>::elasticEnergy() const { return diagnostics().elastic; }
template <int D, class K> Eigen::Vector3d Solver<D, K>::linearMomentum() const { return diagnostics().momentum; }
template <int D, class K> Eigen::Vector3d Solver<D, K>::angularMomentum() const { return diagnostics().angularMomentum; }

template <int D, class K> void Solver<D, K>::setVelocityGradient(int p, const Mat<D>& C)
{
    require(settings_.transfer == Transfer::apic, "velocity gradient", "given with the FLIP transfer",
            "the APIC transfer (only it carries an affine velocity)");
    require(p >= 0 && p < numGlobalPoints(), "point id", p, "0 <= id < " + std::to_string(numGlobalPoints()));
    require(C.allFinite(), "velocity gradient (1/s)", "non-finite", "finite components");
    initialize();
    if (dist_) {  // (a distributed run's point p, if this rank holds it)
        p = dist_->localIndex(points_, p);
        if (p < 0) return;
    }
    points_.affineVelocity[p] = C * momentDiagonalAt(p).asDiagonal();
}

template <int D, class K> Mat<D> Solver<D, K>::velocityGradient(int p) const
{
    if (settings_.transfer != Transfer::apic || !initialized_) return Mat<D>::Zero();
    return affineOf(points_.affineVelocity[p], momentDiagonalAt(p));
}

template <int D, class K> Vec<D> Solver<D, K>::momentDiagonalAt(int p) const
{
    St st;
    st.compute(points_.x[p], grid_, lp_);
    double o[D][S];
    st.offsets(points_.x[p], grid_, o);
    return st.momentDiagonal(o);
}

#define EMP_INSTANTIATE(D, K) template class Solver<D, K>;
EMP_SOLVER_CONFIGURATIONS(EMP_INSTANTIATE)
#undef EMP_INSTANTIATE

}  // namespace emp
