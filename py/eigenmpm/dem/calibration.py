"""DEM micro-parameters (CpmMat, JCFpmMat) for continuum constants E, nu, ft, Gc.

Calibration rule (:func:`calibrate`; affine deformation of an isotropic contact network with
contact density C and branch length L, normal and shear stiffness kn and ks = alpha kn):
    nu = (1 - alpha) / (4 + alpha),    E = C L^2 kn (2 + 3 alpha) / (3 (4 + alpha)),
so alpha = (1 - 4 nu) / (1 + nu) (nu <= 0.25), and for the hcp lattice (12 contacts per
sphere, L = 2r) E = c_E E_b with c_E = phi 12 / 4 (2 + 3 alpha) / (4 + alpha) and the bond
modulus E_b = kn L / A (A = pi r^2): CPM E_b = young, JCFpm E_b = 2 young / pi. In uniaxial
tension the bonds along the load carry the strain of the specimen, so the specimen starts to
crack at the bond's strain at damage onset (CPM epsCrackOnset) or break (JCFpm): epsCrackOnset
= ft / E, JCFpm tensileStrength = ft / c_E. The CPM bond's fracture energy per volume is
E_b eps0^2 (1/2 + relDuctility) (exponential softening); with the bonds crossing a plane of unit
area (3 phi 12 / (8 pi r^2) of them, each of volume 2 pi r^3) all broken, Gc = 9 phi r E_b eps0^2
(1/2 + relDuctility), which gives relDuctility. JCFpm bonds are brittle: its fracture energy
follows from E and ft and the radius and is only reported. :func:`uniaxialTension` measures
what the rule achieves; :func:`calibrateMeasured` corrects young and the bond strength by it.
"""
import math
import numbers

import numpy as np

from ..fracture import EigenErosion
from ..materials import ElasticMaterial
from ..params import Param, declared, takes
from .labtests import TEST_OPTIONS, uniaxialTension
from .specimen import CALIBRATION, HCP_CONTACTS, HCP_FRACTION, MODEL, RADIUS

NU_FIT = (0.384, 0.894)  # nu = a (1 - alpha) / (b + alpha), the 3-layer hcp slab (stiffnessRatio)
ALPHA_MAX = 0.45  # above, the rotational stiffness makes PWaveTimeStep() steps unstable


def _isCorrection(c):
    return (isinstance(c, (tuple, list)) and len(c) == 2
            and all(isinstance(k, numbers.Real) and not isinstance(k, bool) and math.isfinite(k) and k > 0
                    for k in c))


# The continuum constants the DEM is calibrated for: those of the MPM's material and erosion.
YOUNG = declared(ElasticMaterial, "E")
POISSON = declared(ElasticMaterial, "nu").replace(default=None, required=True)
DENSITY = declared(ElasticMaterial, "rho")
GC = declared(EigenErosion, "Gc")
STRENGTH = Param("ft", None, "Pa", "tensile strength (uniaxial)", kind="float", bounds="(0, inf)", required=True)
CONSTANTS = (MODEL.replace(default=None, required=True), YOUNG, POISSON, STRENGTH, GC, RADIUS)


def stiffnessRatio(nu):
    """ks / kn (CpmMat/JCFpmMat ``poisson``) for the in-plane Poisson's ratio nu of the hcp
    slab. The affine estimate is nu = (1 - alpha) / (4 + alpha); the slab measured with
    :func:`uniaxialTension` (3 layers, alpha = 0 to 0.4) follows nu = a (1 - alpha) / (b + alpha)
    with (a, b) = NU_FIT = (0.384, 0.894) within 0.007, so alpha = (a - b nu) / (a + nu),
    limited to 0 <= alpha <= ALPHA_MAX (nu from 0.17 to 0.38 is reachable)."""
    nu = POISSON.validate(nu, "stiffnessRatio")
    a, b = NU_FIT
    return min(ALPHA_MAX, max(0.0, (a - b * nu) / (a + nu)))


def modulusFactor(alpha):
    """c_E = E / E_b for the hcp lattice under affine deformation (see the module doc)."""
    return HCP_FRACTION * HCP_CONTACTS / 4.0 * (2.0 + 3.0 * alpha) / (4.0 + alpha)


@takes(*CONSTANTS,
       Param("correction", (1.0, 1.0), "", "factors (kE, kS) of the bond modulus and the bond strength "
                                          "(see calibrateMeasured)", kind="object",
             accepts="(kE, kS), two positive numbers", check=_isCorrection))
