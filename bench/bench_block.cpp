// Throughput benchmark of one explicit step (DESIGN.md "Performance design"): an elastic block
// on a fixed base, vibrating from a sinusoidal plus random initial velocity field, so that the
// stresses are nonzero and the spectral split takes all of its branches.
//
// Points lie on a lattice of spacing h/ppc (x = (i + 1/2) h/ppc) with ppc = 2. For each case and
// size the block is built afresh for every thread count, stepped a few times to warm up, then
// timed for at least --min-time seconds of step() calls. Reported: particle-steps per second
// (points x steps / wall seconds) and the ratio to the 1-thread run.
//
// Determinism: the first thread count of a size fixes a step count K; every later run of that
// size records a checksum of the state after K timed steps, and the benchmark checks that the
// checksums are bitwise equal (the solver must not depend on the thread count).
//
//   bench_block [--sizes 1e5,1e6] [--threads 1,2] [--min-time 3] [--warmup 3]
//               [--cases gimp2,linear2,gimp3] [--size3d 1e5] [--steps N] [--amp 0.01] [--quick]
//               [--transfer FLIP|APIC] [--stress-update smallStrain|corotational] [--gravity G]
//               [--modes "FLIP smallStrain,APIC corotational" [--chunk N]] [--erosion]
//
// --amp A sets the initial velocity amplitude to A times the wave speed (strains of order A).
// With the default 1e-2 the points leave their lattice sites within a few steps; with 1e-5
// they stay within 1e-3 h of them, as in small-strain elastodynamics (the vibrating bar).
// --gravity G (m/s2, along -y; default 0) adds a body force: the stress pass then also scatters
// N m g, as in most scenes with contact.
// --steps N times exactly N steps per run instead of --min-time (the checksums then compare
// builds: an optimisation that keeps the arithmetic must keep them).
// --quick is --sizes 2e4 --size3d 2e4 --min-time 0.3 --warmup 1.
// --step passes runs every step pass by pass (Solver::setPipelined(false)); by default a scene
// the wavefront serves runs as one (Solver::pipelineable; doc/performance.md, "Session 52"), with
// the same results. JSON lines carry "step": "pipelined" or "passes" (the last step's).
// --erosion attaches an eigenerosion stage that never fires (Gc = 1e12 J/m2, alpha 2, kappa
// 1.1 h: no point is ever a source, as in bench_fracture's case (a)); the results, and so the
// checksums, are those without it, and the benchmark fails if it ever searched or eroded.
// JSON lines carry "erosion": true or false. (Issue 12 item 1 asks for the step's speed "with
// eigenerosion attached".)
// --modes "T U,T U,..." (transfer and stress update per mode) measures what the options cost in
// one process: it builds the block once per mode and steps the scenes in turn, --chunk steps
// (default 1) each, in alternating order, on the first thread count, until each has run
// --min-time s (or --steps steps). On a shared machine whose speed changes from second to
// second, every round's modes then see the same machine. Printed per mode: its rate, its time
// per step over the first mode's (the ratio of the totals) and the median of the rounds' own
// ratios with its quartiles; JSON lines carry "mode" and "time_ratio_to_first_mode".
// Output (stdout): one progress line per run, then a table, the peak resident set of the process
// (VmHWM) and its ratio to the points of the largest scene, then one JSON object per line
// (prefix "JSON ") per run, with resident_bytes_per_point: the resident set the scene added
// (VmRSS after its timed steps minus before its build) over its points.
// Memory per point: run one case, one size and one thread count per process, e.g.
//   bench_block --cases gimp2 --sizes 1e6 --threads 1 --steps 5
// (a later scene in one process reuses the pages an earlier one freed).
// --mpi distributes the block over the ranks of mpiexec (doc/parallel.md; needs --steps):
//   mpiexec -n 2 bench_block --mpi --cases gimp2 --sizes 1e6 --threads 1 --steps 20
// with --column-cells W --rank-columns C in C columns of ranks along x (a decomposition in two
// directions; --column-cells alone orders one process's sums by those columns).
// Then rank 0 prints the whole scene's rate (its points over the slowest rank's time) and the
// bytes each rank sent per step (the most of any rank); no checksum.
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <memory>
#include <ctime>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "Lanes.hpp"
#include "Laws.hpp"
#include "MpiTransport.hpp"
#include "Solver.hpp"

