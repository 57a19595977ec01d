"""One specimen modelled twice in one YADE scene: a plane-stress EigenMPM body and a DEM slab,
with the same conditions, one O.dt and records of both; and the run of the comparison examples."""
import math
import time

import numpy as np

from ..engines import MpmEngine
from ..fracture import EigenErosion
from ..materials import ElasticMaterial
from ..params import Param, arguments, declare, declared, takes
from ..ramp import rampTimeTo
from . import reports
from .calibration import DENSITY, GC, POISSON, STRENGTH, YOUNG, calibrate
from .reports import BAND, COMPONENT, EXTRA, LOAD, OUT, PAIR, SIGN, SMOOTH, TITLE
from .specimen import CALIBRATION, DAMPING, DT_FRACTION, LAYERS, MODEL, RADIUS, DemSpecimen, layersFor


class _Pair:
    """A pair of conditions, MPM and DEM, under one label."""

    def __init__(self, label, mpm, dem, mpmIds, mpmEngine):
        self.label, self.mpm, self.dem, self._ids, self._engine = label, mpm, dem, mpmIds, mpmEngine
        self._x0 = mpmEngine.solver.positions()[mpmIds].copy() if len(mpmIds) else None

    def mpmDisplacement(self):
        if self._x0 is None:
            return np.zeros(3)
        return np.mean(self._engine.solver.positions()[self._ids] - self._x0, axis=0)


def _isPredicate(region):
    return callable(region) or hasattr(region, "aabb")


# The arguments of a pair of conditions: the MPM side as MpmEngine.velocityBC, the DEM side.
_LABEL = Param("label", None, "", "name of the condition in both models (pairs, curves, summary)", kind="str",
               required=True)
_DEM_REGION = Param("demRegion", None, "", "the DEM spheres whose centre lies in this predicate (specimen "
                                           "coordinates); default: `points` or `region` enlarged by r",
                    kind="object", accepts="a yade.pack predicate or a callable pred(x, pad)", check=_isPredicate)
_BC = MpmEngine.velocityBC


