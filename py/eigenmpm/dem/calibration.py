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

import numpy as np

from .labtests import uniaxialTension
from .specimen import HCP_CONTACTS, HCP_FRACTION

MODELS = ("cpm", "jcfpm")
NU_FIT = (0.384, 0.894)  # nu = a (1 - alpha) / (b + alpha), the 3-layer hcp slab (stiffnessRatio)
ALPHA_MAX = 0.45  # above, the rotational stiffness makes PWaveTimeStep() steps unstable


def stiffnessRatio(nu):
    """ks / kn (CpmMat/JCFpmMat ``poisson``) for the in-plane Poisson's ratio nu of the hcp
    slab. The affine estimate is nu = (1 - alpha) / (4 + alpha); the slab measured with
    :func:`uniaxialTension` (3 layers, alpha = 0 to 0.4) follows nu = a (1 - alpha) / (b + alpha)
    with (a, b) = NU_FIT = (0.384, 0.894) within 0.007, so alpha = (a - b nu) / (a + nu),
    limited to 0 <= alpha <= ALPHA_MAX (nu from 0.17 to 0.38 is reachable)."""
    if not -1.0 < nu < 0.5:
        raise ValueError(f"EigenMPM: nu = {nu!r} is invalid; allowed: -1 < nu < 0.5")
    a, b = NU_FIT
    return min(ALPHA_MAX, max(0.0, (a - b * nu) / (a + nu)))


def modulusFactor(alpha):
    """c_E = E / E_b for the hcp lattice under affine deformation (see the module doc)."""
    return HCP_FRACTION * HCP_CONTACTS / 4.0 * (2.0 + 3.0 * alpha) / (4.0 + alpha)


def calibrate(model, E, nu, ft, Gc, radius, correction=(1.0, 1.0)):
    """DEM micro-parameters for continuum constants E (Pa), nu, ft (tensile strength, Pa) and
    Gc (J/m2) at sphere radius `radius` (m), by the rule of the module doc, with the bond modulus
    and the bond strength multiplied by correction = (kE, kS) (see :func:`calibrateMeasured`;
    relDuctility follows, so that Gc is kept). Returns a dict: the material's keyword arguments
    under 'material', and the rule's numbers."""
    model = _model(model)
    for name, v in (("E", E), ("ft", ft), ("Gc", Gc), ("radius", radius)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"EigenMPM: {name} = {v!r} is invalid; allowed: {name} > 0")
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


def measure(calibration, rho, layers=3, directions=("x", "y"), **kw):
    """:func:`uniaxialTension` along each direction; returns E, nu, ft averaged over them, the
    single results under 'runs' (without curves) and the CPU seconds."""
    runs = [uniaxialTension(calibration, rho, layers=layers, direction=d, **kw) for d in directions]
    out = {k: float(np.mean([r[k] for r in runs])) for k in ("E", "nu", "ft")}
    out["runs"] = [{k: v for k, v in r.items() if k != "curve"} for r in runs]
    out["cpu_s"] = sum(r["cpu_s"] for r in runs)
    return out


def calibrateMeasured(model, E, nu, ft, Gc, radius, rho, layers=3, iterations=1, **kw):
    """:func:`calibrate`, then `iterations` corrections: the DEM is measured (:func:`measure`:
    uniaxial tension along x and y, averaged) and young and the bond strength scaled by target /
    measured of E and ft. The result carries every measurement under 'history' and the last,
    of the returned parameters, under 'measured' (so iterations=0 measures the plain rule).
    Resets the scene (run it before building the specimens)."""
    kE = kS = 1.0
    history = []
    for it in range(iterations + 1):
        cal = calibrate(model, E, nu, ft, Gc, radius, correction=(kE, kS))
        m = measure(cal, rho, layers, **kw)
        m.update(correctionE=kE, correctionStrength=kS, errorE=m["E"] / E - 1, errorFt=m["ft"] / ft - 1,
                 errorNu=m["nu"] - nu)
        history.append(m)
        kE *= E / m["E"]
        kS *= ft / m["ft"]
    cal["measured"] = history[-1]
    cal["history"] = history
    return cal


def _model(model):
    m = str(model).lower()
    if m not in MODELS:
        raise ValueError(f"EigenMPM: DEM model = {model!r} is invalid; allowed: 'cpm' or 'jcfpm'")
    return m