namespace {

struct Options {
    std::vector<double> sizes{1e5, 1e6};
    std::vector<int> threads{1, 2};
    std::vector<std::string> cases{"gimp2", "linear2", "gimp3"};
    double size3d = 1e5;
    double minTime = 3.0;
    int warmup = 3;
    long steps = 0;  ///< > 0: exactly this many timed steps (for comparing checksums between builds)
    double amp = 0.01;  ///< velocity amplitude / wave speed (about the strain amplitude)
    emp::Transfer transfer = emp::Transfer::flip;
    emp::StressUpdate stressUpdate = emp::StressUpdate::smallStrain;
    double gravity = 0;  ///< m/s2 along -y
    bool mpi = false;
    int columnCells = 0, rankColumns = 1;  ///< the scheduler's columns; --mpi: columns of ranks
    std::vector<std::pair<emp::Transfer, emp::StressUpdate>> modes;  ///< --modes: interleaved scenes
    int chunk = 1;  ///< --modes: steps per scene and turn
    bool passes = false;  ///< --step passes: every step pass by pass (Solver::setPipelined(false))
    bool erosion = false;  ///< --erosion: an erosion stage that never fires
};

/// The MPI transport, counting the bytes this rank sends (exchanges, reductions, gathers).
class CountingTransport : public emp::MpiTransport {
public:
    double sent = 0;
    void exchange(const std::vector<char>& toLeft, const std::vector<char>& toRight, std::vector<char>& fromLeft,
                  std::vector<char>& fromRight) override
    {
        sent += static_cast<double>(toLeft.size() + toRight.size());
        MpiTransport::exchange(toLeft, toRight, fromLeft, fromRight);
    }
    void sum(double* v, int n) override
    {
        sent += 8.0 * n;
        MpiTransport::sum(v, n);
    }
    void max(double* v, int n) override
    {
        sent += 8.0 * n;
        MpiTransport::max(v, n);
    }
    std::vector<std::vector<char>> allGather(const std::vector<char>& mine) override
    {
        sent += static_cast<double>(mine.size());
        return MpiTransport::allGather(mine);
    }
    std::vector<std::vector<char>> allToAll(const std::vector<std::vector<char>>& toEach) override
    {
        for (int r = 0; r < size(); ++r)
            if (r != rank()) sent += static_cast<double>(toEach[r].size());
        return MpiTransport::allToAll(toEach);
    }
    std::vector<std::vector<char>> neighbourExchange(const std::vector<int>& ranks,
                                                     const std::vector<std::vector<char>>& out) override
    {
        for (const auto& o : out) sent += static_cast<double>(o.size());
        return MpiTransport::neighbourExchange(ranks, out);
    }
};

CountingTransport* mpiTransport()
{
    static auto t = std::make_shared<CountingTransport>();
    return t.get();
}

struct Result {
    std::string caseName;
    long points = 0;
    int threads = 0;
    long steps = 0;
    double wall = 0, cpu = 0, pps = 0, ratio = 0;
    double bytesPerPoint = 0;  ///< resident set added by the scene (after its steps) per point
    std::uint64_t checksum = 0;
    bool checked = false, deterministic = true;
    std::string mode;  ///< --modes: "TRANSFER+STRESSUPDATE"
    double timeRatio = 0, medianRatio = 0, q1 = 0, q3 = 0;  ///< --modes: time per step over the first mode's
    int ranks = 1;
    double bytesSentPerStep = 0;  ///< --mpi: the most any rank sent per step
    bool pipelined = false;  ///< whether the timed steps ran as a wavefront (Solver::lastStepPipelined)
};

template <class T> std::vector<T> splitList(const std::string& s)
{
    std::vector<T> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        if (!item.empty()) out.push_back(static_cast<T>(std::stod(item)));
    return out;
}

std::vector<std::string> splitNames(const std::string& s)
{
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        if (!item.empty()) out.push_back(item);
    return out;
}

[[noreturn]] void usage(const char* msg)
{
    std::fprintf(stderr,
                 "bench_block: %s\nusage: bench_block [--sizes 1e5,1e6] [--threads 1,2] [--min-time S]\n"
                 "       [--warmup N] [--cases gimp2,linear2,gimp3] [--size3d N] [--steps N] [--amp A] [--quick]\n"
                 "       [--column-cells W] [--mpi [--rank-columns C]] [--transfer T] [--stress-update U]\n"
                 "       [--step passes|pipelined] [--erosion]\n"
                 "       [--modes \"T U,T U,...\" [--chunk N]]\n",
                 msg);
    std::exit(2);
}

Options parse(int argc, char** argv)
{
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) usage(("missing value after " + a).c_str());
            return argv[++i];
        };
        if (a == "--sizes") o.sizes = splitList<double>(next());
        else if (a == "--threads") o.threads = splitList<int>(next());
        else if (a == "--min-time") o.minTime = std::stod(next());
        else if (a == "--warmup") o.warmup = std::stoi(next());
        else if (a == "--steps") o.steps = std::stol(next());
        else if (a == "--amp") o.amp = std::stod(next());
        else if (a == "--cases") o.cases = splitNames(next());
        else if (a == "--size3d") o.size3d = std::stod(next());
        else if (a == "--mpi") o.mpi = true;
        else if (a == "--column-cells") o.columnCells = std::stoi(next());
        else if (a == "--rank-columns") o.rankColumns = std::stoi(next());
        else if (a == "--gravity") o.gravity = std::stod(next());
        else if (a == "--erosion") o.erosion = true;
        else if (a == "--step") {
            const std::string v = next();
            if (v != "passes" && v != "pipelined") usage("--step takes passes or pipelined");
            o.passes = v == "passes";
        }
        else if (a == "--transfer") {
            o.transfer = emp::transferOf(next());
            if (o.transfer == emp::Transfer::unset) usage("--transfer takes FLIP or APIC");
        } else if (a == "--stress-update") {
            o.stressUpdate = emp::stressUpdateOf(next());
            if (o.stressUpdate == emp::StressUpdate::unset) usage("--stress-update takes smallStrain or corotational");
        }
        else if (a == "--modes") {
            for (const auto& m : splitNames(next())) {
                std::stringstream ss(m);
                std::string t, u, extra;
                ss >> t >> u;
                const auto mode = std::make_pair(emp::transferOf(t), emp::stressUpdateOf(u));
                if (mode.first == emp::Transfer::unset || mode.second == emp::StressUpdate::unset || (ss >> extra))
                    usage(("--modes takes 'TRANSFER STRESSUPDATE' pairs separated by commas (FLIP|APIC, "
                           "smallStrain|corotational), not '" + m + "'").c_str());
                o.modes.push_back(mode);
            }
        } else if (a == "--chunk") o.chunk = std::stoi(next());
        else if (a == "--quick") {
            o.sizes = {2e4};
            o.size3d = 2e4;
            o.minTime = 0.3;
            o.warmup = 1;
        } else if (a == "-h" || a == "--help") usage("help");
        else usage(("unknown argument " + a).c_str());
    }
    if (o.sizes.empty() || o.threads.empty() || o.cases.empty()) usage("empty list");
    for (int t : o.threads)
        if (t < 1) usage("thread counts must be >= 1");
    if (o.chunk < 1) usage(("--chunk must be >= 1, not " + std::to_string(o.chunk)).c_str());
    if (!o.modes.empty() && o.mpi) usage("--modes runs in one process, without --mpi");
    if (o.mpi && o.steps <= 0) usage("--mpi needs --steps N (every rank steps the same number of times)");
    if (o.rankColumns > 1 && (!o.mpi || o.columnCells <= 0)) usage("--rank-columns needs --mpi and --column-cells W > 0");
    return o;
}

