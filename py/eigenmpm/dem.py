"""DEM fracture beside EigenMPM in one YADE run: the same specimen, material and loading,
modelled by YADE's discrete elements (CPM, or JCFpm) and by the material point method.

    import eigenmpm as em
    pair = em.DemMpmPair(specimen, E=30e9, nu=0.2, rho=2400, Gc=100, ft=3e6, h=0.01,
                         radius=0.005, thickness=0.05)
    pair.notch([(0.225, -0.01, 0), (0.225, 0.05, 0)])
    pair.fix('left', points=..., components='y')
    load = pair.velocityBC('load', points=..., components='y', velocity=(0, -0.02, 0))
    O.engines = pair.engines() + [em.callEvery(pair.record, iterPeriod=10)]
    pair.setTimeStep(0.8)            # one O.dt below both critical steps
    O.run(5000, True)
    pair.summary()

The DEM specimen is a slab of spheres of radius r on a hexagonal close-packed (hcp) lattice
with the stacking axis along z, so that its in-plane elastic response is isotropic; it lies
``offset`` away from the MPM specimen (beside it in x by default), so the two never touch (they
could not interact anyway: MPM points are not YADE bodies). Each sphere represents the volume
of its lattice cell, 2r x sqrt(3) r x 2 sqrt(6)/3 r = (4/3 pi r^3) / phi with phi = pi/(3 sqrt 2),
and gets the density rho / phi, so the DEM slab has the continuum's mass. A slab of n layers
represents the thickness n 2 sqrt(6)/3 r; DEM forces and energies are scaled by
thickness / (that thickness) so that both models report them for the MPM's thickness.

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
what the rule achieves; ``calibrate(..., measured=...)`` corrects young and the strength once.
"""
import math
import time

import numpy as np

HCP_FRACTION = math.pi / (3.0 * math.sqrt(2.0))  # solid fraction of hcp (and fcc)
HCP_CONTACTS = 12
LAYER = 2.0 * math.sqrt(6.0) / 3.0  # hcp layer spacing / r
MODELS = ("cpm", "jcfpm")


# --- calibration rule ---------------------------------------------------------------------------
NU_FIT = (0.384, 0.894)  # nu = a (1 - alpha) / (b + alpha), the 3-layer hcp slab (module doc)
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


# --- DEM specimen -----------------------------------------------------------------------------
def _zplane(predicate):
    lo, hi = predicate.aabb()
    return 0.5 * (lo[2] + hi[2]) if math.isfinite(lo[2]) and math.isfinite(hi[2]) else 0.0


def hcpCenters(predicate, radius, layers):
    """Centres (n x 3, m) of a slab of `layers` hcp layers of spheres of radius `radius` whose
    in-plane lattice cells (2r x sqrt(3) r) have their centre inside the predicate (evaluated in
    the plane z = middle of its z-range, like MpmEngine.fill); the slab is centred on z = 0."""
    if layers < 1:
        raise ValueError(f"EigenMPM: layers = {layers!r} is invalid; allowed: layers >= 1")
    lo, hi = predicate.aabb()
    if not all(math.isfinite(lo[i]) and math.isfinite(hi[i]) for i in (0, 1)):
        raise ValueError("EigenMPM: the predicate's bounding box is unbounded in x or y; intersect it with a box")
    zp = _zplane(predicate)
    r = radius
    dy = math.sqrt(3.0) * r
    dz = LAYER * r
    out = []
    for k in range(int(layers)):
        z = (k - 0.5 * (layers - 1)) * dz
        sx, sy = (r, dy / 3.0) if k % 2 else (0.0, 0.0)
        ny = int(math.floor((hi[1] - lo[1]) / dy)) + 2
        nx = int(math.floor((hi[0] - lo[0]) / (2 * r))) + 2
        for j in range(-1, ny):
            y = lo[1] + (j + 0.5) * dy + sy
            shift = r if j % 2 else 0.0
            for i in range(-1, nx):
                x = lo[0] + r + 2 * r * i + shift + sx
                if predicate((x, y, zp), 0.0):
                    out.append((x, y, z))
    return np.array(out, float).reshape(-1, 3)


def layersFor(thickness, radius):
    """Number of hcp layers whose represented thickness (layers x 2 sqrt(6)/3 r) is nearest to
    `thickness` (at least 1)."""
    return max(1, int(round(thickness / (LAYER * radius))))