def calibrate(model, E, nu, ft, Gc, radius, correction):
    """DEM micro-parameters (CpmMat or JCFpmMat) for the continuum constants of a material, by a
    calibration rule. The constants are E (Pa), nu, ft (tensile strength, Pa) and Gc (J/m2), at
    sphere radius `radius` (m); the rule (eigenmpm.dem.calibration, doc/dem-comparison.md) is that
    of an hcp lattice under affine deformation, with the bond modulus and the bond strength
    multiplied by correction = (kE, kS) (see :func:`calibrateMeasured`; relDuctility follows, so
    that Gc is kept). Returns a dict: the material's keyword arguments under 'material', and the
    rule's numbers.

    Example::

        cal = eigenmpm.calibrateDem('cpm', E=30e9, nu=0.2, ft=3e6, Gc=100, radius=0.005)
        cal['material']      # CpmMat(**cal['material'], density=...)
    """
    alpha = stiffnessRatio(nu)
    cE = modulusFactor(alpha)
    kE, kS = (float(c) for c in correction)
    Eb = kE * E / cE  # bond modulus
    sb = kS * ft / cE  # bond stress at damage onset (CPM) or break (JCFpm)
    out = dict(model=model, alpha=alpha, modulusFactor=cE, bondModulus=Eb, bondStrength=sb,
               correctionE=kE, correctionStrength=kS, radius=radius)
    friction = math.atan(0.8)
    if model == "cpm":
        eps0 = sb / Eb
        relDuctility = Gc / (9.0 * HCP_FRACTION * radius * Eb * eps0 ** 2) - 0.5
        if relDuctility < 1.0:
            raise ValueError(f"EigenMPM: CPM relDuctility = {relDuctility:.3g} < 1 for Gc = {Gc} J/m2, "
                             f"ft = {ft} Pa at radius {radius} m: the spheres are too large for this "
                             f"fracture energy (bonds would snap back); use a smaller radius")
        out["material"] = dict(young=Eb, poisson=alpha, epsCrackOnset=eps0, relDuctility=relDuctility,
                               sigmaT=1.5 * sb, frictionAngle=friction)
        out["bondGc"] = Gc
    else:
        young = 0.5 * math.pi * Eb
        out["material"] = dict(young=young, poisson=alpha, tensileStrength=sb, cohesion=2.0 * sb,
                               frictionAngle=friction, residualFrictionAngle=friction)
        out["bondGc"] = 9.0 * HCP_FRACTION * radius * Eb * (sb / Eb) ** 2 * 0.5  # implied, brittle
    return out


# What the measurement of a calibration adds: the slab and the directions of the test.
_LAYERS = declared(uniaxialTension, "layers")
_DIRECTIONS = Param("directions", ("x", "y"), "", "directions of the uniaxial tension tests, averaged",
                    kind="object", accepts="a non-empty tuple or list of 'x' and 'y'",
                    check=lambda d: isinstance(d, (tuple, list)) and len(d) > 0 and all(x in ("x", "y") for x in d))


@takes(CALIBRATION, DENSITY, _LAYERS, _DIRECTIONS, *TEST_OPTIONS)
def measure(calibration, rho, layers, directions, **options):
    """What a calibration gives: :func:`uniaxialTension` along each direction. Returns E, nu, ft
    averaged over the directions, the single results under 'runs' (without curves) and the CPU
    seconds."""
    runs = [uniaxialTension(calibration, rho, layers=layers, direction=d, **options) for d in directions]
    out = {k: float(np.mean([r[k] for r in runs])) for k in ("E", "nu", "ft")}
    out["runs"] = [{k: v for k, v in r.items() if k != "curve"} for r in runs]
    out["cpu_s"] = sum(r["cpu_s"] for r in runs)
    return out


@takes(*CONSTANTS, DENSITY, _LAYERS,
       Param("iterations", 1, "", "corrections by measurement (0: measure the plain rule)", bounds="[0, inf)"),
       _DIRECTIONS, *TEST_OPTIONS)
def calibrateMeasured(model, E, nu, ft, Gc, radius, rho, layers, iterations, **measurement):
    """DEM micro-parameters by the calibration rule, corrected by measuring the DEM. That is
    :func:`calibrate`, then `iterations` corrections: the DEM is measured (:func:`measure`:
    uniaxial tension along x and y, averaged) and young and the bond strength scaled by target /
    measured of E and ft. The result carries every measurement under 'history' and the last,
    of the returned parameters, under 'measured' (so iterations=0 measures the plain rule).
    Resets the scene (run it before building the specimens)."""
    kE = kS = 1.0
    history = []
    for it in range(iterations + 1):
        cal = calibrate(model, E, nu, ft, Gc, radius, correction=(kE, kS))
        m = measure(cal, rho, layers, **measurement)
        m.update(correctionE=kE, correctionStrength=kS, errorE=m["E"] / E - 1, errorFt=m["ft"] / ft - 1,
                 errorNu=m["nu"] - nu)
        history.append(m)
        kE *= E / m["E"]
        kS *= ft / m["ft"]
    cal["measured"] = history[-1]
    cal["history"] = history
    return cal