/// FNV-1a over the bytes of the point positions, velocities and stresses (stressOf: not stored).
template <int D, class K> std::uint64_t checksum(const emp::Solver<D, K>& s)
{
    const auto& P = s.points();
    std::uint64_t h = 1469598103934665603ull;
    auto mix = [&](const double* d, std::size_t n) {
        const auto* b = reinterpret_cast<const unsigned char*>(d);
        for (std::size_t i = 0; i < n * sizeof(double); ++i) {
            h ^= b[i];
            h *= 1099511628211ull;
        }
    };
    for (std::size_t p = 0; p < P.size(); ++p) {
        mix(P.x[p].data(), D);
        mix(P.v[p].data(), D);
        const emp::Mat<D> stress = s.stressOf(p);  // (all D x D components, as before Sym2)
        mix(stress.data(), D * D);
    }
    return h;
}

/// Builds the block: n[d] points per direction on the h/ppc lattice, bottom nodes fixed.
template <int D, class K> emp::Solver<D, K> makeBlock(const std::array<int, D>& n, double ampFraction, const Options& o)
{
    const double h = 0.01, E = 1e7, nu = 0.3, rho = 1000.0;
    const int ppc = 2;
    emp::SolverSettings s;
    s.massCutoff = 1e-14;
    s.padding = 3;
    s.gravity.setZero();
    if (o.gravity != 0) s.gravity[1] = -o.gravity;
    s.h = h;
    s.ppc = ppc;
    s.transfer = o.transfer;
    s.stressUpdate = o.stressUpdate;
    s.columnCells = o.columnCells;
    emp::Solver<D, K> solver(s);
    solver.setPipelined(!o.passes);
    if (o.erosion) solver.setErosion(std::make_shared<emp::EigenErosion<D>>(emp::ErosionSettings{1e12, 2.0, 1.1 * h}));
    const int mat = solver.addMaterial(E, nu, rho, false, emp::lawIndex("spectral"));
    const double dx = h / ppc, vol = std::pow(dx, D);
    const double c = solver.materials()[mat].waveSpeed();
    const double amp = ampFraction * c;  // strain amplitude of order amp / c
    Eigen::Vector3d L = Eigen::Vector3d::Ones();
    for (int d = 0; d < D; ++d) L[d] = n[d] * dx;
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    long total = 1;
    for (int d = 0; d < D; ++d) total *= n[d];
    solver.reservePoints(static_cast<std::size_t>(total));  // (as the Python engine's addPoints does)
    for (long k = 0; k < total; ++k) {
        long r = k;
        Eigen::Vector3d x = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
        for (int d = 0; d < D; ++d) {
            x[d] = (r % n[d] + 0.5) * dx;
            r /= n[d];
        }
        // A smooth mode (shear and stretch) plus a 20% random field: tension, compression and
        // mixed principal strains all occur.
        const double sx = std::sin(M_PI * x[0] / L[0]), sy = std::sin(M_PI * x[D - 1] / L[D - 1]);
        v[0] = amp * sy;
        v[D - 1] = amp * sx * sy;
        for (int d = 0; d < D; ++d) v[d] += 0.2 * amp * uni(rng);
        solver.addPoint(x, v, vol, mat);
    }
    solver.initialize();
    // Fixed base: every node on or below the block's bottom face (last axis) is held at rest.
    const auto& g = solver.grid();
    std::vector<int> base;
    for (int I = 0; I < g.numNodes(); ++I)
        if (g.nodePosition(I)[D - 1] <= 1e-12) base.push_back(I);
    solver.addVelocityCondition(base, {}, (1u << D) - 1, Eigen::Vector3d::Zero(), 0.0);
    return solver;
}

