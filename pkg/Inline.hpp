// EMP_ALWAYS_INLINE: forced inlining (GCC/Clang) of the small per-point functions of the hot
// passes. Left to itself, GCC's inliner keeps some instantiations out of line in a large
// translation unit, and a per-point call then costs the call and keeps the pass's sums out of
// registers (about 20 % for Stencil::forEach; 20 % for the co-rotational update's helpers).
// EMP_LAMBDA_INLINE: the same for a lambda (after its parameter list): a pass's per-point body
// inlined into the Scheduler's loop.
// EMP_NOINLINE: the opposite, for a rare branch of a hot loop whose inlined body would change the
// loop's code (Solver::mapSupport: P2G took 3 % more instructions with it inlined).
#pragma once

#if defined(__GNUC__)
#define EMP_ALWAYS_INLINE __attribute__((always_inline)) inline
#define EMP_NOINLINE __attribute__((noinline))
#define EMP_LAMBDA_INLINE __attribute__((always_inline))
#else
#define EMP_LAMBDA_INLINE
#define EMP_ALWAYS_INLINE inline
#define EMP_NOINLINE
#endif
