"""John-Shah three-point bending of a concrete beam with an offset notch (paper Section 5.4).

Beam depth D = 76.2 mm, span L = 228.6 mm, l1 = 101.6 mm, a notch a = 19.05 mm deep at the
offset l2 = gamma l1 from midspan, a small 1.27 mm flaw at the bottom of the midspan. Concrete:
E = 31.37 GPa, nu = 0.2, rho = 2400 kg/m3, Gc = 31.1 N/m. The top midspan point is driven
down by the ramp of paper Eq 35 (v0 = 0.06 m/s, t0 = 196 us). Eigenerosion with alpha = 2,
kappa = 1.15 h. Paper: h = 0.635 mm, dt = 0.1 us; the crack starts at the notch for small gamma
and at the midspan for large gamma, the transition lying between gamma = 0.738 and 0.744
(experiment: 0.77).

Modelling choices (parameters in brackets):

- Coordinates: midspan at x = 0, bottom at y = 0. The beam runs from -(L/2 + overhang) to
  L/2 + overhang [overhang_mm = 12.7]: 254 mm in all, the length of John and Shah's specimen.
  The supports are at x = -+L/2 = -+114.3 mm; since l1 = 101.6 mm < L/2, the notch at
  x = +gamma l1 lies between the midspan and the right support for 0 <= gamma <= 1.
- Plane stress with thickness h (the paper's unit thickness h); forces scale with it.
- The notch and the flaw are sharp phantom-node cracks (paper Section 3.3.1), vertical, from
  y = -h (just outside the bottom edge) to y = a and to y = 1.27 mm [flaw_mm]. Their x is moved
  to the nearest mid-line between two columns of points (x = 0 is one; gamma l1 is one for
  h = 0.635 k mm with 320 gamma / k an integer, e.g. gamma = 0.5, 0.75, 0.85 at the default
  and quick h; otherwise a shift below h/4).
- [notchWidth_mm = 0] A positive width replaces the sharp notch by an open one of that width
  (a sawn notch; the points within half of it from the notch line are left out), to see how the
  notch's sharpness moves the transition. [flawWidth_mm = 0] likewise for the midspan flaw.
- Supports: rollers, the velocity y = 0 on the grid nodes nearest to the bottom row of points
  within supportWidth_mm / 2 (2.54 mm, at least the two points next to x = -+L/2) of the
  support; load: the velocity (0, -v(t)) on the nodes nearest to the top row of points within
  loadWidth_mm / 2 (2.54 mm) of the midspan. At the quick h = 2.54 mm each is one node (the
  paper's point); at the default h = 0.635 mm five nodes over 2.54 mm. Reason (measured at
  h = 1.27 mm): on a single node the compressive stress concentrates as 1/h and, through the
  lateral tensile strain of the spectral split, erodes points at the supports before any crack
  starts (supports first at 1406-1577 us, gamma = 0.85 then gave no crack by 3000 us). The
  conditions are bilateral (the API has none that only pushes), so once the beam is broken the
  supports pull on it: the reactions after fracture are not physical.
- [loading = condition] loading=bodies replaces the three conditions by YADE bodies and
  `eigenmpm.BodyContact` (frictionless): two fixed spheres of radius supportRadius_mm (6.35 mm)
  under the beam at x = -+L/2, each just touching the nearest point of the bottom row (in 2D a
  disc: a roller across the thickness; with its top at y = 0 a support between two columns of
  points would leave a gap, 32 um at h = 2.54 mm, through which the beam falls first), and a
  hammer, a box loadWidth_mm wide and hammerHeight_mm (10 mm) high on the top edge at the
  midspan, not dynamic, moved down along Eq 35 by HammerDriver (its velocity in each step is
  the ramp's displacement over that step / dt, so it is where the ramp puts it at every step).
  Contacts only push: the beam may leave the hammer and the supports (unilateral), as it does
  once it is broken. Nothing holds the beam but the bodies (no gravity): it starts just
  touching them. The contact forces come in steps (each first touch of a node is an impulse),
  so the load record and the loads at initiation are their means over the last 10 us
  (LOAD_WINDOW); the summary adds each support's smallest force in any step (>= 0: never a
  pull), when each lifted off after the crack started (no force for 10 us), the hammer's
  smallest force, the raw peak, and the supports' force at initiation; DIR/load.csv (both
  modes) has the record. With the conditions the supports pull once the beam is broken
  (`support_sum_min_reaction_N` < 0). Measured (one thread): --quick gamma = 0.5 from the notch
  at 1324 us (conditions 1541 us), 0.85 from the midspan at 1804 us (2228 us), the transition
  between 0.7 and 0.75 (conditions 0.75-0.8); the default h, gamma = 0.5 from the notch at
  1408.5 us (1439 us; 641 s), 0.85 from the notch at 2497.4 us (2542 us; 732 s); the cracks
  start at the conditions' midspan stress, sooner because the beam is stiffer through contacts
  (doc/validation.md, "With the supports and the hammer as YADE bodies").
- Crack origin: the eroded points connected (within 2 kappa) to an eroded point within 4 h of
  the notch tip or of the flaw tip form the notch and the midspan cracks; `crack_origin` is the
  one whose first erosion came first ('notch' or 'midspan'; null when neither started) and
  `initiation_time_us` that time. In every run below this is also where the first eroded
  points lie (`first_erosion_mm`, `first_erosion_time_us`). Erosion elsewhere (under the load
  point and at the supports: a few points) is counted in `eroded_elsewhere` and would not
  decide the origin.
- The run ends at endTime_us (4000 us) or stopAfter_us (20 us) after a notch or midspan crack
  reaches 0.9 D, whichever comes first.

Run::

    yade -n -x examples/john_shah.py [--quick] [--out DIR] [param=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]
    yade-batch table.txt examples/john_shah.py      # e.g. a column gamma (and quick)

--checkpoint-every N saves the scene every N iterations into DIR/checkpoints (eigenmpm.Checkpoint,
doc/restart.md); --resume DIR/checkpoints continues from the newest of them (give the same
parameters) to the end state of the uninterrupted run, the load record and the stop after
0.9 D included, and writes the outputs as usual (wall_time_s then counts the resumed part only;
the VTK series continues in the first run's folder).

params: gamma, h_mm, kappaOverH, alpha, endTime_us, dt_us, v0_m_s, rampTime_us, overhang_mm,
flaw_mm, notchWidth_mm, flawWidth_mm, supportWidth_mm, loadWidth_mm, stopAfter_us, vtkPeriod_us, E, nu, rho, Gc,
transfer (the particle-grid transfer of MpmEngine: FLIP, the paper's and the default, or APIC) and
stressUpdate (smallStrain, the paper's and the default, or corotational; doc/stability.md),
loading (condition, the paper's and the default: velocity conditions on the grid; bodies: YADE
bodies with contact, see above; supportWidth_mm then unused), supportRadius_mm and
hammerHeight_mm (loading=bodies only; the hammer is loadWidth_mm wide), distributedSetup (default
1: under mpiexec each rank builds only its share of the points, doc/parallel.md "Memory"; 0: every
rank builds the whole scene first; the same results either way). Writes
DIR/summary.json (crack_origin, initiation_time_us, notch_/midspan_initiation_time_us and the load
and nominal midspan bending stress then (notch_/midspan_initiation_load_N, ..._midspan_stress_Pa), the
crack tops, eroded_elsewhere, peak_load_N, dissipated_energy_J, transfer, stress_update, particles,
steps, wall_time_s, particle_steps_per_s, support_sum_min_reaction_N, ...), DIR/damage.png,
DIR/load.png (load-point and support reactions), DIR/load.csv (the same record) and a VTK series
DIR/vtk/beam-*.vtp.

--quick: h = 2.54 mm (12 000 points), dt = 0.5 us (critical 0.69 us). Measured on one core:
gamma = 0.5: crack from the notch at 1541 us, 0.9 D reached and the run stopped at 1773 us
(3545 steps, 8 s of stepping, 10 to 12 s in all); gamma = 0.85: from the midspan at 2228 us,
stopped at 2361 us (4721 steps, 12 s, 15 s in all). Quick gamma sweep: 0.65 / 0.7 / 0.75
from the notch (1886 / 1979 / 2207 us), 0.8 from the midspan (2248 us): the transition lies
between 0.75 and 0.8 at this resolution. It depends on the resolution: at h_mm=1.27 dt_us=0.3
(48 000 points) gamma = 0.5 starts at the notch at 1462 us (44 s of stepping) but gamma = 0.85
too starts at the notch, at 2541 us (66 s), while G_p at the flaw tip had reached only about
0.9 Gc. The 1.27 mm flaw is half a cell at h = 2.54 mm and one cell at 1.27 mm, so its tip field
is not resolved and the eigenerosion threshold there depends on kappa = 1.15 h; the notch
(a = 7.5 h at 2.54 mm) is resolved at both. At h = 1.27 mm gamma = 0.9, 0.95 and 1.0 start at
the midspan (2658 / 2635 / 2618 us). The default (the paper's h = 0.635 mm, 192 000 points, one
thread): gamma = 0.5 from the notch at 1439 us (426 s), 0.85 from the notch at 2542 us (1022 s),
0.875 from the notch at 2716 us (678 s), 0.9 from the midspan at 2821 us with the notch
following at 2834 us (749 s), 0.95 from the midspan at 2820 us (the notch at 2932 us, 722 s):
the transition lies between 0.875 and 0.9 (doc/validation.md).
"""
import json
import math
import os
import sys
import time

