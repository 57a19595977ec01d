"""What running through YADE costs over the bare solver (issue 6, item 4: a plain elastic scene
costs the same as the bare solver). Run inside YADE, one thread:

    PYTHONPATH=build/python yade -n -j 1 -x bench/bench_yade_overhead.py [--rounds 12] [--steps 20]
                                                                        [--sizes 2e3,1e5]

Two identical plain elastic scenes (2D uGIMP block, E = 10 MPa, smooth initial velocity, no
boundary condition, no fracture physics), one per path:
  (Y) an MpmEngine in O.engines, advanced by O.run(steps, True): YADE's loop, the PyRunner, the
      engine's Python _action (time, boundary-condition updates) and the C++ step;
  (B) the bare solver of the same class (eigenmpm._eigenmpm.solvers[(2, 'ugimp')]), advanced by calling
      solver.step(dt, 1) `steps` times from Python (one bound call per step).
  (P) a third identical bare solver stepped by a plain yade.PyRunner in O.engines (command
      '_bare.step(dt, 1)'), to split YADE's own per-iteration cost (loop, PyRunner) from the
      engine's Python code.
All run the same steps from the same state. A round is one block of `steps` steps of each path,
the order rotating from round to round; the time is the process's CPU time (time.process_time),
which other processes on the machine do not inflate. Reported: the medians over rounds of the
ratios Y/B, P/B and Y/P, the range of Y/B, and the median extra CPU time per step of Y over B
(us). The paths' states are compared at the end (they must agree bitwise: same code, same
inputs).
"""
import json
import math
import sys
import time

import numpy as np
from yade import O

import eigenmpm as em
from eigenmpm import _eigenmpm


def options(argv):
    o = {"rounds": 12, "steps": 20, "sizes": "2e3,1e5"}
    i = 0
    while i < len(argv):
        key = argv[i].lstrip("-")
        if key not in o:
            sys.exit(f"bench_yade_overhead: unknown argument {argv[i]}")
        o[key] = type(o[key])(argv[i + 1])
        i += 2
    o["sizes"] = [int(float(s)) for s in str(o["sizes"]).split(",")]
    return o


def block(n):
    """Points of a square block of about n points at h = 1 cm, 2 per cell per direction."""
    side = int(round(math.sqrt(n)))
    dx = 0.005
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    pos = np.zeros((side * side, 3))
    pos[:, 0] = (i.ravel() + 0.5) * dx
    pos[:, 1] = (j.ravel() + 0.5) * dx
    vel = np.zeros_like(pos)
    vel[:, 0] = 0.1 * np.sin(40 * pos[:, 0])
    vel[:, 1] = 0.1 * np.cos(30 * pos[:, 1])
    return pos, vel, dx * dx


def main():
    import builtins
    from yade import PyRunner
    o = options(sys.argv[1:])
    results = []
    for n in o["sizes"]:
        O.reset()
        pos, vel, vol = block(n)
        mat = em.ElasticMaterial(E=1e7, nu=0.3, rho=1000)
        mpm = em.MpmEngine(dim=2, h=0.01, ppc=2, threads=1)
        mpm.addPoints(pos, mat, vol, vel)

        def bareSolver():
            # the engine's and the material's declared values, so that the states compare bitwise
            s = _eigenmpm.solvers[(2, 'ugimp')](h=mpm.h, ppc=mpm.ppc, massCutoff=mpm.massCutoff,
                                                padding=mpm.padding, gravity=mpm.gravity)
            s.addPoints(np.ascontiguousarray(pos), np.ascontiguousarray(vel), np.full(len(pos), vol),
                        s.addMaterial(E=mat.E, nu=mat.nu, rho=mat.rho, planeStress=mat.planeStress,
                                      split=mat.split))
            return s

        bare, viaRunner = bareSolver(), bareSolver()
        dt = 0.5 * mpm.criticalTimeStep()
        builtins._emp_bench = (viaRunner, dt)
        runner = PyRunner(command="_emp_bench[0].step(_emp_bench[1], 1)", iterPeriod=1)
        O.dt = dt
        steps = o["steps"]

        def yadePath():
            O.engines = [mpm]
            O.run(steps, True)

        def runnerPath():
            O.engines = [runner]
            O.run(steps, True)

        def barePath():
            for _ in range(steps):
                bare.step(dt, 1)

        paths = [("Y", yadePath), ("P", runnerPath), ("B", barePath)]
        for _, f in paths:
            f()  # warm-up (grid built, caches)
        t = {"Y": [], "P": [], "B": []}
        for k in range(o["rounds"]):
            for name, f in paths[k % 3:] + paths[:k % 3]:
                c0 = time.process_time()
                f()
                t[name].append(time.process_time() - c0)
        Y, P, B = (np.array(t[k]) for k in "YPB")
        same = all(np.array_equal(mpm.solver.positions(), s.positions())
                   and np.array_equal(mpm.solver.velocities(), s.velocities()) for s in (bare, viaRunner))
        r = {"points": len(pos), "rounds": o["rounds"], "steps_per_block": steps,
             "median_ratio_yade_over_bare": float(np.median(Y / B)),
             "min_ratio": float(np.min(Y / B)), "max_ratio": float(np.max(Y / B)),
             "median_ratio_pyrunner_over_bare": float(np.median(P / B)),
             "median_ratio_yade_over_pyrunner": float(np.median(Y / P)),
             "median_extra_us_per_step": float(np.median(Y - B) / steps * 1e6),
             "bare_us_per_step": float(np.median(B) / steps * 1e6),
             "states_bitwise_equal": bool(same)}
        results.append(r)
        print(f"{len(pos):8d} points, {o['rounds']} rounds of {steps} steps: MpmEngine/bare median "
              f"{r['median_ratio_yade_over_bare']:.3f} (rounds {r['min_ratio']:.3f}-{r['max_ratio']:.3f}), "
              f"plain PyRunner/bare {r['median_ratio_pyrunner_over_bare']:.3f}, MpmEngine/PyRunner "
              f"{r['median_ratio_yade_over_pyrunner']:.3f}; extra {r['median_extra_us_per_step']:.0f} us per step "
              f"over {r['bare_us_per_step']:.0f} us; states bitwise equal: {same}", flush=True)
        print("JSON " + json.dumps(r), flush=True)
    if not all(r["states_bitwise_equal"] for r in results):
        sys.exit("bench_yade_overhead: the paths diverged")


main()