def _material(model, params, density):
    from yade import CpmMat, JCFpmMat
    kw = dict(params["material"], density=density)
    return CpmMat(**kw) if model == "cpm" else JCFpmMat(**kw)


def _demEngines(model, damping, factor, tag):
    from yade import (Bo1_Sphere_Aabb, ForceResetter, Ig2_Sphere_Sphere_ScGeom, InsertionSortCollider,
                      InteractionLoop, NewtonIntegrator)
    if model == "cpm":
        from yade import Ip2_CpmMat_CpmMat_CpmPhys, Law2_ScGeom_CpmPhys_Cpm
        ip, law = Ip2_CpmMat_CpmMat_CpmPhys(cohesiveThresholdIter=10), Law2_ScGeom_CpmPhys_Cpm()
    else:
        from yade import Ip2_JCFpmMat_JCFpmMat_JCFpmPhys, Law2_ScGeom_JCFpmPhys_JointedCohesiveFrictionalPM
        ip = Ip2_JCFpmMat_JCFpmMat_JCFpmPhys(cohesiveTresholdIteration=1)
        law = Law2_ScGeom_JCFpmPhys_JointedCohesiveFrictionalPM()
    bo1 = Bo1_Sphere_Aabb(aabbEnlargeFactor=factor, label=f"{tag}_aabb")
    ig2 = Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=factor, label=f"{tag}_ig2")
    law.label = f"{tag}_law"
    engines = [ForceResetter(label=f"{tag}_forces"), InsertionSortCollider([bo1], label=f"{tag}_collider"),
               InteractionLoop([ig2], [ip], [law], label=f"{tag}_interactions"),
               NewtonIntegrator(damping=damping, label=f"{tag}_newton")]
    return engines, bo1, ig2, law


class DemBC:
    """Prescribed velocity on DEM spheres (blocked translational DOFs moved at the velocity).
    ``reaction`` is the force the condition exerts on the specimen: minus the sum of the
    forces the specimen exerts on these spheres (O.forces), times the thickness scale."""

    def __init__(self, ids, components, velocity, rampTime, scale):
        from yade import O
        self.ids, self.components = list(ids), components
        self.velocity, self.rampTime, self.scale = velocity, float(rampTime), scale
        self.x0 = np.array([list(O.bodies[i].state.pos) for i in self.ids]).reshape(-1, 3)
        for i in self.ids:
            O.bodies[i].state.blockedDOFs = components
        self._mask = np.array([c in components for c in "xyz"], float)

    def value(self, t):
        if callable(self.velocity):
            return np.asarray(list(self.velocity(t)), float)
        f = 1.0 if self.rampTime <= 0 else min(max(t / self.rampTime, 0.0), 1.0)
        return f * np.asarray(list(self.velocity), float)

    def apply(self, t):
        from yade import O, Vector3
        done = not callable(self.velocity) and t >= self.rampTime
        if done and getattr(self, "_final", False):
            return  # blocked DOFs keep their velocity: nothing to do after the ramp
        self._final = done
        v = self.value(t) * self._mask
        for i in self.ids:
            s = O.bodies[i].state
            w = s.vel
            s.vel = Vector3(*[v[k] if self._mask[k] else w[k] for k in range(3)])

    @property
    def reaction(self):
        from yade import O, Vector3
        f = np.zeros(3)
        for i in self.ids:
            f -= np.asarray(list(O.forces.f(i)), float)
        return Vector3(*(self.scale * f))

    def displacement(self):
        """Mean displacement of the spheres (Vector3-like numpy array, m)."""
        from yade import O
        x = np.array([list(O.bodies[i].state.pos) for i in self.ids]).reshape(-1, 3)
        return np.mean(x - self.x0, axis=0) if len(x) else np.zeros(3)