import numpy as np
from yade import O, pack, plot, utils
from yade.wrapper import ForceResetter, FrictMat, NewtonIntegrator

import eigenmpm as em
from eigenmpm import plots
from eigenmpm.cli import checkpointArgs, finish, runSteps, scriptArgs
from eigenmpm.fracture import linked
from eigenmpm.ramp import rampDisplacement

DEFAULTS = dict(gamma=0.5, h_mm=0.635, kappaOverH=1.15, alpha=2.0, endTime_us=4000.0, dt_us=0.1,
                v0_m_s=0.06, rampTime_us=196.0, overhang_mm=12.7, flaw_mm=1.27, notchWidth_mm=0.0, flawWidth_mm=0.0,
                supportWidth_mm=2.54, loadWidth_mm=2.54, stopAfter_us=20.0,
                vtkPeriod_us=100.0, E=31.37e9, nu=0.2, rho=2400.0, Gc=31.1, transfer="FLIP",
                stressUpdate="smallStrain", loading="condition", supportRadius_mm=6.35, hammerHeight_mm=10.0,
                distributedSetup=True)
QUICK = dict(h_mm=2.54, dt_us=0.5)
LOADINGS = ("condition", "bodies")
D, L, L1, A = 0.0762, 0.2286, 0.1016, 0.01905


