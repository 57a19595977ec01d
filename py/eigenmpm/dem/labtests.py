"""Laboratory tests of the DEM alone, to measure what a calibration gives. Each resets the
scene (O.reset()) and leaves it holding the test: run them before building a scene."""
import math
import time

import numpy as np

from ..materials import ElasticMaterial
from ..params import Param, declared, takes
from .specimen import CALIBRATION, DAMPING, DT_FRACTION, LAYER, LAYERS, DemSpecimen

# How the test runs, beside the slab and the direction (shared with calibrateMeasured and measure).
_LENGTH = Param("length", None, "m", "length of the prism along the pull; default 24 r", kind="float",
                bounds="(0, inf)")
_WIDTH = Param("width", None, "m", "width of the prism across the pull; default 12 r", kind="float", bounds="(0, inf)")
_RATE = Param("strainRate", None, "1/s", "strain rate of the pull; default: the peak (about eps0) after about "
                                         "60 wave transits over the length (quasi-static)", kind="float",
              bounds="(0, inf)")
_END = Param("endStrain", None, "", "strain at which the test ends; default 6 eps0 (JCFpm) or "
                                    "(4 + relDuctility / 2) eps0 (CPM), eps0 the bonds' strain at damage "
                                    "onset or break", kind="float", bounds="(0, inf)")
_DAMPING = DAMPING.replace(default=0.4, doc="YADE's local damping (NewtonIntegrator.damping), for a "
                                            "quasi-static response")
_STOP = Param("stopBelow", 0.5, "", "past the peak, the test stops once the stress is below stopBelow x the "
                                    "peak (0: it runs to endStrain)", bounds="[0, 1)")
TEST_OPTIONS = (_LENGTH, _WIDTH, _RATE, _END, _DAMPING, DT_FRACTION, _STOP)


@takes(CALIBRATION, declared(ElasticMaterial, "rho"),
       LAYERS.replace(default=3, doc="hcp layers of the prism (those of the specimen's slab)"),
       _LENGTH, _WIDTH,
       Param("direction", "x", "", "direction of the pull: 'x' (along the close-packed rows) or 'y'",
             choices=("x", "y")),
       _RATE, _END, _DAMPING, DT_FRACTION, _STOP)