class DemSpecimen:
    """A slab of CPM or JCFpm spheres filling a yade.pack predicate (see :func:`hcpCenters`), with
    its engines, boundary conditions and fracture diagnostics. Bodies are appended to O.bodies."""

    def __init__(self, predicate, params, rho, radius, layers, thickness, offset=(0, 0, 0),
                 damping=0.0, factor=1.1, tag="dem"):
        from yade import O, Vector3, utils
        self.model, self.params, self.radius, self.layers = params["model"], params, radius, int(layers)
        self.offset = np.asarray(list(offset), float)
        self.tag = tag
        centres = hcpCenters(predicate, radius, self.layers)
        if len(centres) == 0:
            raise ValueError(f"EigenMPM: the predicate {predicate!r} holds no DEM sphere of radius {radius}")
        self.representedThickness = self.layers * LAYER * radius
        self.scale = thickness / self.representedThickness  # DEM forces/energies -> thickness
        self.density = rho / HCP_FRACTION
        self.material = _material(self.model, params, self.density)
        mat = O.materials.append(self.material)
        bodies = [utils.sphere(Vector3(*(c + self.offset)), radius, material=mat) for c in centres]
        self.ids = list(O.bodies.append(bodies))
        self._idset = set(self.ids)
        self.engineList, self.bo1, self.ig2, self.law = _demEngines(self.model, damping, factor, tag)
        self.bcs = {}
        self.bonds = None  # (id1, id2) -> (A, L, E, eps0, epsF) of the initial cohesive bonds

    def remove(self, ids):
        """Removes spheres (before the first step), e.g. a notch."""
        from yade import O
        for i in ids:
            O.bodies.erase(int(i))
            self._idset.discard(int(i))
        self.ids = [i for i in self.ids if i in self._idset]

    def centres(self):
        """Current positions of the spheres, n x 3 (m), and their ids."""
        from yade import O
        return np.array([list(O.bodies[i].state.pos) for i in self.ids]).reshape(-1, 3), self.ids

    def select(self, region, pad=0.0):
        """Ids of the spheres whose centre, moved back by the offset, lies in `region` (a yade.pack
        predicate in specimen coordinates, evaluated in its own middle z-plane) with ``pad``."""
        x, ids = self.centres()
        zp = _zplane(region)
        return [i for i, p in zip(ids, x) if region((p[0] - self.offset[0], p[1] - self.offset[1], zp), pad)]

    def velocityBC(self, label, ids, components, velocity, rampTime=0.0):
        if len(ids) == 0:
            raise ValueError(f"EigenMPM: DEM condition {label!r} selects no sphere; give a demRegion")
        bc = DemBC(ids, components, velocity, rampTime, self.scale)
        self.bcs[label] = bc
        return bc

    def control(self):
        """Per-step work before the integrator: back to a detection factor of 1 once the initial
        bonds exist, then the prescribed velocities at O.time."""
        from yade import O
        if O.iter >= 1 and self.bonds is None:
            self.bo1.aabbEnlargeFactor = self.ig2.interactionDetectionFactor = 1.0
            self._snapshotBonds()
        t = O.time
        for bc in self.bcs.values():
            bc.apply(t)

    def engines(self):
        from .engines import callEvery
        ctl = callEvery(self.control, iterPeriod=1, label=f"{self.tag}_control")
        return self.engineList[:3] + [ctl] + self.engineList[3:]

    def criticalTimeStep(self):
        """YADE's PWaveTimeStep(): min over spheres of r / sqrt(young / density), in s."""
        from yade import utils
        return utils.PWaveTimeStep()

    # --- bonds, damage and energy -----------------------------------------------------------
    def _snapshotBonds(self):
        from yade import O
        self.bonds = {}
        for i in O.interactions:
            if not i.isReal or i.id1 not in self._idset or i.id2 not in self._idset:
                continue
            p = i.phys
            if not p.isCohesive:
                continue
            if self.model == "cpm":
                self.bonds[(i.id1, i.id2)] = (p.crossSection, p.refLength, p.E, p.epsCrackOnset, p.epsFracture)
            else:
                self.bonds[(i.id1, i.id2)] = (p.crossSection, 2 * self.radius, p.kn, p.FnMax, p.FsMax)

    def bondState(self, omegaBroken=0.99):
        """(positions of broken bonds n x 3, broken count, bond count, dissipated energy J). CPM:
        a bond is broken when its damage omega >= omegaBroken or it has been deleted; the
        dissipated energy is the tensile damage dissipation of every bond with the exponential
        law, A L E [eps0^2/2 + eps0 epsF (1 - x) - eps0 kappa x / 2], x = exp(-(kappa - eps0)/epsF),
        kappa the largest normal strain (shear plasticity is not counted). JCFpm: a bond is broken
        when it lost cohesion; the energy is the bond's elastic energy at breakage (the law's
        totalTensCracksE + totalShearCracksE). Energies are scaled to the thickness."""
        from yade import O
        if O.iter < 1:
            return np.zeros((0, 3)), 0, 0, 0.0
        if self.bonds is None:
            self._snapshotBonds()
        seen = set()
        energy = 0.0
        broken = []
        pos = {}

        def mid(a, b):
            for j in (a, b):
                if j not in pos:
                    pos[j] = np.asarray(list(O.bodies[j].state.pos), float)
            return 0.5 * (pos[a] + pos[b])

        for i in O.interactions:
            key = (i.id1, i.id2)
            if key not in self.bonds or not i.isReal:
                continue
            p = i.phys
            seen.add(key)
            if self.model == "cpm":
                A, L, E, e0, ef = self.bonds[key]
                energy += cpmBondEnergy(p.kappaD, e0, ef) * A * L * E
                if p.omega >= omegaBroken:
                    broken.append(mid(*key))
            elif p.isBroken or not p.isCohesive:
                broken.append(mid(*key))
        for key, b in self.bonds.items():
            if key not in seen:  # deleted: fully broken
                if self.model == "cpm":
                    energy += cpmBondEnergy(math.inf, b[3], b[4]) * b[0] * b[1] * b[2]
                broken.append(mid(*key))
        if self.model == "jcfpm":
            energy = self.law.totalTensCracksE + self.law.totalShearCracksE
        return np.array(broken, float).reshape(-1, 3), len(broken), len(self.bonds), self.scale * energy