def geometry(o):
    """Beam ends, notch and flaw positions (m): the notch x = gamma l1 and the flaw x = 0 moved
    to the nearest mid-line between two columns of points."""
    h = o["h_mm"] * 1e-3
    s = h / 2
    half = 0.5 * L + o["overhang_mm"] * 1e-3
    xn = round(o["gamma"] * L1 / s) * s
    return h, s, half, xn


def build(o):
    h, s, half, xn = geometry(o)
    mpm = em.MpmEngine(dim=2, h=h, ppc=2, thickness=h, label="beam", transfer=o["transfer"],
                       stressUpdate=o["stressUpdate"], distributedSetup=o["distributedSetup"])
    concrete = em.ElasticMaterial(E=o["E"], nu=o["nu"], rho=o["rho"], planeStress=True)
    beam = pack.inAlignedBox((-half, 0, 0), (half, D, 0))
    w = 0.5e-3 * o["notchWidth_mm"]
    if w > 0:  # a sawn notch: no points within w/2 of the notch line, up to the notch depth
        beam = beam - pack.inAlignedBox((xn - w, -1, -1), (xn + w, A, 1))
    wf = 0.5e-3 * o["flawWidth_mm"]
    if wf > 0:  # an open flaw: no points within wf/2 of the midspan, up to the flaw depth
        beam = beam - pack.inAlignedBox((-wf, -1, -1), (wf, o["flaw_mm"] * 1e-3, 1))
    mpm.fill(beam, concrete)
    if w <= 0:
        mpm.crack([(xn, -h, 0), (xn, A, 0)])
    if wf <= 0:
        mpm.crack([(0, -h, 0), (0, o["flaw_mm"] * 1e-3, 0)])
    e = 1e-6 * h
    if o["loading"] == "bodies":
        load, supports = loadingBodies(o, mpm)
    else:
        ws = max(0.5 * o["supportWidth_mm"] * 1e-3, 0.5 * s) + e
        supports = [mpm.velocityBC(points=pack.inAlignedBox((x - ws, -1, -1), (x + ws, s, 1)),
                                   components="y", velocity=(0, 0, 0), label=name)
                    for x, name in ((-0.5 * L, "left"), (0.5 * L, "right"))]
        wl = max(0.5 * o["loadWidth_mm"] * 1e-3, 0.5 * s) + e
        load = mpm.velocityBC(points=pack.inAlignedBox((-wl, D - s, -1), (wl, 1, 1)), components="y",
                              velocity=(0, -o["v0_m_s"], 0), rampTime=o["rampTime_us"] * 1e-6, label="load")
    crack = em.EigenErosion(engine=mpm, Gc=o["Gc"], alpha=o["alpha"], kappaOverH=o["kappaOverH"],
                            iterPeriod=max(1, int(round(2.0 / o["dt_us"]))))
    return mpm, crack, load, supports