@declare
class DemMpmPair:
    """One specimen modelled twice in one YADE scene, by EigenMPM and by YADE's discrete elements.
    The specimen (a yade.pack predicate, 2D in x-y) is a plane-stress EigenMPM body of
    thickness t (MpmEngine.fill + EigenErosion) and a DEM slab (see eigenmpm.dem.specimen), the DEM
    placed `offset` away (default: beside the MPM specimen in +x, a gap of a quarter of its
    width). Give the calibration (a dict of calibrateDem or calibrateMeasured) or let it be made
    by calibrateDem's rule. Boundary conditions go on both through :meth:`velocityBC` /
    :meth:`fix`; :meth:`engines` returns the engines of both; :meth:`setTimeStep` sets one O.dt
    below both critical steps.

    Example::

        pair = em.DemMpmPair(pack.inAlignedBox((0, 0, 0), (0.45, 0.1, 0)), E=30e9, nu=0.2, rho=2400,
                             Gc=100, ft=3e6, h=0.01, radius=0.005, thickness=0.05)
        pair.notch([(0.225, -0.005, 0), (0.225, 0.05, 0)])
        pair.fix('left', points=pack.inAlignedBox((-1, -1, -1), (0.01, 0.005, 1)), components='y')
        pair.velocityBC('load', points=pack.inAlignedBox((0.22, 0.095, -1), (0.23, 1, 1)),
                        components='y', velocity=(0, -0.02, 0), rampTime=1e-3)
        O.engines = pair.engines() + [em.callEvery(pair.record, iterPeriod=10)]
        pair.setTimeStep(0.8)
        O.run(5000, True)
        pair.summary('load')
    """

    positional = 1  # the specimen may be given first, without its keyword
    params = (
        Param("predicate", None, "", "the specimen: a yade.pack predicate in the x-y plane, bounded in x and y",
              kind="object", accepts="a yade.pack predicate", check=lambda p: hasattr(p, "aabb"), required=True),
        YOUNG, POISSON, DENSITY, GC, STRENGTH,
        declared(MpmEngine, "h"),
        RADIUS,
        declared(MpmEngine, "thickness"),
        MODEL,
        CALIBRATION.replace(required=False, doc="DEM micro-parameters (a dict of calibrateDem or "
                                                "calibrateMeasured, for `model`); default: calibrateDem's rule"),
        LAYERS,
        Param("offset", None, "m", "position of the DEM slab relative to the MPM specimen; default: beside it "
                                   "in +x, a gap of max(w / 4, 4 r + 2 h) for the specimen width w",
              kind="vector"),
        declared(MpmEngine, "ppc"),
        declared(EigenErosion, "alpha"),
        declared(EigenErosion, "kappaOverH").replace(default=1.1),
        DAMPING,
        declared(EigenErosion, "iterPeriod").replace(name="erosionPeriod"),
        declared(MpmEngine, "label").replace(doc="YADE label of the MpmEngine; it prefixes the keys of its "
                                                 "plotData()"),
    )

    def __init__(self, *args, **kw):
        from yade import O
        a = arguments(self.params, args, kw, "DemMpmPair", positional=self.positional)
        self.model = a["model"]
        E, nu, rho, Gc, ft, h, radius, thickness = (a[k] for k in ("E", "nu", "rho", "Gc", "ft", "h", "radius",
                                                                   "thickness"))
        self.constants = dict(E=E, nu=nu, rho=rho, Gc=Gc, ft=ft, thickness=thickness, h=h, radius=radius)
        self.calibration = a["calibration"] or calibrate(self.model, E, nu, ft, Gc, radius)
        if self.calibration["model"] != self.model:
            raise ValueError(f"EigenMPM: the calibration is for DEM model {self.calibration['model']!r}, "
                             f"not model = {self.model!r} (DemMpmPair)")
        self.mpm = MpmEngine(dim=2, h=h, ppc=a["ppc"], thickness=thickness, label=a["label"])
        self.mpm.fill(a["predicate"], ElasticMaterial(E=E, nu=nu, rho=rho, planeStress=True))
        self.erosion = EigenErosion(engine=self.mpm, Gc=Gc, alpha=a["alpha"], kappaOverH=a["kappaOverH"],
                                    iterPeriod=a["erosionPeriod"])
        lo, hi = a["predicate"].aabb()
        offset = a["offset"]
        if offset is None:
            w = hi[0] - lo[0]
            offset = (w + max(0.25 * w, 4 * radius + 2 * h), 0.0, 0.0)
        self.layers = a["layers"] or layersFor(thickness, radius)
        self.dem = DemSpecimen(a["predicate"], self.calibration, rho, radius, self.layers, thickness, offset,
                               damping=a["damping"])
        self.pairs = {}
        self.curves = {}
        self._t0 = None
        O.timingEnabled = True

    # --- specimen and conditions ------------------------------------------------------------
    @takes(Param("vertices", None, "m", "the notch's polyline (2 or more points), specimen coordinates",
                 kind="points", required=True),
           Param("width", None, "m", "width of the DEM notch; default 2.02 r (it cuts every bond across it)",
                 kind="float", bounds="(0, inf)"))
    def notch(self, vertices, width):
        """A notch along the polyline `vertices` (specimen coordinates): in the MPM a phantom-node
        crack (MpmEngine.crack), in the DEM the spheres whose centre lies within width/2 (default
        1.01 r, which cuts the bonds across it) of the polyline, measured normal to a segment
        (no round caps at the ends), are removed: a notch 2 to 4 r wide that ends within r of
        the last vertex. Returns the ids of the removed spheres."""
        self.mpm.crack(vertices)
        half = 0.5 * width if width else 1.01 * self.dem.radius
        x, ids = self.dem.centres()
        v = np.array([list(p) for p in vertices], float)[:, :2] + self.dem.offset[:2]
        gone = [i for i, p in zip(ids, x) if _distanceToPolyline(p[:2], v, caps=False) < half]
        self.dem.remove(gone)
        return gone

    @takes(_LABEL, declared(_BC, "points"), declared(_BC, "region"), _DEM_REGION, declared(_BC, "components"),
           declared(_BC, "velocity"), declared(_BC, "rampTime"))
    def velocityBC(self, label, points, region, demRegion, components, velocity, rampTime):
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
        d = self.dem.velocityBC(label, ids, components or "xy", velocity, rampTime)
        pair = _Pair(label, m, d, mpmIds, self.mpm)
        self.pairs[label] = pair
        self.curves[label] = []
        return pair

    @takes(_LABEL, declared(_BC, "points"), declared(_BC, "region"), _DEM_REGION, declared(_BC, "components"))
    def fix(self, label, points, region, demRegion, components):
        """Zero velocity on both models (see :meth:`velocityBC`): a support (all components) or a
        roller (one). Returns the pair (.mpm, .dem)."""
        return self.velocityBC(label, points, region, demRegion, components, (0.0, 0.0, 0.0), 0.0)

    # --- engines and time step --------------------------------------------------------------
    def engines(self):
        """DEM engines (force reset, collider, interactions, control, integrator), then the MPM
        solver and its EigenErosion engine."""
        return self.dem.engines() + [self.mpm, self.erosion]

    def criticalTimeSteps(self):
        """(DEM, MPM) critical time steps, s: PWaveTimeStep() and MpmEngine.criticalTimeStep()."""
        return self.dem.criticalTimeStep(), self.mpm.criticalTimeStep()

    @takes(DT_FRACTION.replace(name="fraction"))
    def setTimeStep(self, fraction):
        """O.dt = fraction x the smaller critical step; returns it."""
        from yade import O
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

    @takes(_LABEL.replace(doc="name of the condition"), COMPONENT)
    def curve(self, label, component):
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

    @takes(LOAD.replace(default=None, required=False, doc="the loading condition (its label), whose reaction "
                                                          "component gives the peak loads; default: none"),
           COMPONENT, SMOOTH)
    def summary(self, load, component, smooth):
        """Scalars for summary.json (see ``eigenmpm.dem.reports.summary``): both models' peak load,
        particles, dissipated energies, broken bonds and eroded points, wall times, time steps and
        the calibration."""
        return reports.summary(self, load, component, smooth)


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


