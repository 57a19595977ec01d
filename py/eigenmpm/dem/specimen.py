"""The DEM specimen, its velocity conditions and its bonds.

The DEM specimen is a slab of spheres of radius r on a hexagonal close-packed (hcp) lattice
with the stacking axis along z, so that its in-plane elastic response is isotropic; it lies
``offset`` away from the MPM specimen (beside it in x by default), so the two never touch (they
could not interact anyway: MPM points are not YADE bodies). Each sphere represents the volume
of its lattice cell, 2r x sqrt(3) r x 2 sqrt(6)/3 r = (4/3 pi r^3) / phi with phi = pi/(3 sqrt 2),
and gets the density rho / phi, so the DEM slab has the continuum's mass. A slab of n layers
represents the thickness n 2 sqrt(6)/3 r; DEM forces and energies are scaled by
thickness / (that thickness) so that both models report them for the MPM's thickness.
"""
import math

import numpy as np

from .. import builders
from ..params import Param
from ..ramp import rampFactor

MODELS = ("cpm", "jcfpm")  # YADE's CpmMat / JCFpmMat bonds, the laws the specimen is made of
HCP_FRACTION = math.pi / (3.0 * math.sqrt(2.0))  # solid fraction of hcp (and fcc)
HCP_CONTACTS = 12
LAYER = 2.0 * math.sqrt(6.0) / 3.0  # hcp layer spacing / r


def _isCalibration(c):
    return isinstance(c, dict) and c.get("model") in MODELS and "material" in c and "radius" in c


# Parameters of a DEM specimen, shared by the pair, the calibration and the laboratory tests.
MODEL = Param("model", "cpm", "", "DEM bond law: 'cpm' (YADE's concrete particle model, exponential "
                                  "softening) or 'jcfpm' (JCFpm, brittle bonds)", choices=MODELS)
RADIUS = Param("radius", None, "m", "radius r of the DEM spheres", kind="float", bounds="(0, inf)", required=True)
CALIBRATION = Param("calibration", None, "", "DEM micro-parameters: a dict returned by calibrateDem "
                                             "(eigenmpm.dem.calibrate) or calibrateMeasured",
                    kind="object", accepts="a dict of calibrateDem or calibrateMeasured",
                    check=_isCalibration, required=True)
LAYERS = Param("layers", None, "", "hcp layers of the DEM slab; default: the number whose represented "
                                   "thickness (layers x 2 sqrt(6)/3 r) is nearest to the thickness (layersFor)",
               kind="int", bounds="[1, inf)")
DAMPING = Param("damping", 0.0, "", "YADE's local damping of the DEM (NewtonIntegrator.damping); 0 for "
                                    "dynamics like the MPM's", bounds="[0, 1)")
DT_FRACTION = Param("dtFraction", 0.8, "", "O.dt as a fraction of the smallest critical time step",
                    bounds="(0, 1]")


def hcpCenters(predicate, radius, layers):
    """Centres (n x 3, m) of a slab of `layers` hcp layers of spheres of radius `radius` whose
    in-plane lattice cells (2r x sqrt(3) r) have their centre inside the predicate (evaluated in
    the plane z = middle of its z-range, like MpmEngine.fill); the slab is centred on z = 0."""
    if layers < 1:
        raise ValueError(f"EigenMPM: layers = {layers!r} is invalid; allowed: layers >= 1")
    lo, hi = predicate.aabb()
    if not all(math.isfinite(lo[i]) and math.isfinite(hi[i]) for i in (0, 1)):
        raise ValueError("EigenMPM: the predicate's bounding box is unbounded in x or y; intersect it with a box")
    zp = builders.zPlane(predicate)
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
        """Prescribed velocity at time t: velocity(t), or the vector times the ramp of paper Eq 34
        (the same as MpmEngine.velocityBC's rampTime)."""
        if callable(self.velocity):
            return np.asarray(list(self.velocity(t)), float)
        return rampFactor(t, self.rampTime) * np.asarray(list(self.velocity), float)

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
        predicate in specimen coordinates, evaluated in its own middle z-plane) with ``pad``: the
        selection of MpmEngine.pointsIn in 2D."""
        x, ids = self.centres()
        return [ids[i] for i in builders.select(x - self.offset, region, pad, 2)]

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
        from ..engines import callEvery
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