def loadingBodies(o, mpm):
    """The supports and the hammer as YADE bodies (loading=bodies). Supports: two fixed spheres
    of radius supportRadius_mm under the beam at x = -+L/2, each placed so that the nearest
    point of the bottom row lies exactly a half-width h/4 from it (in 2D a sphere centred in
    the plane z = 0 acts as a disc: a roller across the beam's thickness). Hammer: a box
    loadWidth_mm wide and hammerHeight_mm high, its lower face on the beam's top edge at the
    midspan (the top row of points h/4 below it), not dynamic: HammerDriver moves it down along
    paper Eq 35. So the beam touches the bodies from its first move. Returns (hammer id, [left
    support id, right support id])."""
    steel = O.materials.append(FrictMat(density=7800, young=2e11, poisson=0.3, frictionAngle=0, label="steel"))
    h = geometry(o)[0]
    r, w = o["supportRadius_mm"] * 1e-3, 0.25 * h  # w: the points' half-width, where they touch
    X = mpm.referenceOfPoints()  # this process's points (under mpiexec: its share)
    low = em.parallel.bounds(X[:, 1:2])[0][0]  # the bottom row's y over every rank
    bottom = X[X[:, 1] < low + 0.1 * h]
    supports = []
    for x in (-0.5 * L, 0.5 * L):
        # the sphere's surface exactly w from the nearest point of the bottom row (y = s/2): with
        # its top at y = 0 a support between two columns would leave a gap (32 um at h = 2.54 mm,
        # a third of the load point's travel when the notch cracks), which the beam falls through
        near = np.min(np.abs(bottom[:, 0] - x)) if len(bottom) else np.inf
        dx = em.parallel.bounds(np.array([[near]]))[0][0]
        y = low - math.sqrt((r + w) ** 2 - dx ** 2)
        supports.append(O.bodies.append(utils.sphere((x, y, 0), r, material=steel, fixed=True)))
    wl, hh = 0.5e-3 * o["loadWidth_mm"], 0.5e-3 * o["hammerHeight_mm"]
    hammer = O.bodies.append(utils.box((0, D + hh, 0), (wl, hh, 0.5 * wl + hh), material=steel, fixed=True))
    return hammer, supports


class HammerDriver:
    """Moves the hammer (a body that is not dynamic; a callEvery before the MpmEngine, every
    step) down along the ramp of paper Eq 35: in the step from t to t + dt its velocity is
    (u(t + dt) - u(t)) / dt, u the ramp's displacement, so that YADE's NewtonIntegrator puts it
    where the ramp is at every step, and the contact sees that velocity. A class at the top level
    so that a checkpoint saves it."""

    def __init__(self, o, hammer):
        self.v0, self.t0, self.hammer = o["v0_m_s"], o["rampTime_us"] * 1e-6, hammer

    def __call__(self):
        t, dt = O.time, O.dt
        v = (rampDisplacement(t + dt, self.v0, self.t0) - rampDisplacement(t, self.v0, self.t0)) / dt
        O.bodies[self.hammer].state.vel = (0, -v, 0)