def cpmBondEnergy(kappa, eps0, epsF):
    """Energy dissipated per bond volume / E by CPM's exponential damage law (damLaw = 1) after
    the largest normal strain kappa: the envelope work minus the elastic energy left,
    eps0^2/2 + eps0 epsF (1 - x) - eps0 kappa x / 2 with x = exp(-(kappa - eps0)/epsF), 0 below
    eps0, eps0^2/2 + eps0 epsF for kappa -> infinity."""
    if not kappa > eps0:
        return 0.0
    if math.isinf(kappa):
        return 0.5 * eps0 ** 2 + eps0 * epsF
    x = math.exp(-(kappa - eps0) / epsF)
    return 0.5 * eps0 ** 2 + eps0 * epsF * (1.0 - x) - 0.5 * eps0 * kappa * x


# --- the pair ---------------------------------------------------------------------------------
class _Pair:
    """A pair of conditions, MPM and DEM, under one label."""

    def __init__(self, label, mpm, dem, mpmIds, mpmEngine):
        self.label, self.mpm, self.dem, self._ids, self._engine = label, mpm, dem, mpmIds, mpmEngine
        self._x0 = mpmEngine.solver.positions()[mpmIds].copy() if len(mpmIds) else None

    def mpmDisplacement(self):
        if self._x0 is None:
            return np.zeros(3)
        return np.mean(self._engine.solver.positions()[self._ids] - self._x0, axis=0)


