"""Scenes that tests/python/test_isa.py runs once with each build of the compiled module
(EIGENMPM_ISA=x86-64 and x86-64-v2): 2D and 3D, uGIMP and linear shapes, both transfers and
both stress updates, eigenerosion that erodes and a phantom-node crack. Prints one line per
scene: its name, the sha256 of its solver's saved state (every point and node array) after the
steps, and its eroded points, so that the two builds can be compared bitwise.

    EIGENMPM_ISA=x86-64 yade -n -x tests/python/isa_scenes.py
"""
import hashlib
import math

import numpy as np
from yade import O, pack

import eigenmpm as em

GLASS = dict(E=72e9, nu=0.22, rho=2440.0)


def spinning(dim, shape, transfer, stressUpdate, Gc):
    """A spinning, stretching block (rotation and a tensile rate), eroding when Gc is small."""
    O.reset()
    h, a = 1e-3, 8e-3
    lo, hi = (-2 * a, -2 * a, -2 * a if dim == 3 else 0), (2 * a, 2 * a, 2 * a if dim == 3 else 0)
    mpm = em.MpmEngine(dim=dim, h=h, **(dict(thickness=h) if dim == 2 else {}), shape=shape, transfer=transfer, stressUpdate=stressUpdate,
                       domain=(lo, hi))
    mpm.fill(pack.inAlignedBox((-a, -a / 2, -a / 2 if dim == 3 else -1), (a, a / 2, a / 2 if dim == 3 else 1)),
             em.ElasticMaterial(**GLASS))
    x = np.array(mpm.solver.positions())
    omega, rate = 2e3, 2e2
    v = np.zeros((len(x), 3))
    v[:, 0] = -omega * x[:, 1] + rate * x[:, 0]
    v[:, 1] = omega * x[:, 0]
    mpm.solver.setVelocities(np.ascontiguousarray(v))
    erosion = em.EigenErosion(engine=mpm, Gc=Gc, alpha=2.0, kappaOverH=1.1)
    O.engines = [mpm, erosion]
    O.dt = 0.4 * mpm.criticalTimeStep()
    return mpm, erosion


def precracked():
    """A 2D plate pulled apart at its ends with a phantom-node crack from one edge."""
    O.reset()
    h, L, W = 1e-3, 0.04, 0.02
    mpm = em.MpmEngine(dim=2, h=h, thickness=h, domain=((-2 * h, -2 * h, 0), (L + 2 * h, W + 2 * h, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, -1), (L, W, 1)), em.ElasticMaterial(**GLASS))
    mpm.crack([(L / 2, -h, 0), (L / 2, W / 2 + 0.3 * h, 0)])
    x = np.array(mpm.solver.positions())
    v = np.zeros((len(x), 3))
    v[:, 0] = 4.0 * (x[:, 0] - L / 2) / L
    mpm.solver.setVelocities(np.ascontiguousarray(v))
    erosion = em.EigenErosion(engine=mpm, Gc=20.0, alpha=2.0, kappaOverH=1.1)
    O.engines = [mpm, erosion]
    O.dt = 0.4 * mpm.criticalTimeStep()
    return mpm, erosion


SCENES = {
    "2D uGIMP FLIP smallStrain": (lambda: spinning(2, "uGIMP", "FLIP", "smallStrain", 5.0), 200),
    "2D uGIMP APIC corotational": (lambda: spinning(2, "uGIMP", "APIC", "corotational", 5.0), 200),
    "2D linear FLIP corotational": (lambda: spinning(2, "linear", "FLIP", "corotational", 5.0), 200),
    "3D uGIMP FLIP smallStrain": (lambda: spinning(3, "uGIMP", "FLIP", "smallStrain", 5.0), 40),
    "3D uGIMP APIC corotational": (lambda: spinning(3, "uGIMP", "APIC", "corotational", 5.0), 40),
    "2D uGIMP phantom crack": (precracked, 300),
}

for name, (build, steps) in SCENES.items():
    mpm, erosion = build()
    O.run(steps, True)
    state = bytes(mpm.solver.saveState())
    eroded = int(np.sum(np.array(mpm.solver.damage()) == 0))
    assert math.isfinite(mpm.kineticEnergy())
    print(f"SCENE {name}: {hashlib.sha256(state).hexdigest()} eroded {eroded} points {mpm.solver.numPoints}", flush=True)