def connected(x, seed, radius):
    """Indices of the rows of x (reference positions) connected to row `seed` within radius."""
    return np.nonzero(linked(x, seed, radius))[0]


def analyse(o, x0, events, kappa):
    """Where and when cracks started (x0: the reference positions of the events' points, a row
    each): the eroded points connected (within 2 kappa) to an eroded
    point within 4 h of the notch tip or of the flaw tip form the notch and midspan cracks; the
    crack that started first (its first erosion) gives crack_origin and initiation_time_us."""
    h, s, half, xn = geometry(o)
    tips = (("notch", np.array([xn, A])), ("midspan", np.array([0.0, o["flaw_mm"] * 1e-3])))
    res = dict(crack_origin=None, initiation_time_us=None, notch_initiation_time_us=None,
               midspan_initiation_time_us=None, notch_crack_points=0, midspan_crack_points=0,
               notch_crack_top_mm=None, midspan_crack_top_mm=None, crack_top_fraction=0.0,
               first_erosion_mm=None, first_erosion_time_us=None, eroded_elsewhere=0, notch_x_mm=1e3 * xn)
    if not events:
        return res
    ids = np.array([e[0] for e in events])
    t = np.array([e[2] for e in events])
    x = np.asarray(x0)[:, :2]
    first = t <= t[0] + 1e-12
    res.update(first_erosion_mm=(1e3 * x[first].mean(axis=0)).tolist(), first_erosion_time_us=1e6 * t[0])
    claimed = np.zeros(len(ids), bool)
    for name, tip in tips:
        d = np.linalg.norm(x - tip, axis=1)
        if d.min() > 4.0 * h:
            continue
        member = connected(x, int(np.argmin(d)), 2.0 * kappa)
        claimed[member] = True
        res[f"{name}_initiation_time_us"] = 1e6 * float(t[member].min())
        res[f"{name}_crack_points"] = int(len(member))
        top = member[np.argmax(x[member, 1])]
        res[f"{name}_crack_top_mm"] = (1e3 * x[top]).tolist()
        res["crack_top_fraction"] = max(res["crack_top_fraction"], float(x[top, 1] / D))
    res["eroded_elsewhere"] = int((~claimed).sum())
    started = [(res[f"{name}_initiation_time_us"], name) for name, _ in tips
               if res[f"{name}_initiation_time_us"] is not None]
    if started:
        res["initiation_time_us"], res["crack_origin"] = min(started)
    return res


class LoadWatch:
    """Records the load (a callEvery: `curve`, rows of time, load-point reaction, support
    reactions) and ends the run stopAfter_us after a crack reaches 90 % of the depth. A class at
    the top level, not a local function, so that a checkpoint saves it with its record and
    --resume continues it."""

    def __init__(self, o, mpm, crack, load, supports, contact=None):
        self.o = dict(o)
        self.mpm, self.crack, self.load, self.supports = mpm, crack, load, list(supports)
        self.contact = contact  # loading=bodies: load and supports are YADE body ids
        self.checkEvery = 1  # look for a crack at 0.9 D every this many calls
        self.curve = []
        self.at = None  # when a crack reached 0.9 D, s

    def reactions(self):
        """(load, left support, right support), N, positive in compression: the conditions'
        reactions, or the forces of the points on the bodies (loading=bodies)."""
        if self.contact is None:
            return -self.load.reaction[1], self.supports[0].reaction[1], self.supports[1].reaction[1]
        f = self.contact.force
        return float(f(self.load)[1]), -float(f(self.supports[0])[1]), -float(f(self.supports[1])[1])

    def __call__(self):
        o, mpm = self.o, self.mpm
        P, left, right = self.reactions()
        if self.contact is None:
            self.curve.append((mpm.solver.time, P, left + right))
        else:  # with each support's own force
            self.curve.append((mpm.solver.time, P, left + right, left, right))
        if self.at is None and self.crack.core.erodedCount and len(self.curve) % self.checkEvery == 0:
            ev = self.crack.core.events()
            kappa = o["kappaOverH"] * geometry(o)[0]
            x0 = mpm.referenceOf([e[0] for e in ev])  # (every rank calls it, as it must)
            if np.max(x0[:, 1]) >= 0.9 * D and analyse(o, x0, ev, kappa)["crack_top_fraction"] >= 0.9:
                self.at = mpm.solver.time
        if self.at is not None and o["stopAfter_us"] >= 0 and mpm.solver.time >= self.at + o["stopAfter_us"] * 1e-6:
            O.pause()


