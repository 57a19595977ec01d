"""Kalthoff-Winkler edge-cracked steel plate under impact (paper Section 5.3).

Half model (the plate and the load are symmetric about y = 0): 100 x 100 mm, plane strain
(thickness 1 m, so energies are per metre), a notch from the left edge 50 mm long at
y = 25 mm, the left edge below the notch (0 <= y < 25 mm) driven in +x by the ramp of paper
Eq 34 (v0 = 16.5 m/s, t0 = 1 us), a symmetry (roller) plane on the bottom edge, the other
edges free. Steel: E = 190 GPa, nu = 0.3, rho = 8000 kg/m3, Gc = 22 130 N/m; Rayleigh speed
2803 m/s. Eigenerosion with alpha = 2, kappa = 1.15 h. Paper: h = 0.5 mm (160 000 points),
dt = 0.01 us; initiation about 26 us, initial angle about 70.5 deg up to about 40 us, overall
66.5 deg, the crack reaches the boundary at 102 us, maximum tip speed 1635 m/s; experiment
about 70 deg.

Modelling choices (parameters in brackets):

- The notch is a sharp phantom-node crack (paper Section 3.3.1) from x = -h (just outside the
  left edge) to the notch tip (50, 25) mm. Its line is moved to the nearest mid-line between two
  rows of points, so that both faces lie h/4 from it (no shift for h = 0.5, 1, 1.25, 2.5 mm;
  0.125 mm for h = 0.75 mm). Unaligned, one face can lie 0.06 mm from the crack.
- Open mouth [slitWidth_mm = 1, slitLength_mm = 40]: along the first 40 mm of the notch the
  points within 0.5 mm of the notch line are left out; the last 10 mm before the tip are the
  sharp crack alone. Reason (measured): the phantom-node faces have no contact. The block above
  the notch turns counter-clockwise (its left end moves down at about 20 m/s by 50 us) and
  the faces at the mouth interpenetrate; a point that crosses the crack line joins the other
  face's nodes, the faces bond and drag, points erode at the mouth and fly off. With the sharp
  notch alone (slitWidth_mm=0) at h = 1 mm, dt = 0.12 us: mouth erosion from about 93 us,
  point speeds above 800 m/s and a step above the critical one at about 116 us; the initial
  angle was 66.7 deg instead of 70.0 deg. A machined notch has a finite width anyway. With
  crackContact=1 (contact between the notch's faces, doc/contact.md) the sharp notch alone
  (slitWidth_mm=0) works: see doc/contact.md for the numbers.
- The impact is a velocity condition on the x component of the grid nodes nearest to the
  points of the left column (x < h/2) below the notch (y < notch - h/2), found anew each step
  as the points move (the paper's "monitoring the positions of boundary particles").
- [projectile = condition] Instead of the velocity condition, projectile=body strikes the
  left edge below the notch with a YADE rigid body (a box, `eigenmpm.BodyContact`,
  frictionless: the condition too prescribes x only), which YADE's NewtonIntegrator moves with
  the contact force; the plate can leave it (contact, not a bilateral condition). The box is
  projectileLength_mm (50 mm) long, reaches from the symmetry plane up to h/8 below the notch
  line (the experiment's projectile, 50 mm across, spans the 50 mm between the two notches), is
  one metre deep like the plane-strain model, moves in x only (blockedDOFs 'yzXYZ': the roller
  at y = 0 acts on grid nodes, not on it) and starts touching the plate's left edge at
  projectileSpeed_m_s. A YADE body is rigid, so the interface starts at the body's speed, not at
  half of it as between the experiment's steel projectile and its steel plate (equal
  impedances: the paper's 16.5 m/s is half the projectile's 33 m/s). Hence the default body
  (projectileMass_kg = 0): kinematic (not dynamic, infinite mass) at 16.5 m/s, the paper's
  loading made unilateral. The experiment's projectile (steel, 50 mm across, 50 mm long as the
  experiment is usually quoted: 0.785 kg) per plate thickness (19 mm) is 41.34 kg per metre,
  20.67 kg/m in the half model: projectileMass_kg=20.67 projectileSpeed_m_s=33 is that
  projectile taken rigid (its face starts at twice the interface speed), and
  projectileMass_kg=41.34 at 16.5 m/s the same momentum at the interface speed. Measured at
  h = 1 mm: the kinematic body cracks the plate like the condition; the rigid projectile leaves
  the plate at about 37 us and the crack arrests; the same momentum at 16.5 m/s starts no crack
  by 110 us. The condition gives the half plate about twice the projectile's momentum by 110 us
  (doc/contact.md, "The paper's benchmarks with YADE bodies").
- The symmetry plane y = 0 is fixed in y on the grid nodes of the bottom row (roller).
- The run ends at endTime_us or stopAfter_us (2 us) after the crack reaches the boundary,
  whichever comes first (stopAfter_us=-1 runs to endTime_us).
- Crack geometry is measured on the reference (initial) positions of the eroded points that
  form the crack: those connected (within 2 kappa) to the eroded point nearest the notch tip.
  Erosion elsewhere (none seen in the runs below) is counted in `eroded_elsewhere` and left out
  of the angles and the tip speed. `crack_path.csv` lists the crack points.
- Angles are measured from the notch direction (+x) to the crack path, counter-clockwise
  positive. The crack runs up and to the right, away from the impacted strip below the notch
  (mode II loading with the lower face sliding in +x: kink angle +70.5 deg by the maximum
  hoop stress criterion), so they are positive:
  * `crack_angle_initial_deg`: direction of the least-squares line through the notch tip fitted
    to the crack points within initLength_mm (10 mm) of the tip at the time the crack first
    reaches that distance (`initial_angle_time_us`; about 36 us, the paper's "to about 40 us");
  * `crack_angle_overall_deg`: angle of the chord from the notch tip to the crack point where
    the crack reaches the boundary (its first point within one point spacing h/2 of the top or
    right edge; `boundary_time_us`), or to the crack point farthest from the tip at the end;
  * `crack_angle_fit_deg`: least-squares line through the notch tip fitted to the whole path.
- Tip speed: the front distance (largest distance of a crack point from the notch tip,
  reference configuration) differentiated over a sliding window tipWindow_us (2 us, i.e. 4
  point spacings at 1000 m/s for h = 1 mm) of the erosion times; `max_tip_speed_m_s` is its
  maximum. `initiation_time_us` is the time of the first erosion.

Run::

    yade -n -x examples/kalthoff.py [--quick] [--out DIR] [param=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]
    yade-batch table.txt examples/kalthoff.py          # a column per parameter (and quick)

--checkpoint-every N saves the scene every N iterations into DIR/checkpoints (eigenmpm.Checkpoint,
doc/restart.md); --resume DIR/checkpoints continues from the newest of them (give the same
parameters) to the end state of the uninterrupted run, the edge watch (stopAfter_us) included,
and writes the outputs as usual (wall_time_s then counts the resumed part only; the VTK series
continues in the first run's folder).

params: h_mm, kappaOverH, alpha, endTime_us, dt_us, v0_m_s, rampTime_us, slitWidth_mm,
slitLength_mm, stopAfter_us, initLength_mm, tipWindow_us, vtkPeriod_us, E, nu, rho, Gc, split (the
tension/compression split of the strain energy: spectral, the paper's and the default; volumetric;
none; see doc/fracture.md), transfer (the particle-grid transfer of MpmEngine: FLIP, the paper's
and the default, or APIC), stressUpdate (smallStrain, the paper's and the default, or
corotational; doc/stability.md), crackContact (0, the paper's and the default: the notch's
faces pass through each other; 1: they touch, doc/contact.md), projectile (condition, the
paper's and the default: the velocity condition v0_m_s with the ramp rampTime_us; body: a YADE
rigid body, see above), projectileSpeed_m_s, projectileMass_kg (kg per metre of thickness of the
half model; 0, the default, or inf: kinematic) and projectileLength_mm (projectile=body only; v0_m_s and rampTime_us then unused),
distributedSetup (default 1: under mpiexec each rank builds only its share of the points,
doc/parallel.md "Memory"; 0: every rank builds the whole scene first; the same results either way).
With projectile=body the summary adds the projectile's speed at the start, at initiation and
at the end, its peak force and the impulse it gave the plate (per metre of thickness), the
momentum it lost, and when it lost contact (projectile_*), and the VTK series has the plate's
points only. Writes
DIR/summary.json (initiation_time_us, crack_angle_initial_deg, crack_angle_overall_deg,
crack_angle_fit_deg, boundary_time_us, max_tip_speed_m_s, dissipated_energy_J, transfer,
stress_update, crack_contact, particles,
steps, wall_time_s, particle_steps_per_s, ...), DIR/damage.png, DIR/tip_speed.png (with the
Rayleigh speed), DIR/energy.png, DIR/crack_path.csv and a VTK series DIR/vtk/plate-*.vtp.

--quick: h = 1 mm (39 840 points), dt = 0.12 us (critical 0.177 us at the start), 909 steps
(stopped at 109 us). Measured on one core: 8 s of stepping, 11 s in all (13 s and 18 s on a
busier machine); initiation 27.5 us, initial angle 70.0 deg, overall 64.4 deg (the crack
reaches the top edge at x = 85.8 mm at 106.4 us), maximum tip speed 1547 m/s (0.55 of the
Rayleigh speed), no erosion elsewhere. At h = 1 mm the angles scatter by 2 to 3 deg with dt
(dt = 0.15 / 0.10 / 0.06 us: initial 67.0 / 66.4 / 66.9 deg, overall 60.2 / 62.6 / 62.7 deg;
the run with dt = 0.06 us ended at 110 us just before the crack reached the edge).
h_mm=0.75 dt_us=0.1 (71 075 points, 27 s): initiation 27.1 us, initial 69.7 deg, overall
62.9 deg, boundary at 104.2 us, maximum tip speed 1510 m/s. The default (the paper's h = 0.5 mm,
159 360 points, 11 000 steps, 228 s on one thread): initiation 27.0 us, initial 69.8 deg,
overall 67.1 deg, the top edge reached at 109.3 us, maximum tip speed 1346 m/s
(doc/validation.md).
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

DEFAULTS = dict(h_mm=0.5, kappaOverH=1.15, alpha=2.0, endTime_us=110.0, dt_us=0.01, v0_m_s=16.5,
                rampTime_us=1.0, slitWidth_mm=1.0, slitLength_mm=40.0, stopAfter_us=2.0, initLength_mm=10.0,
                tipWindow_us=2.0, vtkPeriod_us=10.0, E=190e9, nu=0.3, rho=8000.0, Gc=22130.0,
                split="spectral", transfer="FLIP", stressUpdate="smallStrain", crackContact=False,
                projectile="condition", projectileSpeed_m_s=16.5, projectileMass_kg=0.0, projectileLength_mm=50.0,
                distributedSetup=True)
QUICK = dict(h_mm=1.0, dt_us=0.12)
PROJECTILES = ("condition", "body")
RAYLEIGH = 2803.0
SIZE, NOTCH_LEN = 0.1, 0.05


def notchY(h, ppc=2):
    """The notch line: y = 25 mm moved to the nearest mid-line between two rows of points (rows
    at (i + 1/2) h/ppc), so that both faces lie h/(2 ppc) from it (a shift below h/(2 ppc);
    none for h = 0.5, 1, 1.25, 2.5 mm)."""
    s = h / ppc
    return round(0.025 / s) * s


def build(o):
    h = o["h_mm"] * 1e-3
    yn = notchY(h)
    # The grid leaves 5 mm around the plate: the impact wave reflected at the free right edge moves
    # its points outward by more than a few cells (at h = 0.5 mm a point left a 3-cell margin at 86 us).
    mpm = em.MpmEngine(dim=2, h=h, ppc=2, thickness=1.0, label="plate",
                       domain=((-0.005, -0.005, 0), (SIZE + 0.005, SIZE + 0.005, 0)),
                       transfer=o["transfer"], stressUpdate=o["stressUpdate"], crackContact=o["crackContact"],
                       distributedSetup=o["distributedSetup"])
    steel = em.ElasticMaterial(E=o["E"], nu=o["nu"], rho=o["rho"], planeStress=False, split=o["split"])
    plate = pack.inAlignedBox((0, 0, 0), (SIZE, SIZE, 0))
    if o["slitWidth_mm"] > 0 and o["slitLength_mm"] > 0:
        w = 0.5e-3 * o["slitWidth_mm"]
        plate = plate - pack.inAlignedBox((-1, yn - w, -1), (o["slitLength_mm"] * 1e-3, yn + w, 1))
    mpm.fill(plate, steel)
    mpm.crack([(-h, yn, 0), (NOTCH_LEN, yn, 0)])
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 0, 1)), components="y", label="symmetry")
    if o["projectile"] == "condition":
        impact = mpm.velocityBC(points=pack.inAlignedBox((-1, -1, -1), (0.5 * h, yn - 0.5 * h, 1)),
                                components="x", velocity=(o["v0_m_s"], 0, 0), rampTime=o["rampTime_us"] * 1e-6,
                                label="impact")
    else:
        impact = projectileBody(o, h, yn)
    crack = em.EigenErosion(engine=mpm, Gc=o["Gc"], alpha=o["alpha"], kappaOverH=o["kappaOverH"],
                            origin=(NOTCH_LEN, yn, 0), tipWindow=o["tipWindow_us"] * 1e-6,
                            iterPeriod=max(1, int(round(0.5 / o["dt_us"]))))
    return mpm, crack, impact


def projectileBody(o, h, yn):
    """The projectile as a YADE box (projectile=body): projectileLength_mm long in x, from the
    symmetry plane y = 0 up to an eighth of a cell below the notch line (so that the points of
    the block above the notch, h/4 above the line, are out of its reach), its front face on the
    plate's left edge x = 0 (the points of the left column lie h/4 from it: they touch it from
    its first move). One metre deep in z like the plane-strain model; only x is free
    (blockedDOFs 'yzXYZ'), so the roller at y = 0 does not touch it. Mass projectileMass_kg
    (per metre of thickness, the half model's); 0 (the default) or inf: a kinematic body (not
    dynamic, infinite mass) moving at projectileSpeed_m_s whatever the plate does. Returns its
    id."""
    top = yn - h / 8
    lp = o["projectileLength_mm"] * 1e-3
    steel = O.materials.append(FrictMat(density=o["rho"], young=o["E"], poisson=o["nu"], frictionAngle=0,
                                        label="projectile"))
    m = o["projectileMass_kg"]
    b = utils.box((-0.5 * lp, 0.5 * top, 0), (0.5 * lp, 0.5 * top, 0.5), material=steel, fixed=not dynamicMass(m))
    bid = O.bodies.append(b)
    if dynamicMass(m):
        b.state.mass = m
        b.state.blockedDOFs = "yzXYZ"
    b.state.vel = (o["projectileSpeed_m_s"], 0, 0)
    return bid


def dynamicMass(m):
    """Whether projectileMass_kg = m makes a dynamic projectile (0 or inf: kinematic)."""
    return 0 < m < math.inf


class ProjectileWatch:
    """Records the projectile (projectile=body; a callEvery every step, after the
    NewtonIntegrator): rows of time, its x velocity, the x force of the points on it in this
    step, the points in contact. A class at the top level so that a checkpoint saves it with its
    record."""

    def __init__(self, mpm, contact, body):
        self.mpm, self.contact, self.body = mpm, contact, body
        self.rows = []

    def __call__(self):
        b = O.bodies[self.body]
        self.rows.append((self.mpm.solver.time, float(b.state.vel[0]), float(self.contact.force(self.body)[0]),
                          self.contact.pointsInContact()))


def projectileSummary(o, watch, initiation_us):
    """The projectile's record in summary keys: speed at the start, at crack initiation and at the
    end, peak force, the impulse given to the plate (the force's integral) and the momentum the
    projectile lost (mass x speed change; equal for a free body), when it lost contact."""
    r = np.array(watch.rows) if watch.rows else np.zeros((0, 4))
    m = o["projectileMass_kg"]
    t, v, f, n = (r[:, k] for k in range(4))
    impulse = float(np.sum(f)) * O.dt  # one row per step
    touched = np.nonzero(n > 0)[0]
    left = None
    if len(touched):
        after = np.nonzero((n == 0) & (np.arange(len(n)) > touched[0]))[0]
        left = 1e6 * float(t[after[0]]) if len(after) else None
    vInit = float(np.interp(initiation_us * 1e-6, t, v)) if initiation_us is not None and len(t) else None
    return dict(projectile=o["projectile"], projectile_mass_kg_per_m=m if dynamicMass(m) else None,
                projectile_speed_start_m_s=o["projectileSpeed_m_s"],
                projectile_speed_at_initiation_m_s=vInit, projectile_speed_end_m_s=float(v[-1]) if len(v) else None,
                projectile_peak_force_N_per_m=float(-f.min()) if len(f) else 0.0,
                projectile_max_pull_N_per_m=float(f.max()) if len(f) else 0.0,  # > 0 would be a pull
                projectile_impulse_N_s_per_m=-impulse,
                projectile_momentum_lost_N_s_per_m=m * (o["projectileSpeed_m_s"] - float(v[-1]))
                if dynamicMass(m) and len(v) else None,
                projectile_contact_end_us=left)


def crackPoints(x0, events, tip, radius):
    """The erosion events (id, time) whose points are connected, within `radius` in the
    reference configuration (x0: the reference positions of the events' points, a row each), to
    the eroded point nearest the notch tip, with their rows of x0 (x, y); and the others."""
    if not events:
        return [], [], np.zeros((0, 2))
    x = np.asarray(x0)[:, :2]
    seen = linked(x, int(np.argmin(np.sum((x - tip) ** 2, axis=1))), radius)
    pick = [(int(e[0]), float(e[2])) for e, s in zip(events, seen) if s]
    rest = [(int(e[0]), float(e[2])) for e, s in zip(events, seen) if not s]
    return pick, rest, x[seen]


def fitAngle(d):
    """Direction (deg, in (-90, 270)) of the least-squares line through the origin fitted to the
    offsets d (n x 2), oriented along their mean."""
    if len(d) == 0:
        return None
    w, v = np.linalg.eigh(d.T @ d)
    a = v[:, -1]
    if a @ d.sum(axis=0) < 0:
        a = -a
    return math.degrees(math.atan2(a[1], a[0]))


def analyse(o, x0, events, spacing, kappa):
    """The crack's path, angles and tip speed from the erosion events and the reference positions
    x0 of their points (a row each)."""
    tip = np.array([NOTCH_LEN, notchY(o["h_mm"] * 1e-3)])
    pick, rest, xs = crackPoints(x0, events, tip, 2.0 * kappa)
    res = dict(crack_points=len(pick), eroded_elsewhere=len(rest), crack_angle_initial_deg=None,
               crack_angle_overall_deg=None, crack_angle_fit_deg=None, boundary_time_us=None,
               initial_angle_time_us=None, crack_end_mm=None, crack_length_chord_mm=0.0)
    if not pick:
        return res, np.zeros((0, 2)), np.zeros(0), np.array([]), np.array([])
    t = np.array([s for _, s in pick])
    d = xs - tip
    r = np.hypot(d[:, 0], d[:, 1])
    # initial angle: the path within initLength of the tip once the crack is that long
    L0 = o["initLength_mm"] * 1e-3
    reached = np.nonzero(r >= L0)[0]
    if len(reached):
        tInit = t[reached].min()
        sel = (r <= L0) & (t <= tInit)
        res["initial_angle_time_us"] = 1e6 * tInit
    else:
        sel = r <= L0
    res["crack_angle_initial_deg"] = fitAngle(d[sel])
    # overall angle: the chord from the notch tip to where the crack reaches the boundary
    onEdge = np.nonzero((xs[:, 0] >= SIZE - spacing) | (xs[:, 1] >= SIZE - spacing))[0]
    if len(onEdge):
        k = onEdge[np.argmin(t[onEdge])]
        res["boundary_time_us"] = 1e6 * t[k]
    else:
        k = int(np.argmax(r))
    res["crack_angle_overall_deg"] = math.degrees(math.atan2(d[k, 1], d[k, 0]))
    res["crack_end_mm"] = (1e3 * xs[k]).tolist()
    res["crack_length_chord_mm"] = 1e3 * float(r[k])
    res["crack_angle_fit_deg"] = fitAngle(d)
    # tip speed: front distance against erosion time, over a sliding window
    order = np.argsort(t, kind="stable")
    ts, front = t[order], np.maximum.accumulate(r[order])
    w = o["tipWindow_us"] * 1e-6
    grid = np.arange(ts[0], ts[-1] + 1e-12, 0.25 * w) if ts[-1] > ts[0] else np.array([ts[0]])
    f = np.array([front[np.searchsorted(ts, g, side="right") - 1] for g in grid])
    speedT, speed = [], []
    for i, g in enumerate(grid):
        j = np.searchsorted(grid, g - w - 1e-15)
        if g - grid[j] >= w * (1 - 1e-9):
            speedT.append(g - 0.5 * w)
            speed.append((f[i] - f[j]) / (g - grid[j]))
    return res, xs, t, np.array(speedT), np.array(speed)


class EdgeWatch:
    """Ends the run stopAfter_us after the crack (connected to the notch tip) reaches the top or
    right edge (a callEvery). A class at the top level, not a local function, so that a
    checkpoint saves it with its state (the time the edge was reached) and --resume continues it."""

    def __init__(self, o, mpm, crack):
        h = o["h_mm"] * 1e-3
        self.mpm, self.crack = mpm, crack
        self.h, self.kappa, self.spacing = h, o["kappaOverH"] * h, h / mpm.ppc
        self.stopAfter_us = o["stopAfter_us"]
        self.at = None  # when the crack reached the edge, s

    def __call__(self):
        mpm, spacing = self.mpm, self.spacing
        if self.at is None:
            ev = self.crack.core.events()
            x0 = mpm.referenceOf([e[0] for e in ev])[:, :2]  # (every rank calls it, as it must)
            if len(ev) and np.max(x0) >= SIZE - spacing:
                _, _, xs = crackPoints(x0, ev, np.array([NOTCH_LEN, notchY(self.h)]), 2.0 * self.kappa)
                if np.max(xs) >= SIZE - spacing:
                    self.at = mpm.solver.time
        if self.at is not None and mpm.solver.time >= self.at + self.stopAfter_us * 1e-6:
            O.pause()


def main(argv):
    argv, resume, every = checkpointArgs("kalthoff", argv)
    o, out, quick = scriptArgs("kalthoff", DEFAULTS, QUICK, argv)
    os.makedirs(out, exist_ok=True)
    O.reset()
    plot.reset()
    steps = int(round(o["endTime_us"] / o["dt_us"]))
    if o["projectile"] not in PROJECTILES:
        raise SystemExit(f"kalthoff: projectile = {o['projectile']!r} is invalid; allowed: {', '.join(PROJECTILES)}")
    body = o["projectile"] == "body"
    if body and not o["projectileMass_kg"] >= 0:
        raise SystemExit(f"kalthoff: projectileMass_kg = {o['projectileMass_kg']!r} is invalid; allowed: >= 0 "
                         "(kg per metre of thickness; 0 or inf: a kinematic projectile)")
    watch = None
    if resume:  # the scene, its engines and the edge watch as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm = em.findEngine("plate")
        (crack,) = [e for e in mpm.physics.values() if isinstance(e, em.EigenErosion)]
        found = [e.function for e in O.engines if isinstance(getattr(e, "function", None), ProjectileWatch)]
        if body != bool(found):
            raise SystemExit(f"kalthoff: --resume {resume}: the checkpoint was saved with projectile="
                             f"{'body' if found else 'condition'}; give the same parameters (projectile={o['projectile']})")
        watch = found[0] if found else None
    else:
        mpm, crack, impact = build(o)
        O.dt = o["dt_us"] * 1e-6
        vtk = em.VTKRecorder(fileName=os.path.join(out, "vtk", "plate-"),
                             iterPeriod=max(1, int(round(o["vtkPeriod_us"] / o["dt_us"]))))
        engines = [mpm, crack, em.PlotRecorder(iterPeriod=crack.iterPeriod), vtk,
                   em.Progress(endIter=steps, realPeriod=20)]
        if body:  # YADE moves the projectile; the contact's forces reach it through O.forces
            contact = em.BodyContact(engine=mpm, bodies=[impact], label="contact")
            watch = ProjectileWatch(mpm, contact, impact)
            engines = ([ForceResetter()] + engines[:2] + [contact, NewtonIntegrator(damping=0)] + engines[2:]
                       + [em.callEvery(watch, iterPeriod=1)])
        if o["stopAfter_us"] >= 0:
            engines.append(em.callEvery(EdgeWatch(o, mpm, crack), iterPeriod=crack.iterPeriod))
        if every:
            engines.insert(0, em.Checkpoint(directory=os.path.join(out, "checkpoints"), iterPeriod=every))
        O.engines = engines
    n = mpm.numPoints()  # (all points: under mpiexec a rank's solver holds its part)
    h = o["h_mm"] * 1e-3
    kappa = o["kappaOverH"] * h
    spacing = h / mpm.ppc
    start = time.time()
    end = runSteps(steps - O.iter)  # Ctrl-C, SIGTERM or a solver error: outputs up to the stop, then finish()
    wall = time.time() - start
    steps = mpm.solver.steps
    speeds = em.parallel.gather(mpm, np.linalg.norm(mpm.solver.velocities(), axis=1))
    events = crack.core.events()
    res, path, tEr, speedT, speed = analyse(o, mpm.referenceOf([e[0] for e in events]), events, spacing, kappa)
    s = crack.summary()
    summary = dict(initiation_time_us=s["initiation_time_us"], **res,
                   max_tip_speed_m_s=float(speed.max()) if len(speed) else 0.0,
                   rayleigh_speed_m_s=RAYLEIGH, end_time_us=1e6 * mpm.solver.time,
                   max_point_speed_m_s=float(np.max(speeds)),
                   dissipated_energy_J=s["dissipated_energy_J"],
                   eroded_count=s["eroded_count"], particles=n, steps=steps, wall_time_s=wall,
                   particle_steps_per_s=n * steps / wall, dt_s=O.dt, critical_dt_s=mpm.criticalTimeStep(),
                   elastic_energy_J=mpm.elasticEnergy(), kinetic_energy_J=mpm.kineticEnergy(),
                   transfer=mpm.transfer, stress_update=mpm.stressUpdate, crack_contact=bool(mpm.crackContact),
                   parameters=o, quick=quick)
    if watch is not None:
        summary.update(projectileSummary(o, watch, s["initiation_time_us"]))
    summary.update(end.summary())
    plots.damageMap(mpm, os.path.join(out, "damage.png"),  # (every rank: it sums a raster over the ranks)
                    title=f"Kalthoff-Winkler, h = {o['h_mm']:g} mm, t = {mpm.solver.time * 1e6:.1f} us")
    if not em.parallel.isRoot():  # under mpiexec rank 0 writes the outputs (doc/parallel.md)
        finish(end, out)
        return summary
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    with open(os.path.join(out, "crack_path.csv"), "w") as f:
        f.write("x_mm,y_mm,erosion_time_us\n")
        for (x, y), te in zip(path, tEr):
            f.write(f"{x * 1e3:.6g},{y * 1e3:.6g},{te * 1e6:.6g}\n")
    plots.series(os.path.join(out, "tip_speed.png"), speedT, {"EigenMPM": speed}, ylabel="tip speed (m/s)",
                 title=f"Crack tip speed (window {o['tipWindow_us']:g} us)",
                 hlines=((RAYLEIGH, "Rayleigh speed 2803 m/s"), (1635, "paper maximum 1635 m/s")))
    t = np.array(plot.data["t"])
    plots.series(os.path.join(out, "energy.png"), t, {"elastic (Eq 32)": plot.data["plate_Ee"],
                                                      "kinetic": plot.data["plate_Ek"],
                                                      "dissipated (Eq 33)": plot.data["erosion_Ef"]},
                 ylabel="energy (J per m thickness)", title="Kalthoff-Winkler: energies")
    print(json.dumps({k: v for k, v in summary.items() if k != "parameters"}, indent=2))
    print("outputs in", out)
    finish(end, out)
    return summary


if __name__ == "__main__":
    main(sys.argv[1:])