class DemMpmPair:
    """The same specimen (a yade.pack predicate, 2D in x-y) as a plane-stress EigenMPM body of
    thickness t (MpmEngine.fill + EigenErosion) and a DEM slab (see the module doc), the DEM
    placed `offset` away (default: beside the MPM specimen in +x, a gap of a quarter of its
    width). Give the calibration (a dict of :func:`calibrate`) or let it be made by the rule.
    Boundary conditions go on both through :meth:`velocityBC` / :meth:`fix`; :meth:`engines`
    returns the engines of both; :meth:`setTimeStep` sets one O.dt below both critical steps."""

    def __init__(self, predicate, E, nu, rho, Gc, ft, h, radius, thickness=1.0, model="cpm",
                 calibration=None, layers=None, offset=None, ppc=2, alpha=1.5, kappaOverH=1.1,
                 damping=0.0, erosionPeriod=100, label="mpm"):
        from yade import O
        from .engines import MpmEngine
        from .fracture import EigenErosion
        from .materials import ElasticMaterial
        self.model = _model(model)
        self.constants = dict(E=E, nu=nu, rho=rho, Gc=Gc, ft=ft, thickness=thickness, h=h, radius=radius)
        self.calibration = calibration or calibrate(self.model, E, nu, ft, Gc, radius)
        if self.calibration["model"] != self.model:
            raise ValueError("EigenMPM: the calibration is for another DEM model")
        self.mpm = MpmEngine(dim=2, h=h, ppc=ppc, thickness=thickness, label=label)
        self.mpm.fill(predicate, ElasticMaterial(E=E, nu=nu, rho=rho, planeStress=True))
        self.erosion = EigenErosion(engine=self.mpm, Gc=Gc, alpha=alpha, kappaOverH=kappaOverH,
                                    iterPeriod=erosionPeriod)
        lo, hi = predicate.aabb()
        if offset is None:
            w = hi[0] - lo[0]
            offset = (w + max(0.25 * w, 4 * radius + 2 * h), 0.0, 0.0)
        self.layers = int(layers) if layers else layersFor(thickness, radius)
        self.dem = DemSpecimen(predicate, self.calibration, rho, radius, self.layers, thickness, offset,
                               damping=damping)
        self.pairs = {}
        self.curves = {}
        self._t0 = None
        O.timingEnabled = True

    # --- specimen and conditions ------------------------------------------------------------
    def notch(self, vertices, width=None):
        """A notch along the polyline `vertices` (specimen coordinates): in the MPM a phantom-node
        crack (MpmEngine.crack), in the DEM the spheres whose centre lies within width/2 (default
        1.01 r, which cuts the bonds across it) of the polyline, measured normal to a segment
        (no round caps at the ends), are removed: a notch 2 to 4 r wide that ends within r of
        the last vertex."""
        self.mpm.crack(vertices)
        half = 0.5 * width if width else 1.01 * self.dem.radius
        x, ids = self.dem.centres()
        v = np.array([list(p) for p in vertices], float)[:, :2] + self.dem.offset[:2]
        gone = [i for i, p in zip(ids, x) if _distanceToPolyline(p[:2], v, caps=False) < half]
        self.dem.remove(gone)
        return gone

    def velocityBC(self, label, points=None, region=None, demRegion=None, components="xy",
                   velocity=(0, 0, 0), rampTime=0.0):
        """A velocity condition on both models: on the MPM as ``MpmEngine.velocityBC(points= or
        region=)``, on the DEM on the spheres whose centre lies in demRegion (specimen coordinates;
        default: `points`, enlarged by the radius r). Returns the pair (.mpm, .dem)."""
        if points is not None and not callable(points) and not hasattr(points, "aabb"):
            mpmIds = np.asarray(points, int)
        elif points is not None:
            mpmIds = self.mpm.pointsIn(points)
        else:
            mpmIds = np.zeros(0, int)
        m = self.mpm.velocityBC(region=region, points=None if points is None else mpmIds,
                                components=components, velocity=velocity, rampTime=rampTime, label=label)
        if demRegion is not None:
            ids = self.dem.select(demRegion)
        elif points is not None and hasattr(points, "aabb"):
            ids = self.dem.select(points, -self.dem.radius)
        elif region is not None and hasattr(region, "aabb"):
            ids = self.dem.select(region, -self.dem.radius)
        else:
            raise ValueError(f"EigenMPM: give demRegion for condition {label!r}")
        d = self.dem.velocityBC(label, ids, components, velocity, rampTime)
        pair = _Pair(label, m, d, mpmIds, self.mpm)
        self.pairs[label] = pair
        self.curves[label] = []
        return pair

    def fix(self, label, points=None, region=None, demRegion=None, components="xy"):
        return self.velocityBC(label, points, region, demRegion, components, (0, 0, 0))

    # --- engines and time step --------------------------------------------------------------
    def engines(self):
        """DEM engines (force reset, collider, interactions, control, integrator), then the MPM
        solver and its EigenErosion engine."""
        return self.dem.engines() + [self.mpm, self.erosion]

    def criticalTimeSteps(self):
        """(DEM, MPM) critical time steps, s: PWaveTimeStep() and MpmEngine.criticalTimeStep()."""
        return self.dem.criticalTimeStep(), self.mpm.criticalTimeStep()

    def setTimeStep(self, fraction=0.8):
        """O.dt = fraction x the smaller critical step; returns it."""
        from yade import O
        if not 0 < fraction <= 1:
            raise ValueError(f"EigenMPM: fraction = {fraction!r} is invalid; allowed: 0 < fraction <= 1")
        O.dt = fraction * min(self.criticalTimeSteps())
        return O.dt

    # --- records ----------------------------------------------------------------------------
    def record(self):
        """Appends (t, MPM displacement, MPM reaction, DEM displacement, DEM reaction) of every
        condition (vectors, m and N; DEM force scaled to the thickness) to self.curves[label]."""
        from yade import O
        if self._t0 is None:
            self._t0 = time.time()
        for label, p in self.pairs.items():
            self.curves[label].append((O.time, p.mpmDisplacement(), np.asarray(list(p.mpm.reaction), float),
                                       p.dem.displacement(), np.asarray(list(p.dem.reaction), float)))

    def curve(self, label, component=1):
        """Arrays (t, u_mpm, F_mpm, u_dem, F_dem) of one component of a condition's record."""
        c = self.curves[label]
        if not c:
            return tuple(np.zeros(0) for _ in range(5))
        t = np.array([r[0] for r in c])
        return (t,) + tuple(np.array([r[k][component] for r in c]) for k in range(1, 5))

    def wallTimes(self):
        """Seconds spent in the engines of each model (YADE's engine timing, O.timingEnabled),
        and per engine label under 'engine_wall_s'."""
        dem = sum(e.execTime for e in self._demEngineObjects()) * 1e-9
        mpm = (self.mpm.execTime + self.erosion.execTime) * 1e-9
        from yade import O
        each = {e.label or type(e).__name__: e.execTime * 1e-9 for e in O.engines}
        return dict(dem_wall_s=dem, mpm_wall_s=mpm, engine_wall_s=each)

    def _demEngineObjects(self):
        from yade import O
        mine = {f"{self.dem.tag}_{n}" for n in ("forces", "collider", "interactions", "control", "newton")}
        return [e for e in O.engines if e.label in mine]

    def summary(self, load=None, component=1, smooth=0.01):
        """Scalars for summary.json: both models' peak load (N, the given condition's reaction
        component), particles, dissipated energies (J), broken bonds and eroded points, wall times,
        time steps, the calibration and the thickness scale of the DEM. Peak loads are those of
        the reaction averaged over a window of `smooth` x the record (both models carry the
        oscillations of explicit dynamics); *_raw the largest recorded."""
        from yade import O
        out = dict(dem_model=self.model, dem_spheres=len(self.dem.ids), dem_layers=self.layers,
                   dem_radius_m=self.dem.radius, dem_force_scale=self.dem.scale,
                   mpm_points=int(self.mpm.solver.numPoints), mpm_h_m=self.mpm.h, dt_s=O.dt,
                   steps=O.iter)
        crit = self.criticalTimeSteps()
        out.update(dem_critical_dt_s=crit[0], mpm_critical_dt_s=crit[1])
        _, nb, nbonds, ed = self.dem.bondState()
        out.update(dem_bonds=nbonds, dem_broken_bonds=nb, dem_dissipated_energy_J=ed)
        es = self.erosion.summary()
        out.update(mpm_eroded=es["eroded_count"], mpm_dissipated_energy_J=es["dissipated_energy_J"])
        out.update(self.wallTimes())
        if load is not None:
            t, um, Fm, ud, Fd = self.curve(load, component)
            if len(t):
                for name, u, F in (("mpm", um, Fm), ("dem", ud, Fd)):
                    Fs = smoothed(np.abs(F), smooth)
                    i = int(np.argmax(Fs))
                    out.update({f"{name}_peak_load_N": float(Fs[i]), f"{name}_displacement_at_peak_m": float(abs(u[i])),
                                f"{name}_peak_load_raw_N": float(np.max(np.abs(F))),
                                f"{name}_end_displacement_m": float(u[-1])})
        out["calibration"] = self.calibration
        return out