using Clock = std::chrono::steady_clock;

/// CPU time of the whole process (all threads), s: on a loaded machine wall time includes the
/// waits for a core, CPU time does not (a 1-thread run then still measures the code).
double cpuSeconds()
{
    timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

/// A field of /proc/self/status in bytes ("VmRSS:", "VmHWM:"), or 0 where there is none.
double statusBytes(const char* field)
{
    std::FILE* f = std::fopen("/proc/self/status", "r");
    if (!f) return 0;
    char line[256];
    double kb = 0;
    const std::size_t n = std::strlen(field);
    while (std::fgets(line, sizeof line, f))
        if (std::strncmp(line, field, n) == 0) kb = std::atof(line + n);
    std::fclose(f);
    return 1024.0 * kb;
}

/// One run: fresh block, warm-up, then timed steps until both minTime and minSteps are reached.
/// The checksum is taken after exactly `checkAt` timed steps (0: after the last one).
template <int D, class K>
Result runOnce(const std::string& name, const std::array<int, D>& n, int threads, const Options& o,
               long minSteps, long checkAt)
{
    const double rss0 = statusBytes("VmRSS:");
    auto solver = makeBlock<D, K>(n, o.amp, o);
    const double dt = 0.5 * solver.criticalTimeStep();
    if (o.mpi)
        solver.distribute(std::shared_ptr<emp::Transport>(std::shared_ptr<void>(), mpiTransport()), o.rankColumns);
    for (int i = 0; i < o.warmup; ++i) solver.step(dt, threads);
    Result r;
    r.caseName = name;
    r.points = static_cast<long>(solver.points().size());
    r.threads = threads;
    double wall = 0, cpu = 0, sent0 = o.mpi ? mpiTransport()->sent : 0;
    long steps = 0;
    while (o.steps > 0 ? steps < o.steps : (wall < o.minTime || steps < minSteps)) {
        const auto t0 = Clock::now();
        const double c0 = cpuSeconds();
        solver.step(dt, threads);
        cpu += cpuSeconds() - c0;
        wall += std::chrono::duration<double>(Clock::now() - t0).count();
        ++steps;
        if (checkAt > 0 && steps == checkAt) r.checksum = checksum(solver);
    }
    if (checkAt <= 0) r.checksum = checksum(solver);
    r.pipelined = solver.lastStepPipelined();
    if (o.erosion && (solver.erosion()->searchedLastStep() || solver.erosion()->erodedCount() != 0)) {
        std::fprintf(stderr, "bench_block: the erosion stage (--erosion) searched or eroded\n");
        std::exit(4);
    }
    if (o.mpi) {  // the whole scene: all ranks' points over the slowest rank's time
        double sums[1] = {static_cast<double>(solver.points().size())};
        double maxes[3] = {wall, cpu, (mpiTransport()->sent - sent0) / steps};
        emp::MpiTransport& t = *mpiTransport();
        t.emp::MpiTransport::sum(sums, 1);
        t.emp::MpiTransport::max(maxes, 3);
        r.points = static_cast<long>(sums[0]);
        wall = maxes[0];
        cpu = maxes[1];
        r.bytesSentPerStep = maxes[2];
        r.ranks = t.size();
        r.checksum = 0;
    }
    r.steps = steps;
    r.wall = wall;
    r.cpu = cpu;
    r.pps = static_cast<double>(r.points) * steps / wall;
    r.bytesPerPoint = (statusBytes("VmRSS:") - rss0) / r.points;
    return r;
}

/// --modes: one block per mode, stepped in turn (--chunk steps each, the order reversed every
/// round) on the first thread count until each has run minTime (or o.steps steps). The rounds'
/// CPU times pair the modes under the same state of the machine.
template <int D, class K>
void runModes(const std::string& name, const std::array<int, D>& n, const Options& o, std::vector<Result>& out)
{
    const int threads = o.threads.front(), M = static_cast<int>(o.modes.size());
    std::vector<std::unique_ptr<emp::Solver<D, K>>> solvers;
    std::vector<double> dts;
    for (const auto& [transfer, update] : o.modes) {
        Options om = o;
        om.transfer = transfer;
        om.stressUpdate = update;
        solvers.push_back(std::make_unique<emp::Solver<D, K>>(makeBlock<D, K>(n, o.amp, om)));
        dts.push_back(0.5 * solvers.back()->criticalTimeStep());
        for (int i = 0; i < o.warmup; ++i) solvers.back()->step(dts.back(), threads);
    }
    std::vector<double> wall(M, 0), cpu(M, 0);
    std::vector<std::vector<double>> perRound(M);  // CPU seconds per step of each round
    long steps = 0;
    const auto done = [&] {
        if (o.steps > 0) return steps >= o.steps;
        for (int m = 0; m < M; ++m)
            if (wall[m] < o.minTime) return false;
        return true;
    };
    for (int round = 0; !done(); ++round) {
        for (int k = 0; k < M; ++k) {
            const int m = round % 2 == 0 ? k : M - 1 - k;
            const auto t0 = Clock::now();
            const double c0 = cpuSeconds();
            for (int i = 0; i < o.chunk; ++i) solvers[m]->step(dts[m], threads);
            const double c = cpuSeconds() - c0;
            cpu[m] += c;
            wall[m] += std::chrono::duration<double>(Clock::now() - t0).count();
            perRound[m].push_back(c / o.chunk);
        }
        steps += o.chunk;
    }
    const auto quantile = [](std::vector<double> v, double q) {
        std::sort(v.begin(), v.end());
        const double at = q * (v.size() - 1);
        const std::size_t i = static_cast<std::size_t>(at);
        return i + 1 < v.size() ? v[i] + (at - i) * (v[i + 1] - v[i]) : v[i];
    };
    for (int m = 0; m < M; ++m) {
        Result r;
        r.caseName = name;
        r.points = static_cast<long>(solvers[m]->points().size());
        r.threads = threads;
        r.steps = steps;
        r.wall = wall[m];
        r.cpu = cpu[m];
        r.pps = static_cast<double>(r.points) * steps / wall[m];
        r.ratio = 1;
        r.checksum = checksum(*solvers[m]);
        r.pipelined = solvers[m]->lastStepPipelined();
        r.mode = std::string(emp::name(o.modes[m].first)) + "+" + emp::name(o.modes[m].second);
        std::vector<double> ratios;
        for (std::size_t i = 0; i < perRound[m].size(); ++i) ratios.push_back(perRound[m][i] / perRound[0][i]);
        r.timeRatio = cpu[m] / cpu[0];
        r.medianRatio = quantile(ratios, 0.5);
        r.q1 = quantile(ratios, 0.25);
        r.q3 = quantile(ratios, 0.75);
        std::printf("  %-10s %9ld points  %2d threads  %6ld steps  %-26s %.3e particle-steps/CPU s  "
                    "time/step over the first mode: %.3f (rounds: median %.3f, quartiles %.3f-%.3f)\n",
                    name.c_str(), r.points, threads, steps, r.mode.c_str(), r.points * steps / cpu[m], r.timeRatio,
                    r.medianRatio, r.q1, r.q3);
        std::fflush(stdout);
        out.push_back(r);
    }
}

template <int D, class K>
void runCase(const std::string& name, double size, const Options& o, std::vector<Result>& out)
{
    // Near-cubic block of about `size` points; in 2D twice as wide as tall keeps it a "block".
    std::array<int, D> n;
    if constexpr (D == 2) {
        const int ny = std::max(4, static_cast<int>(std::lround(std::sqrt(size / 2.0))));
        n = {std::max(4, static_cast<int>(std::lround(size / ny))), ny};
    } else {
        const int m = std::max(4, static_cast<int>(std::lround(std::cbrt(size))));
        n = {m, m, m};
    }
    if (!o.modes.empty()) {
        runModes<D, K>(name, n, o, out);
        return;
    }
    long firstSteps = 0;
    double firstPps = 0;
    std::uint64_t firstSum = 0;
    for (std::size_t k = 0; k < o.threads.size(); ++k) {
        Result r = runOnce<D, K>(name, n, o.threads[k], o, k == 0 ? 0 : firstSteps, k == 0 ? 0 : firstSteps);
        if (k == 0) {
            firstSteps = r.steps;
            firstPps = r.pps;
            firstSum = r.checksum;
        } else {
            r.checked = !o.mpi;
            r.deterministic = r.checksum == firstSum;
        }
        r.ratio = r.pps / firstPps;
        std::printf("  %-10s %9ld points  %2d threads  %6ld steps  %7.2f s  %.3e particle-steps/s\n",
                    name.c_str(), r.points, r.threads, r.steps, r.wall, r.pps);
        std::fflush(stdout);
        out.push_back(r);
    }
}

/// The JSON fields of a --modes run ("" otherwise).
std::string modeFields(const Result& r)
{
    if (r.mode.empty()) return "";
    char b[256];
    std::snprintf(b, sizeof b,
                  ", \"mode\": \"%s\", \"time_ratio_to_first_mode\": %.4f, \"median_round_ratio\": %.4f, "
                  "\"round_ratio_q1\": %.4f, \"round_ratio_q3\": %.4f",
                  r.mode.c_str(), r.timeRatio, r.medianRatio, r.q1, r.q3);
    return b;
}

}  // namespace

