// What the fracture physics costs over the plain solver (issue: "a scene pays only for the
// physics it uses"), as ratios of step times measured in one run, interleaved:
//
//  (a) elastic block that never breaks: the same solver with and without an eigenerosion stage
//      (Gc so large that no point is a source, so no neighbour search ever runs);
//  (b) the crack-branching plate of the paper (Section 5.2, glass, 12 MPa, phantom-node
//      pre-crack) while it cracks: from the same state at --crack-time, steps with erosion
//      against steps with the erosion stage detached;
//  (c) phantom nodes: the plate with and without its pre-crack (elastic only).
//
// A control pair of identical solvers shows the noise floor of such a comparison on the machine.
// Each pair is timed as alternating blocks of --block steps (A B A B ...) for --min-time s
// of CPU time in total per case and the ratio of the summed times is reported, so that a slow spell of the
// machine hits both; so is the median over the block pairs of the per-pair ratio A/B (robust
// to a pair hit by another process), with its quartiles. Single thread unless --threads N.
//
//   bench_fracture [--h-mm 0.5] [--crack-time-us 25] [--block 20] [--min-time 4] [--threads 1]
//                  [--block-points 1e5] [--quick] [--step-passes]
// --step-passes: (a)'s two blocks step pass by pass (Solver::setPipelined(false)) instead of as a
// wavefront (doc/performance.md, "Session 52"; with erosion since session 53): (a) then reads
// what the erosion stage costs in that form of the step.
// --quick: --h-mm 1 --min-time 0.5 --block-points 2e4.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <algorithm>
#include <vector>
#include <functional>
#include <string>

#include "EigenErosion.hpp"
#include "Laws.hpp"
#include "Solver.hpp"

namespace {

using Plate = emp::Solver<2, emp::GimpKernel>;

struct Options {
    double hmm = 0.5, crackTimeUs = 25.0, minTime = 4.0, blockPoints = 1e5;
    int block = 20, threads = 1;
    bool passes = false;  ///< --step-passes
};

/// CPU seconds of the process spent in f (less sensitive than wall time to other processes
/// taking the core; with one thread it is the step's own time).
double seconds(const std::function<void()>& f)
{
    const std::clock_t c0 = std::clock();
    f();
    return double(std::clock() - c0) / CLOCKS_PER_SEC;
}

/// Summed CPU times of a and b, and the ratio a/b of every pair of blocks.
struct Timing {
    double first = 0, second = 0;
    std::vector<double> ratios;
    double quantile(double q) const
    {
        std::vector<double> r = ratios;
        std::sort(r.begin(), r.end());
        const double pos = q * (r.size() - 1);
        const std::size_t i = static_cast<std::size_t>(pos);
        return i + 1 < r.size() ? r[i] + (pos - i) * (r[i + 1] - r[i]) : r.back();
    }
};

/// Alternates blocks of `block` steps of a and b until minTime is spent (the order within a pair
/// alternating too, so that neither always runs first).
Timing interleave(const std::function<void()>& a, const std::function<void()>& b, double minTime)
{
    Timing t;
    while (t.first + t.second < minTime) {
        double ta, tb;
        if (t.ratios.size() % 2 == 0) {
            ta = seconds(a);
            tb = seconds(b);
        } else {
            tb = seconds(b);
            ta = seconds(a);
        }
        t.first += ta;
        t.second += tb;
        if (tb > 0) t.ratios.push_back(ta / tb);
    }
    return t;
}

/// The crack-branching plate: 100 x 40 mm, glass, traction 12 MPa on the top and bottom layers,
/// phantom-node crack from the left edge to the centre (if `crack`).
Plate plate(double h, bool crack)
{
    emp::SolverSettings s;
    s.massCutoff = 1e-14;
    s.padding = 3;
    s.gravity.setZero();
    s.transfer = emp::Transfer::flip;
    s.stressUpdate = emp::StressUpdate::smallStrain;
    s.h = h;
    s.ppc = 2;
    Plate p(s);
    const int mat = p.addMaterial(72e9, 0.22, 2440, true, emp::lawIndex("spectral"));
    const double dx = h / 2, L = 0.1, W = 0.04;
    std::vector<int> top, bottom;
    for (int j = 0; (j + 0.5) * dx < W; ++j)
        for (int i = 0; (i + 0.5) * dx < L; ++i) {
            const Eigen::Vector3d x((i + 0.5) * dx, (j + 0.5) * dx, 0);
            const int id = p.addPoint(x, Eigen::Vector3d::Zero(), dx * dx * h, mat);
            if (x[1] > W - h) top.push_back(id);
            if (x[1] < h) bottom.push_back(id);
        }
    p.addTraction(top, Eigen::Vector3d(0, 12e6, 0), 0.0, h);
    p.addTraction(bottom, Eigen::Vector3d(0, -12e6, 0), 0.0, h);
    if (crack) p.addCrack({Eigen::Vector3d(-h, W / 2, 0), Eigen::Vector3d(L / 2, W / 2, 0)});
    return p;
}

void report(const char* name, long points, int steps, const Timing& t, const char* what)
{
    const double overhead = 100.0 * (t.first / t.second - 1.0);
    const double median = 100.0 * (t.quantile(0.5) - 1.0);
    std::printf("%-34s %8ld points %7d steps each: %s %+6.1f %%  (%.3g vs %.3g particle-steps/s); median of %zu "
                "block pairs %+6.1f %% (quartiles %+.1f, %+.1f)\n",
                name, points, steps, what, overhead, points * steps / t.first, points * steps / t.second,
                t.ratios.size(), median, 100.0 * (t.quantile(0.25) - 1.0), 100.0 * (t.quantile(0.75) - 1.0));
    std::printf("JSON {\"case\": \"%s\", \"points\": %ld, \"steps\": %d, \"time_with_s\": %.6g, "
                "\"time_without_s\": %.6g, \"overhead_percent\": %.3f, \"pairs\": %zu, "
                "\"median_pair_overhead_percent\": %.3f}\n",
                name, points, steps, t.first, t.second, overhead, t.ratios.size(), median);
}

}  // namespace

