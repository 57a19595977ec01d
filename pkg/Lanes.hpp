// Loops whose iterations are independent lanes (one point each, the same scalar operations in
// each lane, no sum across lanes), run with the widest vectors the processor has: AVX-512, AVX2
// or the build's baseline (SSE2, or SSE4.2 in the x86-64-v2 module), chosen at run time.
//
// The lanes' results do not depend on the width: each lane does the same IEEE operations
// (additions, products, divisions and square roots, correctly rounded in every width), and no
// product is contracted into a fused multiply-add (the build passes -ffp-contract=off; AVX-512
// has FMA instructions). What changes is how many points go through at once: the solver's
// pointwise law and the co-rotational update of a run of points (Solver::lawOfRun2,
// corotationalOfRun2, corotationalOfRun3) wait on square roots and divisions, which the wide
// units take 4 or 8 at a time instead of 2, and P2G's uGIMP weights (Stencil::computeRun) go
// one point per lane (doc/performance.md, "Session 19"). P2G's and the stress pass's scatters
// run inside withLaneIsa too: each row of a support is one loop over its S x D numbers, one
// number per lane (Stencil::forEachRow..., doc/performance.md, "Session 20"). In 3D the sums of
// nodal 3-vectors (the strain update's velocity gradient, G2P's sums, APIC's rows) use one
// 4-lane vector per 3-vector (emp::Lane3), also inside withLaneIsa ("Session 21").
//
// `laneIsa()` is chosen once per process from the processor's flags; the environment variable
// EIGENMPM_LANES=baseline|avx2|avx512 (or auto) caps it, and `setLaneIsa` sets it (the tests run
// the same scene in every width and compare the results bit for bit).
#pragma once
#include <atomic>
#include <string>

#include "Inline.hpp"

namespace emp {

enum class LaneIsa { baseline = 0, avx2 = 1, avx512 = 2 };

/// The widest the processor runs (x86-64 built with GCC; otherwise the baseline).
LaneIsa processorLaneIsa();
namespace lanes {
extern std::atomic<int> now;  ///< laneIsa(), as an int (set at start-up, Lanes.cpp)
}
/// The width the lane loops use now.
inline LaneIsa laneIsa() { return static_cast<LaneIsa>(lanes::now.load(std::memory_order_relaxed)); }
/// Sets it (capped at processorLaneIsa()); returns the width set.
LaneIsa setLaneIsa(LaneIsa isa);
const char* name(LaneIsa isa);
/// "baseline", "avx2", "avx512" or "auto" (the processor's); false for another name.
bool laneIsaOf(const std::string& s, LaneIsa& isa);

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)  // (GCC's target attributes)
#define EMP_LANES_X86 1
namespace lanes {
// f() compiled once more per width: the loops written in f (inlined: the caller's lambda is
// EMP_LAMBDA_INLINE, and a function of the baseline inlines into a wider one) use that width.
template <class F> __attribute__((target("avx512f,avx512dq,prefer-vector-width=512"))) EMP_NOINLINE void avx512Call(F& f)
{
    f();
}
template <class F> __attribute__((target("avx2"))) EMP_NOINLINE void avx2Call(F& f) { f(); }
}  // namespace lanes
#endif

/// Calls f() compiled for the width laneIsa() names: f's own loops over lanes (written so that
/// GCC vectorises them without `omp simd`, Solver::corotationalOfRun3) then use that width. The
/// rest of f keeps its values: Eigen chooses its packets from the translation unit's flags, not
/// the function's, and GCC does not reorder a sum to vectorise it (no -ffast-math).
template <class F> EMP_ALWAYS_INLINE void withLaneIsa(F&& f)
{
#ifdef EMP_LANES_X86
    const LaneIsa isa = laneIsa();
    if (isa == LaneIsa::avx512) return lanes::avx512Call(f);
    if (isa == LaneIsa::avx2) return lanes::avx2Call(f);
#endif
    f();
}

/// Calls f(i) for i = 0 ... n-1 as one vectorised loop in the width laneIsa() names.
template <class F> EMP_ALWAYS_INLINE void forLanes(int n, F&& f)
{
    withLaneIsa([&]() EMP_LAMBDA_INLINE {
#pragma omp simd
        for (int i = 0; i < n; ++i) f(i);
    });
}

}  // namespace emp