def smoothed(F, fraction=0.01):
    """Moving average over a window of `fraction` of the samples (at least 1)."""
    F = np.asarray(F, float)
    k = max(1, int(round(fraction * len(F))))
    return np.convolve(F, np.ones(k) / k, mode="same") if len(F) else F


def _distanceToPolyline(p, v, caps=True):
    """Distance from p to the polyline v; without caps only where p projects inside a segment
    (elsewhere infinite)."""
    best = math.inf
    for a, b in zip(v[:-1], v[1:]):
        ab = b - a
        t = 0.0 if not ab.any() else float(np.dot(p - a, ab) / np.dot(ab, ab))
        if not caps and not 0.0 <= t <= 1.0:
            continue
        t = min(1.0, max(0.0, t))
        best = min(best, float(np.linalg.norm(p - (a + t * ab))))
    return best


# --- uniaxial tension test of the DEM -----------------------------------------------------------
def uniaxialTension(calibration, rho, layers=3, length=None, width=None, direction="x", strainRate=None,
                    endStrain=None, damping=0.4, dtFraction=0.8, stopBelow=0.5):
    """Runs a quasi-static uniaxial tension test of the DEM with the given calibration (a dict
    of :func:`calibrate`) on a prism of `layers` hcp layers (the slab of the specimen),
    length x width in plane (default 24 r x 12 r), pulled along `direction` ('x': along the
    close-packed rows, or 'y') by the velocity of its two end columns (one sphere thick, only
    the pulled component blocked), with damping (YADE's local damping) for a quasi-static
    response. The scene is reset first. Stress = reaction / (width x represented thickness),
    strain = change of the distance of the end columns / their initial distance.

    Returns a dict: E (secant modulus up to 40 % of the peak, Pa), nu (in-plane, from the
    lateral contraction of the middle third, at 40 % of the peak), ft (peak stress, Pa),
    strainAtPeak, Gf (dissipated energy / cross-section at the end, J/m2, when the specimen is
    cut through), spheres, steps, wall_s, and the curve (strain, stress). The run stops at
    endStrain or, past the peak, once the stress is below stopBelow x peak (None: at endStrain)."""
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

    from .engines import callEvery
    O.engines = O.engines + [callEvery(sample, iterPeriod=every)]
    start, cpu = time.time(), time.process_time()
    O.run(steps, True)
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