def uniaxialTension(calibration, rho, layers, length, width, direction, strainRate, endStrain, damping,
                    dtFraction, stopBelow):
    """Uniaxial tension test of the DEM alone: the E, nu and ft a calibration gives. It resets
    the scene (O.reset()), then pulls, quasi-statically, a prism of DEM spheres with the given
    calibration (a dict of :func:`calibrate`) of `layers` hcp layers (the slab of the
    specimen), length x width in plane (default 24 r x 12 r), pulled along
    `direction` ('x': along the close-packed rows, or 'y') by the velocity of its two end columns
    (one sphere thick, only the pulled component blocked), with damping (YADE's local damping)
    for a quasi-static response. Stress = reaction / (width x represented thickness), strain =
    change of the distance of the end columns / their initial distance.

    Returns a dict: E (secant modulus up to 40 % of the peak, Pa), nu (in-plane, from the
    lateral contraction of the middle third, at 40 % of the peak), ft (peak stress, Pa),
    strainAtPeak, Gf (dissipated energy / cross-section at the end, J/m2, when the specimen is
    cut through), spheres, steps, wall_s, and the curve (strain, stress). The run stops at
    endStrain or, past the peak, once the stress is below stopBelow x peak.

    Example::

        cal = eigenmpm.calibrateDem('cpm', 30e9, 0.2, 3e6, 100, 0.005)
        res = eigenmpm.uniaxialTension(cal, rho=2400, direction='y')
        res['E'], res['nu'], res['ft']
    """
    from yade import O, pack
    O.reset()
    r = calibration["radius"]
    L = length or 24 * r
    W = width or 12 * r
    ax = "xy".index(direction)
    size = [L, W] if ax == 0 else [W, L]
    box = pack.inAlignedBox((0, 0, 0), (size[0], size[1], 0))
    dem = DemSpecimen(box, calibration, rho, r, layers, layers * LAYER * r, damping=damping)
    x, ids = dem.centres()
    lo, hi = x[:, ax].min(), x[:, ax].max()
    tol = 0.5 * r
    neg = [i for i, p in zip(ids, x) if p[ax] < lo + r + tol]
    pos = [i for i, p in zip(ids, x) if p[ax] > hi - r - tol]
    E0 = calibration["bondModulus"] * calibration["modulusFactor"]
    eps0 = calibration["bondStrength"] * calibration["modulusFactor"] / E0
    c = math.sqrt(E0 / rho)
    gauge = hi - lo
    # quasi-static: the peak (about eps0) after ~60 wave transits over the length
    rate = strainRate or eps0 / (60.0 * gauge / c)
    v = 0.5 * rate * gauge
    comp = "xyz"[ax]
    vec = [0.0, 0.0, 0.0]
    vec[ax] = v
    bp = dem.velocityBC("pos", pos, comp, tuple(vec))
    vec[ax] = -v
    bn = dem.velocityBC("neg", neg, comp, tuple(vec))
    O.engines = dem.engines()
    O.dt = dtFraction * dem.criticalTimeStep()
    default_end = 6.0 if calibration["model"] == "jcfpm" else 4.0 + 0.5 * calibration["material"].get("relDuctility", 0.0)
    endStrain = endStrain or default_end * eps0
    steps = int(math.ceil(endStrain / rate / O.dt))
    area = W * layers * LAYER * r
    other = 1 - ax
    mid = [i for i, p in zip(ids, x) if abs(p[ax] - 0.5 * (lo + hi)) < gauge / 6]
    xm = x[:, other]
    sideLo = [i for i, p in zip(ids, x) if i in set(mid) and p[other] < xm.min() + tol]
    sideHi = [i for i, p in zip(ids, x) if i in set(mid) and p[other] > xm.max() - tol]
    w0 = xm.max() - xm.min()
    curve = []
    every = max(1, steps // 400)
    state = dict(peak=0.0)

    def sample():
        F = 0.5 * (bp.reaction[ax] - bn.reaction[ax])
        eps = (bp.displacement()[ax] - bn.displacement()[ax]) / gauge
        lat = (np.mean([O.bodies[i].state.pos[other] for i in sideHi]) -
               np.mean([O.bodies[i].state.pos[other] for i in sideLo]) - w0) / w0
        curve.append((eps, F / area, lat))
        state["peak"] = max(state["peak"], F / area)
        if stopBelow and F / area < stopBelow * state["peak"]:
            O.pause()

    from ..cli import runSteps
    from ..engines import callEvery
    O.engines = O.engines + [callEvery(sample, iterPeriod=every)]
    start, cpu = time.time(), time.process_time()
    runSteps(steps).check()  # Ctrl-C stops at once: nothing to keep from a calibration run
    wall, cpu = time.time() - start, time.process_time() - cpu
    e = np.array(curve)
    ip = int(np.argmax(e[:, 1]))
    ft = float(e[ip, 1])
    pre = e[:ip + 1]
    k40 = int(np.searchsorted(pre[:, 1], 0.4 * ft))
    k40 = max(1, min(k40, len(pre) - 1))
    E = float(pre[k40, 1] / pre[k40, 0])
    nu = float(-pre[k40, 2] / pre[k40, 0])
    _, nb, nbonds, energy = dem.bondState()
    cut = e[-1, 1] < 0.02 * ft
    return dict(E=E, nu=nu, ft=ft, strainAtPeak=float(e[ip, 0]), Gf=energy / area if cut else None,
                dissipated_J=energy, cutThrough=bool(cut), brokenBonds=nb, bonds=nbonds,
                spheres=len(ids), steps=O.iter, wall_s=wall, cpu_s=cpu, direction=direction, layers=layers,
                curve=e[:, :2].tolist())