int main(int argc, char** argv)
{
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() { return i + 1 < argc ? std::atof(argv[++i]) : 0.0; };
        if (a == "--h-mm") o.hmm = next();
        else if (a == "--crack-time-us") o.crackTimeUs = next();
        else if (a == "--block") o.block = static_cast<int>(next());
        else if (a == "--min-time") o.minTime = next();
        else if (a == "--threads") o.threads = static_cast<int>(next());
        else if (a == "--block-points") o.blockPoints = next();
        else if (a == "--step-passes") o.passes = true;
        else if (a == "--quick") {
            o.hmm = 1.0;
            o.minTime = 0.5;
            o.blockPoints = 2e4;
        } else {
            std::fprintf(stderr, "bench_fracture: unknown argument %s\n", a.c_str());
            return 2;
        }
    }
    const double h = o.hmm * 1e-3;
    const emp::ErosionSettings glass{135.0, 2.0, 1.1 * h};

    // (a) A plate without crack and without traction never breaks: an elastic block vibrating
    // from a smooth initial velocity, with an erosion stage whose Gc no point can reach.
    {
        const double side = std::sqrt(o.blockPoints) * 0.5 * 1e-3;  // dx = 0.5 mm
        emp::SolverSettings s;
        s.ppc = 2;
        s.massCutoff = 1e-14;
        s.padding = 3;
        s.gravity.setZero();
        s.transfer = emp::Transfer::flip;
        s.stressUpdate = emp::StressUpdate::smallStrain;
        s.h = 1e-3;
        Plate a(s), b(s);
        a.setPipelined(!o.passes);  // (both run as a wavefront unless --step-passes:
        b.setPipelined(!o.passes);  //  Solver::pipelineable)
        for (Plate* p : {&a, &b}) {
            const int mat = p->addMaterial(30e9, 0.2, 2400, false, emp::lawIndex("spectral"));
            for (double y = 0.25e-3; y < side; y += 0.5e-3)
                for (double x = 0.25e-3; x < side; x += 0.5e-3)
                    p->addPoint(Eigen::Vector3d(x, y, 0),
                                Eigen::Vector3d(std::sin(40 * x) * 0.1, std::cos(30 * y) * 0.1, 0), 0.25e-6, mat);
        }
        const double dt = 0.5 * a.criticalTimeStep();
        int steps = 0;
        // Control: the two identical solvers, to show the noise floor of the comparison.
        const auto t0 = interleave([&] { for (int k = 0; k < o.block; ++k) a.step(dt, o.threads); steps += o.block; },
                                   [&] { for (int k = 0; k < o.block; ++k) b.step(dt, o.threads); }, o.minTime);
        report("(0) control, identical solvers", static_cast<long>(a.points().size()), steps, t0, "difference      ");
        steps = 0;
        a.setErosion(std::make_shared<emp::EigenErosion<2>>(emp::ErosionSettings{1e12, 2.0, 1.1e-3}));
        const auto t = interleave([&] { for (int k = 0; k < o.block; ++k) a.step(dt, o.threads); steps += o.block; },
                                  [&] { for (int k = 0; k < o.block; ++k) b.step(dt, o.threads); }, o.minTime);
        if (a.erosion()->erodedCount() != 0 || a.erosion()->searchedLastStep()) {
            std::fprintf(stderr, "bench_fracture: the never-breaking block searched or eroded\n");
            return 1;
        }
        report("(a) erosion, never breaking", static_cast<long>(a.points().size()), steps, t, "erosion overhead");
        std::printf("    the block's step: %s with erosion, %s without\n", a.lastStepPipelined() ? "wavefront" : "passes",
                    b.lastStepPipelined() ? "wavefront" : "passes");
    }

    // (b) The branching plate while cracking, from one state: with and without erosion.
    {
        Plate base = plate(h, true);
        base.setErosion(std::make_shared<emp::EigenErosion<2>>(glass));
        const double dt = 0.01e-6 * o.hmm / 0.25;  // the paper's 0.01 us at h = 0.25 mm, scaled with h
        while (base.time() < o.crackTimeUs * 1e-6) base.step(dt, o.threads);
        Plate with = base, without = base;
        with.setErosion(std::make_shared<emp::EigenErosion<2>>(*base.erosion()));
        without.setErosion(nullptr);
        const std::size_t eroded0 = with.erosion()->erodedCount();
        int steps = 0;
        const auto t = interleave([&] { for (int k = 0; k < o.block; ++k) with.step(dt, o.threads); steps += o.block; },
                                  [&] { for (int k = 0; k < o.block; ++k) without.step(dt, o.threads); }, o.minTime);
        report("(b) erosion, branching plate", static_cast<long>(with.points().size()), steps, t, "erosion overhead");
        std::printf("    eroded before timing: %zu, during the timed steps: %zu (t = %.1f to %.1f us)\n", eroded0,
                    with.erosion()->erodedCount() - eroded0, o.crackTimeUs, with.time() * 1e6);
    }

    // (c) Phantom nodes: the plate with and without its pre-crack, elastic.
    {
        Plate cracked = plate(h, true), intact = plate(h, false);
        const double dt = 0.01e-6 * o.hmm / 0.25;
        int steps = 0;
        const auto t = interleave([&] { for (int k = 0; k < o.block; ++k) cracked.step(dt, o.threads); steps += o.block; },
                                  [&] { for (int k = 0; k < o.block; ++k) intact.step(dt, o.threads); }, o.minTime);
        report("(c) phantom nodes, 50 mm crack", static_cast<long>(cracked.points().size()), steps, t, "crack overhead");
        std::printf("    marked nodes %zu, twins %d of %d regular nodes\n", cracked.phantomNodes().markedNodes().size(),
                    cracked.phantomNodes().numTwins(), cracked.grid().numNodes());
    }
    return 0;
}