# --- outputs of the comparison examples ---------------------------------------------------------
def runToDisplacement(pair, out, load, displacement, velocity, rampTime=0.0, dtFraction=0.8, title="",
                      extra=None, cpu0=None, sign=1.0, band=None, component=1, records=1000):
    """Runs the pair until the load point has moved by `displacement` (m) under `velocity`
    (m/s) reached over the ramp `rampTime` (s) (paper Eq 34), with O.dt = dtFraction x the smaller
    critical step, recording both models about `records` times and reporting progress; a run the
    solver stops with an error keeps what it computed (eigenmpm.cli.runSteps). Then report() and
    a print of the main numbers: returns the summary, with `cpu_time_s` since `cpu0`
    (time.process_time()) when given."""
    from yade import O
    from .cli import runSteps
    from .engines import callEvery
    from .recorders import Progress
    dt = pair.setTimeStep(dtFraction)
    u, v, t0 = displacement, velocity, rampTime
    endTime = u / v + 0.5 * t0 if u / v > 0.5 * t0 else (2 * u * t0 / v) ** 0.5
    steps = int(round(endTime / dt))
    O.engines = pair.engines() + [callEvery(pair.record, iterPeriod=max(1, steps // records), label="record"),
                                  Progress(endIter=steps, realPeriod=30)]
    dtDem, dtMpm = pair.criticalTimeSteps()
    print(f"MPM {pair.mpm.solver.numPoints} points, DEM {len(pair.dem.ids)} spheres ({pair.layers} layers), "
          f"dt {dt:.3g} s (critical DEM {dtDem:.3g}, MPM {dtMpm:.3g}), {steps} steps", flush=True)
    start = time.time()
    stopped = runSteps(steps)
    wall = time.time() - start
    info = dict(extra or {}, stopped_early=stopped, imposed_displacement_m=u)
    summary = report(pair, out, load, component=component, title=title, wall=wall, sign=sign, band=band,
                     extra=info, cpu=None if cpu0 is None else time.process_time() - cpu0)
    import json
    keys = ("mpm_peak_load_N", "dem_peak_load_N", "mpm_displacement_at_peak_m", "dem_displacement_at_peak_m",
            "mpm_dissipated_energy_J", "dem_dissipated_energy_J", "mpm_eroded", "dem_broken_bonds",
            "mpm_wall_s", "dem_wall_s", "particles", "steps", "wall_time_s", "cpu_time_s")
    print(json.dumps({k: summary.get(k) for k in keys}, indent=2, default=float))
    print("outputs in", out)
    return summary


def report(pair, out, load, component=1, title="", extra=None, wall=None, cpu=None, sign=1.0, band=None):
    """Writes DIR/summary.json (pair.summary plus particles, steps, wall_time_s,
    particle_steps_per_s overall and per model, `extra`), DIR/load_displacement.csv and .png
    (both models' reaction of condition `load` against their load-point displacement, in kN and
    mm, times `sign`) and DIR/crack_patterns.png (MPM eroded points, DEM broken bonds, side by
    side). Returns the summary."""
    import json
    import os
    from yade import O
    os.makedirs(out, exist_ok=True)
    s = pair.summary(load, component)
    steps = O.iter
    s.update(particles=s["mpm_points"] + s["dem_spheres"], steps=steps)
    if wall is not None:
        s["wall_time_s"] = wall
        s["particle_steps_per_s"] = s["particles"] * steps / wall if wall > 0 else None
    if cpu is not None:
        s["cpu_time_s"] = cpu
    for name, n in (("mpm", s["mpm_points"]), ("dem", s["dem_spheres"])):
        w = s[f"{name}_wall_s"]
        s[f"{name}_particle_steps_per_s"] = n * steps / w if w > 0 else None
    s.update(extra or {})
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(s, f, indent=2, default=float)
    t, um, Fm, ud, Fd = pair.curve(load, component)
    with open(os.path.join(out, "load_displacement.csv"), "w") as f:
        f.write("t_s,mpm_displacement_mm,mpm_load_kN,dem_displacement_mm,dem_load_kN\n")
        for row in zip(t, um * 1e3 * sign, Fm * 1e-3 * sign, ud * 1e3 * sign, Fd * 1e-3 * sign):
            f.write(",".join(f"{v:.6g}" for v in row) + "\n")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if band is not None:
        ax.fill_between(band[1], band[2], band[3], color="orange", alpha=0.4, label=band[0])
    for name, u, F, c in (("EigenMPM", um, Fm, "b"), (f"DEM ({pair.model.upper()})", ud, Fd, "r")):
        ax.plot(sign * u * 1e3, sign * F * 1e-3, color=c, lw=0.4, alpha=0.35)
        ax.plot(sign * u * 1e3, sign * smoothed(F) * 1e-3, color=c, lw=1.4, label=f"{name} (smoothed)")
    ax.set_xlabel("load-point displacement (mm)")
    ax.set_ylabel(f"load (kN, thickness {pair.constants['thickness'] * 1e3:g} mm)")
    ax.set_title(title or "load-displacement")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, "load_displacement.png"), dpi=110)
    plt.close(fig)
    crackPatterns(pair, os.path.join(out, "crack_patterns.png"), title)
    return s