LOAD_WINDOW = 10e-6  # s: the mean of the contact forces (loading=bodies) over this window before each time


def windowMean(t, f, window):
    """The mean of each column of f over the rows with t in (t_i - window, t_i], for every row i
    (t ascending, one row per step)."""
    c = np.vstack([np.zeros((1, f.shape[1])), np.cumsum(f, axis=0)])
    j = np.searchsorted(t, t - window + 1e-12, side="left")
    i = np.arange(len(t)) + 1
    return (c[i] - c[j]) / (i - j)[:, None]


def supportSummary(raw, smooth, initiation_us):
    """loading=bodies: each support's smallest force in any step (N, positive in compression: a
    contact never pulls), the first time after the crack started at which a support had carried
    nothing for LOAD_WINDOW (it had lifted off the beam), the share of the time after that
    start without force over LOAD_WINDOW, and whether each carried force in the last
    LOAD_WINDOW."""
    t, res = smooth[:, 0], {}
    after = t >= (initiation_us or np.inf) * 1e-6
    for k, side in ((3, "left"), (4, "right")):
        f = smooth[:, k]
        free = after & (f <= 0)
        res[f"{side}_support_min_force_N"] = float(raw[:, k].min())
        res[f"{side}_support_lift_off_us"] = 1e6 * float(t[free][0]) if free.any() else None
        res[f"{side}_support_free_share_after_initiation"] = float(free.sum() / after.sum()) if after.any() else None
        res[f"{side}_support_in_contact_at_end"] = bool(f[-1] > 0)
    return res