@takes(PAIR.replace(doc="the pair to run, its conditions set"), OUT, LOAD,
       Param("displacement", None, "m", "distance the load point moves", kind="float", bounds="(0, inf)",
             required=True),
       Param("velocity", None, "m/s", "speed of the load point after the ramp", kind="float", bounds="(0, inf)",
             required=True),
       declared(_BC, "rampTime"), DT_FRACTION, TITLE, EXTRA,
       Param("cpu0", None, "s", "time.process_time() at the start of the script, for cpu_time_s", kind="float",
             bounds="[0, inf)"),
       SIGN, BAND, COMPONENT,
       Param("records", 1000, "", "about how many times both models are recorded", bounds="[1, inf)"),
       Param("checkpoints", None, "", "folder of the checkpoints (eigenmpm.Checkpoint, doc/restart.md); "
                                      "default: none are saved", kind="str"),
       Param("checkpointEvery", 0, "iterations", "period of the checkpoints; 0: none", bounds="[0, inf)"),
       Param("resumed", False, "", "the pair and its scene come from resumePair(): continue its run "
                                   "(the engines and O.dt as checkpointed)"))
def runToDisplacement(pair, out, load, displacement, velocity, rampTime, dtFraction, title, extra, cpu0, sign,
                      band, component, records, checkpoints, checkpointEvery, resumed):
    """Runs the pair until the load point has moved by `displacement` (m) under `velocity`
    (m/s) reached over the ramp `rampTime` (s) (paper Eq 34), with O.dt = dtFraction x the smaller
    critical step, recording both models about `records` times and reporting progress; a run the
    solver stops with an error, or that SIGINT/SIGTERM interrupts, keeps what it computed
    (eigenmpm.cli.runSteps). With checkpointEvery > 0 a Checkpoint engine, first in O.engines,
    saves the scene into `checkpoints`; with resumed, the run of a pair from resumePair()
    continues to the same end. Then report() and a print of the main numbers: returns the summary,
    with `cpu_time_s` since `cpu0` (time.process_time()) when given, and the run's
    eigenmpm.cli.RunEnd (for eigenmpm.cli.finish)."""
    from yade import O
    from ..checkpoint import Checkpoint
    from ..cli import runSteps
    from ..engines import callEvery
    from ..recorders import Progress
    dt = O.dt if resumed else pair.setTimeStep(dtFraction)
    steps = int(round(rampTimeTo(displacement, velocity, rampTime) / dt))
    if not resumed:
        O.engines = pair.engines() + [callEvery(pair.record, iterPeriod=max(1, steps // records), label="record"),
                                      Progress(endIter=steps, realPeriod=30)]
        if checkpointEvery:
            O.engines = [Checkpoint(directory=checkpoints, iterPeriod=checkpointEvery)] + list(O.engines)
    dtDem, dtMpm = pair.criticalTimeSteps()
    print(f"MPM {pair.mpm.solver.numPoints} points, DEM {len(pair.dem.ids)} spheres ({pair.layers} layers), "
          f"dt {dt:.3g} s (critical DEM {dtDem:.3g}, MPM {dtMpm:.3g}), {steps} steps from iteration {O.iter}",
          flush=True)
    start = time.time()
    end = runSteps(steps - O.iter)
    wall = time.time() - start
    info = dict(extra or {}, **end.summary(), imposed_displacement_m=displacement)
    summary = reports.report(pair, out, load, component=component, title=title, wall=wall, sign=sign, band=band,
                             extra=info, cpu=None if cpu0 is None else time.process_time() - cpu0)
    import json
    keys = ("mpm_peak_load_N", "dem_peak_load_N", "mpm_displacement_at_peak_m", "dem_displacement_at_peak_m",
            "mpm_dissipated_energy_J", "dem_dissipated_energy_J", "mpm_eroded", "dem_broken_bonds",
            "mpm_wall_s", "dem_wall_s", "particles", "steps", "wall_time_s", "cpu_time_s")
    print(json.dumps({k: summary.get(k) for k in keys}, indent=2, default=float))
    print("outputs in", out)
    return summary, end


def resumePair(directory):
    """The DemMpmPair of the newest checkpoint in `directory` (runToDisplacement's run), its scene
    loaded (doc/restart.md): the owner of the `record` runner, restored with both models' records.
    The checkpoint keeps copies of the DEM specimen's YADE engines and functors with it; they are
    pointed back at the loaded scene's (JCFpm's crack energies are read from its law)."""
    from yade import O
    from ..checkpoint import resume
    resume(directory)
    (pair,) = [e.function.__self__ for e in O.engines if e.label == "record"]
    d, engines = pair.dem, {e.label: e for e in O.engines}
    d.engineList = [engines[f"{d.tag}_{n}"] for n in ("forces", "collider", "interactions", "newton")]
    d.bo1 = engines[f"{d.tag}_collider"].boundDispatcher.functors[0]
    loop = engines[f"{d.tag}_interactions"]
    d.ig2, d.law = loop.geomDispatcher.functors[0], loop.lawDispatcher.functors[0]
    O.timingEnabled = True  # the engine times of the summary
    return pair