def crackPatterns(pair, path, title=""):
    """The MPM points (eroded red) and the DEM spheres projected on x-y (bonds broken red, at
    their midpoints), both in specimen coordinates, side by side."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x = pair.mpm.solver.positions() * 1e3
    er = pair.mpm.solver.damage() <= 0
    c, _ = pair.dem.centres()
    c = (c - pair.dem.offset) * 1e3
    b, nb, nbonds, _ = pair.dem.bondState()
    b = (b - pair.dem.offset) * 1e3 if len(b) else b
    lo = np.minimum(x.min(axis=0), c.min(axis=0))
    hi = np.maximum(x.max(axis=0), c.max(axis=0))
    span = hi - lo
    fig, axes = plt.subplots(1, 2, figsize=(11, max(2.5, min(6.0, 5.5 * span[1] / span[0] + 0.8))))
    size = max(0.2, 4e3 / max(len(x), 1))
    axes[0].scatter(x[~er, 0], x[~er, 1], s=size, c="0.75", marker="s", linewidths=0)
    axes[0].scatter(x[er, 0], x[er, 1], s=max(6.0, 3 * size), c="#d62728", marker="s", linewidths=0)
    for k in range(pair.mpm.solver.numCracks):
        v = np.array([list(p) for p in pair.mpm.solver.crackVertices(k)]) * 1e3
        axes[0].plot(v[:, 0], v[:, 1], "k-", lw=1)
    axes[0].set_title(f"EigenMPM: {int(er.sum())} of {len(x)} points eroded", fontsize=9)
    size = max(0.2, 4e3 / max(len(c), 1))
    axes[1].scatter(c[:, 0], c[:, 1], s=size, c="0.75", linewidths=0)
    if len(b):
        axes[1].scatter(b[:, 0], b[:, 1], s=max(6.0, 3 * size), c="#d62728", linewidths=0)
    axes[1].set_title(f"DEM ({pair.model.upper()}): {nb} of {nbonds} bonds broken", fontsize=9)
    for ax in axes:
        ax.set_xlim(lo[0] - 5, hi[0] + 5)
        ax.set_ylim(lo[1] - 5, hi[1] + 5)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
    axes[0].set_ylabel("y (mm)")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