int main(int argc, char** argv)
{
    const Options o = parse(argc, argv);
    if (o.mpi && mpiTransport()->rank() != 0 && !std::freopen("/dev/null", "w", stdout)) return 1;  // rank 0 reports
    std::vector<Result> results;
    try {
        for (const auto& c : o.cases) {
            if (c == "gimp2")
                for (double s : o.sizes) runCase<2, emp::GimpKernel>("2D uGIMP", s, o, results);
            else if (c == "linear2")
                for (double s : o.sizes) runCase<2, emp::LinearKernel>("2D linear", s, o, results);
            else if (c == "gimp3")
                runCase<3, emp::GimpKernel>("3D uGIMP", o.size3d, o, results);
            else if (c == "linear3")
                runCase<3, emp::LinearKernel>("3D linear", o.size3d, o, results);
            else
                usage(("unknown case " + c + " (known: gimp2, linear2, gimp3, linear3)").c_str());
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_block: %s\n", e.what());
        return 1;
    }

    std::printf("\n%-10s %9s %7s %7s %8s %8s %16s %8s %s\n", "case", "points", "threads", "steps",
                "wall_s", "cpu_s", "particle-steps/s", "ratio", "same result as 1st");
    bool allSame = true;
    for (const auto& r : results) {
        std::printf("%-10s %9ld %7d %7ld %8.2f %8.2f %16.4g %8.3f %s\n", r.caseName.c_str(), r.points, r.threads,
                    r.steps, r.wall, r.cpu, r.pps, r.ratio, r.checked ? (r.deterministic ? "bitwise" : "DIFFERS") : "-");
        allSame = allSame && r.deterministic;
    }
    // bench_block is built for any x86-64 processor, bench_block_v2 for x86-64-v2 (CMakeLists.txt).
#ifdef __SSE4_2__
    const char* isa = "x86-64-v2";
#else
    const char* isa = "x86-64";
#endif
    std::printf("\ninstruction set: %s; lane loops: %s (EIGENMPM_LANES)\n", isa, emp::name(emp::laneIsa()));
    std::printf("peak resident set of the process: %.1f MB; per point of the largest scene: %.0f B\n\n",
                statusBytes("VmHWM:") / 1e6, [&] {
                    long most = 1;
                    for (const auto& r : results) most = std::max(most, r.points);
                    return statusBytes("VmHWM:") / most;
                }());
    for (const auto& r : results)
        std::printf("JSON {\"case\": \"%s\", \"points\": %ld, \"threads\": %d, \"steps\": %ld, \"wall_time_s\": %.6f, \"cpu_time_s\": %.6f, "
                    "\"particle_steps_per_s\": %.6g, \"ratio_to_first_thread_count\": %.4f, \"resident_bytes_per_point\": %.1f, "
                    "\"checksum\": \"%016" PRIx64 "\", \"bitwise_equal_to_first\": %s, \"ranks\": %d, \"bytes_sent_per_step\": %.0f, "
                    "\"isa\": \"%s\", \"lanes\": \"%s\", \"step\": \"%s\", \"erosion\": %s%s}\n",
                    r.caseName.c_str(), r.points, r.threads, r.steps, r.wall, r.cpu, r.pps, r.ratio, r.bytesPerPoint, r.checksum,
                    r.checked ? (r.deterministic ? "true" : "false") : "null", r.ranks, r.bytesSentPerStep, isa,
                    emp::name(emp::laneIsa()), r.pipelined ? "pipelined" : "passes", o.erosion ? "true" : "false", modeFields(r).c_str());
    if (!allSame) {
        std::fprintf(stderr, "bench_block: results differ between thread counts (determinism broken)\n");
        return 3;
    }
    return 0;
}