def main(argv):
    argv, resume, every = checkpointArgs("john_shah", argv)
    o, out, quick = scriptArgs("john_shah", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    plot.reset()
    h, s, half, xn = geometry(o)
    kappa = o["kappaOverH"] * h
    steps = int(round(o["endTime_us"] / o["dt_us"]))
    if o["loading"] not in LOADINGS:
        raise SystemExit(f"john_shah: loading = {o['loading']!r} is invalid; allowed: {', '.join(LOADINGS)}")
    bodies = o["loading"] == "bodies"
    if resume:  # the scene, its engines and the load record as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm = em.findEngine("beam")
        (crack,) = [e for e in mpm.physics.values() if isinstance(e, em.EigenErosion)]
        (watch,) = [e.function for e in O.engines if isinstance(getattr(e, "function", None), LoadWatch)]
        if bodies != (watch.contact is not None):
            raise SystemExit(f"john_shah: --resume {resume}: the checkpoint was saved with loading="
                             f"{'bodies' if watch.contact is not None else 'condition'}; give the same parameters "
                             f"(loading={o['loading']})")
    else:
        mpm, crack, load, supports = build(o)
        O.dt = o["dt_us"] * 1e-6
        contact = em.BodyContact(engine=mpm, bodies=[load] + supports, label="contact") if bodies else None
        watch = LoadWatch(o, mpm, crack, load, supports, contact)
        if bodies:
            watch.checkEvery = crack.iterPeriod
        vtk = em.VTKRecorder(fileName=os.path.join(out, "vtk", "beam-"),
                             iterPeriod=max(1, int(round(o["vtkPeriod_us"] / o["dt_us"]))))
        # every step, so that the record holds each step's contact forces
        period = 1 if bodies else crack.iterPeriod
        O.engines = [mpm, crack, em.PlotRecorder(iterPeriod=crack.iterPeriod),
                     em.callEvery(watch, iterPeriod=period), vtk, em.Progress(endIter=steps, realPeriod=20)]
        if bodies:  # the hammer moved along Eq 35 before the step, YADE's integrator after it
            O.engines = ([ForceResetter(), em.callEvery(HammerDriver(o, load)), mpm, crack, contact,
                          NewtonIntegrator(damping=0)] + list(O.engines)[2:])
        if every:
            O.engines = [em.Checkpoint(directory=os.path.join(out, "checkpoints"), iterPeriod=every)] + list(O.engines)
    n = mpm.numPoints()  # (all points: under mpiexec a rank's solver holds its part)
    start = time.time()
    end = runSteps(steps - O.iter)  # Ctrl-C, SIGTERM or a solver error: outputs up to the stop, then finish()
    wall = time.time() - start
    steps = mpm.solver.steps
    speeds = em.parallel.gather(mpm, np.linalg.norm(mpm.solver.velocities(), axis=1))
    events = crack.core.events()
    summary = analyse(o, mpm.referenceOf([e[0] for e in events]), events, kappa)
    cs = crack.summary()
    curve = np.array(watch.curve)
    if bodies:  # the contact's force comes in steps (each first touch is an impulse): 10 us means
        raw = curve
        curve = curve.copy()
        curve[:, 1:] = windowMean(curve[:, 0], curve[:, 1:], LOAD_WINDOW)
    t = mpm.solver.time
    u = rampDisplacement(t, o["v0_m_s"], o["rampTime_us"] * 1e-6)  # imposed load-point displacement
    for site in ("notch", "midspan"):  # the load when each site's crack started (issue 15 item 4)
        ti = summary[f"{site}_initiation_time_us"]
        P = float(np.interp(ti * 1e-6, curve[:, 0], curve[:, 1])) if ti is not None else None
        summary[f"{site}_initiation_load_N"] = P
        # Nominal bending stress at the bottom of the midspan, 3 P L / (2 t D^2), t = thickness h.
        summary[f"{site}_initiation_midspan_stress_Pa"] = 3 * P * L / (2 * h * D * D) if P is not None else None
        if bodies:  # the supports' force then (10 us mean)
            summary[f"{site}_initiation_supports_N"] = (float(np.interp(ti * 1e-6, curve[:, 0], curve[:, 2]))
                                                        if ti is not None else None)
    # negative: the supports pulled (loading=bodies: the smallest in any step)
    summary["support_sum_min_reaction_N"] = float((raw if bodies else curve)[:, 2].min())
    if bodies:
        summary.update(supportSummary(raw, curve, summary["initiation_time_us"]), loading="bodies")
    if bodies:
        summary.update(peak_load_raw_N=float(raw[:, 1].max()), hammer_min_force_N=float(raw[:, 1].min()),
                       load_window_us=1e6 * LOAD_WINDOW)
    plots.damageMap(mpm, os.path.join(out, "damage.png"),  # (every rank: it sums a raster over the ranks)
                    title=f"John-Shah, gamma = {o['gamma']:g}, h = {o['h_mm']:g} mm, "
                          f"t = {mpm.solver.time * 1e6:.0f} us: " + (f"crack from the {summary['crack_origin']}"
                                                                  if summary["crack_origin"] else "no crack"))
    if not em.parallel.isRoot():  # under mpiexec rank 0 writes the outputs (doc/parallel.md)
        finish(end, out)
        return summary
    header = "t_us,load_N,supports_N" + (",left_support_N,right_support_N" if bodies else "")
    np.savetxt(os.path.join(out, "load.csv"), np.column_stack([1e6 * curve[:, 0], curve[:, 1:]]), delimiter=",",
               header=header, comments="", fmt="%.9g")
    summary.update(end_time_us=1e6 * t, load_point_displacement_mm=1e3 * u, peak_load_N=float(curve[:, 1].max()),
                   thickness_m=h, dissipated_energy_J=cs["dissipated_energy_J"], eroded_count=cs["eroded_count"],
                   particles=n, steps=steps, wall_time_s=wall, particle_steps_per_s=n * steps / wall, dt_s=O.dt,
                   critical_dt_s=mpm.criticalTimeStep(),
                   max_point_speed_m_s=float(np.max(speeds)),
                   transfer=mpm.transfer, stress_update=mpm.stressUpdate, parameters=o, quick=quick)
    summary.update(end.summary())
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    plots.series(os.path.join(out, "load.png"), curve[:, 0], {"load point": curve[:, 1], "supports": curve[:, 2]},
                 ylabel=f"force (N, thickness {h * 1e3:g} mm)", title="John-Shah: reactions")
    print(json.dumps({k: v for k, v in summary.items() if k != "parameters"}, indent=2))
    print("outputs in", out)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
