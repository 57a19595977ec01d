"""Initiation of a sharp crack under slowly ramped remote tension, against Griffith.

A square glass plate W x W (plane strain, E = 32 GPa, nu = 0.2, rho = 2450 kg/m3, Gc = 3 J/m2)
holds a phantom-node crack along x: a centre crack of length 2a = 2 aOverW W (geometry=centre),
or an edge crack of length a = aOverW W from the left edge (geometry=edge), at mid-height. The
crack is moved along x by tipShift cells, so that its tips lie tipShift of a cell off the node
lines (grid bias); crackAngle_deg inclines the centre crack by beta against x (the load stays
along y: mixed mode, K_I = sigma sqrt(pi a) cos^2 beta, K_II = sigma sqrt(pi a) sin beta cos beta);
and the whole specimen (plate, crack and load) can be turned by angle_deg
about the plate's centre against the grid axes (grid bias again: the physics do not change). A traction in y on the
points within h of the top and bottom edges rises linearly from 0 to ratioMax sigma_G over
rampTransits wave transits W/c, slowly enough for the plate to follow quasi-statically; on a
turned specimen the traction's layer (Eq 28) is the loaded points' area over W, so that each edge
carries W times the traction (with the layer h, before 2026-12-02, a band turned by 45 degrees
carried 5.6-6.3 % more). The run
stops at the first erosion (eigenerosion, kappa = kappaOverH h) and reports the traction then,
over Griffith's stress with Feddersen's finite-width correction,

    centre: sigma_G = sqrt(E' Gc / (pi a)) / sqrt(sec(pi a / W)),   E' = E / (1 - nu^2),
    edge:   sigma_G = sqrt(E' Gc / (pi a)) / F(a/W),  F = 1.12 - 0.231 s + 10.55 s^2 - 21.72 s^3 + 30.39 s^4
            (Tada's single-edge-cracked strip, s = a/W <= 0.6; the plate here is square).

With the paper's alpha = 2 the ratio is about 1 / sqrt(2 r) = 1.72 (r = 0.168, the initiation
ratio of doc/fracture.md); with alpha = 'griffith' (alpha = 1 / r) it should be 1 at fine
resolution. For an inclined crack the summary also gives two predictions of the initiation
traction over sigma_G of the straight crack: Eq 24 on the mixed field (pred_erosion_ratio =
sqrt(r_I / r(beta)) / cos beta with alpha = 1 / r_I, r(beta) the ratio at mixity beta) and the
maximum hoop stress criterion (pred_mts_ratio), with its kink angle pred_mts_kink_deg; with
kinkPoints = N > 0 the run goes on until N points have eroded and kink_deg is the direction, from
the right tip and against the crack, of the eroded points more than kappa from it, and
kink_ring_deg that direction from the eroded points between kappa and 3 kappa from
either tip (reference positions), eroded up to the step in which that tip's branch first passed
3 kappa (kink_ring_points of them; the left tip's turned by 180 degrees, the plate's symmetry;
kink_ring_right_deg and kink_ring_left_deg per tip) and kink_reach_right_over_kappa /
kink_reach_left_over_kappa the farthest such point ahead of each tip, in kappa; for a straight
crack the summary then also has the crack length grown (grown_length_m), the dissipated energy
over Gc t (dissipated_over_Gc_t_m, t the thickness) and |C_kappa| / (2 kappa) of the eroded set
(C_kappa_over_2kappa_m), which for a straight cut of length L is L + pi kappa / 2 per free end.
With kinkPoints > 0 the energies at one time level (MpmEngine.energyBalance) are recorded every
20 steps and at the stop into DIR/energy.csv (t_s, Ek_J, Ee_J, Psi_f_J: Eq 33, Wext_J, balance_J
= Ek + Ee + Psi_f - Wext, eroded) and the summary has external_work_J, dissipated_energy_J,
energy_balance_final_J, energy_balance_max_abs_J (largest change from the first record), and
over the growth (from the last record before the first erosion to the stop): growth_external_work_J,
growth_dissipated_J, growth_balance_drift_J, growth_balance_drift_over_work (the drift over the
external work of that interval) and growth_drift_without_Ef_over_work (the same without Psi_f).

Run::

    yade -n -x examples/verification/griffith_initiation.py [--quick] [--out DIR] [name=value ...]
        [--checkpoint-every N] [--resume DIR/checkpoints]

with names geometry (centre or edge), h_mm (cell size), W_mm, aOverW, tipShift (cells), angle_deg,
crackAngle_deg, kinkPoints,
alpha (a number or griffith), kappaOverH, rampTransits, ratioMax, dtFraction, ppc. --quick: h = 2 mm (a / h = 2), a coarse check that the run
starts a crack near sigma_G. Writes DIR/summary.json: initiation_ratio (traction at the first
erosion / sigma_G), initiation_stress_Pa, griffith_stress_Pa, initiation_time_s, first_eroded
(position, m), alpha_used, eroded_at_stop, a_over_h, particles, steps, wall_time_s (of this run),
traction_layer_over_h (turned specimen: the layers of the top and bottom loads over h),
resumed_from_iteration (0 unless --resume), ...
Default DIR: out/griffith_initiation. --checkpoint-every N saves the scene every N iterations into
DIR/checkpoints; --resume DIR/checkpoints, with the same parameters, continues from the newest one
to the same summary (doc/restart.md).
"""
import json
import math
import os
import sys
import time

import numpy as np
from yade import O, pack, plot

import eigenmpm as em
from eigenmpm import _eigenmpm
from eigenmpm.cli import checkpointArgs, finish, runSteps, scriptArgs

DEFAULTS = dict(geometry="centre", h_mm=0.5, W_mm=40.0, aOverW=0.1, tipShift=0.0, angle_deg=0.0,
                crackAngle_deg=0.0, kinkPoints=0, alpha="griffith", kappaOverH=1.1, rampTransits=60.0,
                ratioMax=1.5, dtFraction=0.5, ppc=2, E=32e9, nu=0.2, rho=2450.0, Gc=3.0)
QUICK = dict(h_mm=2.0)


def griffithStress(E, nu, Gc, a, W, geometry="centre"):
    """Griffith's remote stress (plane strain) for a centre crack 2a in a plate of width W with
    Feddersen's finite-width correction, or for an edge crack a with Tada's."""
    s = a / W
    if geometry == "edge":
        F = 1.12 - 0.231 * s + 10.55 * s ** 2 - 21.72 * s ** 3 + 30.39 * s ** 4
    elif geometry == "centre":
        F = math.sqrt(1.0 / math.cos(math.pi * s))
    else:
        raise ValueError(f"griffith_initiation: geometry = {geometry!r} is invalid; allowed: 'centre' or 'edge'")
    return math.sqrt(E / (1 - nu * nu) * Gc / (math.pi * a)) / F


class TurnedBand:
    """yade.pack-style predicate: the points whose coordinates in the plate's frame (turned by
    `angle` about `centre`) lie in [lo, hi] (x and y), for filling and for selecting edges."""

    def __init__(self, centre, angle, lo, hi):
        self.c, self.cs, self.sn, self.lo, self.hi = np.array(centre), math.cos(angle), math.sin(angle), lo, hi

    def local(self, p):
        dx, dy = p[0] - self.c[0], p[1] - self.c[1]
        return self.cs * dx + self.sn * dy, -self.sn * dx + self.cs * dy

    def __call__(self, p, pad=0.0):
        u, v = self.local(p)
        return self.lo[0] <= u <= self.hi[0] and self.lo[1] <= v <= self.hi[1]

    def aabb(self):
        corners = [(u, v) for u in (self.lo[0], self.hi[0]) for v in (self.lo[1], self.hi[1])]
        xs = [self.c[0] + self.cs * u - self.sn * v for u, v in corners]
        ys = [self.c[1] + self.sn * u + self.cs * v for u, v in corners]
        return (min(xs), min(ys), 0.0), (max(xs), max(ys), 0.0)


def propagation(mpm, er, events, o, h, W, a, shift):
    """Energy of the crack grown from a straight crack (kinkPoints > 0): the crack length produced
    (along x beyond the initial tips), the engine's dissipated energy (Eq 33) over Gc t, and
    |C_kappa| / (2 kappa) of the eroded set (C_kappa: the points of the plane within kappa of an
    eroded point, measured on a raster of kappa/40), which for a straight cut of length L is
    L + pi kappa / 2 per free end. Lengths in m."""
    from scipy.spatial import cKDTree
    kappa = o["kappaOverH"] * h
    x = mpm.solver.positions()[[p for p, _, _ in events], :2]
    if o["geometry"] == "edge":
        grown = max(0.0, x[:, 0].max() - (a + shift))
    else:
        grown = max(0.0, x[:, 0].max() - (0.5 * W + a + shift)) + max(0.0, (0.5 * W - a + shift) - x[:, 0].min())
    step = kappa / 40
    lo, hi = x.min(axis=0) - kappa, x.max(axis=0) + kappa
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], step) + 0.5 * step, np.arange(lo[1], hi[1], step) + 0.5 * step)
    cells = np.column_stack([gx.ravel(), gy.ravel()])
    d, _ = cKDTree(x).query(cells, distance_upper_bound=kappa * (1 + 1e-9))
    area = np.count_nonzero(np.isfinite(d)) * step * step
    return dict(grown_length_m=grown, dissipated_J=er.dissipatedEnergy(),
                dissipated_over_Gc_t_m=er.dissipatedEnergy() / (o["Gc"] * mpm.thickness),
                C_kappa_over_2kappa_m=area / (2 * kappa), kappa_m=kappa, eroded_points=len(events))


def energyBalance(rows):
    """The energy balance over the run from the records (columns: time, Ek, Ee, Psi_f, Wext,
    balance = Ek + Ee + Psi_f - Wext, eroded count): its final value and largest change from the
    first record, and its drift during growth, from the last record before the first erosion to
    the stop, absolute and over the external work done in that interval (and what that drift
    would be without Psi_f, to show what the balance resolves). Energies in J."""
    b, w, f = rows[:, 5], rows[:, 4], rows[:, 3]
    before = np.flatnonzero(rows[:, 6] == 0)
    i = int(before[-1]) if len(before) else 0
    dw = w[-1] - w[i]
    drift = b[-1] - b[i]
    return dict(external_work_J=float(w[-1]), dissipated_energy_J=float(f[-1]),
                energy_balance_final_J=float(b[-1]), energy_balance_max_abs_J=float(np.max(np.abs(b - b[0]))),
                growth_start_time_s=float(rows[i, 0]), growth_external_work_J=float(dw),
                growth_dissipated_J=float(f[-1] - f[i]), growth_balance_drift_J=float(drift),
                growth_balance_drift_over_work=float(drift / dw) if dw else None,
                growth_drift_without_Ef_over_work=float((drift - (f[-1] - f[i])) / dw) if dw else None,
                energy_records=len(rows))


def run(o, checkpoints=None, checkpointEvery=0, resume=None):
    """The plate's run to the stop; with checkpointEvery > 0 a Checkpoint engine saves it every
    checkpointEvery iterations into `checkpoints`; with `resume` (a folder of checkpoints) the
    run continues from the newest one instead of being built."""
    O.reset()
    plot.reset()
    h, W = o["h_mm"] * 1e-3, o["W_mm"] * 1e-3
    a = o["aOverW"] * W
    alpha = o["alpha"] if o["alpha"] == "griffith" else float(o["alpha"])
    angle = math.radians(o["angle_deg"])
    centre = (0.5 * W, 0.5 * W)
    turn = lambda x, y: (centre[0] + math.cos(angle) * (x - centre[0]) - math.sin(angle) * (y - centre[1]),  # noqa: E731
                         centre[1] + math.sin(angle) * (x - centre[0]) + math.cos(angle) * (y - centre[1]), 0)
    half = 0.5 * W
    y = 0.5 * W + 0.13 * h  # off the point rows and node lines
    shift = o["tipShift"] * h
    beta = math.radians(o["crackAngle_deg"])
    ends = [(0.5 * W + shift + sgn * a * math.cos(beta), y + sgn * a * math.sin(beta)) for sgn in (-1, 1)]
    tip = np.array(turn(*ends[1])[:2])
    sG = griffithStress(o["E"], o["nu"], o["Gc"], a, W, o["geometry"])
    c = math.sqrt(o["E"] * (1 - o["nu"]) / ((1 + o["nu"]) * (1 - 2 * o["nu"]) * o["rho"]))
    ramp = o["rampTransits"] * W / c
    t = o["ratioMax"] * sG
    layers = [None, None]
    if resume:  # the scene as checkpointed (doc/restart.md)
        em.checkpoint.resume(resume)
        mpm, er = em.findEngine("plate"), next(e for e in O.engines if isinstance(e, em.EigenErosion))
    else:
        mpm = em.MpmEngine(dim=2, h=h, ppc=int(o["ppc"]), label="plate")
        mat = em.ElasticMaterial(E=o["E"], nu=o["nu"], rho=o["rho"])
        if angle == 0:
            mpm.fill(pack.inAlignedBox((0, 0, 0), (W, W, 0)), mat)
            top, bottom = pack.inAlignedBox((-1, W - h, -1), (1, 1, 1)), pack.inAlignedBox((-1, -1, -1), (1, h, 1))
        else:
            mpm.fill(TurnedBand(centre, angle, (-half, -half), (half, half)), mat)
            top = TurnedBand(centre, angle, (-2 * half, half - h), (2 * half, 2 * half))
            bottom = TurnedBand(centre, angle, (-2 * half, -2 * half), (2 * half, -half + h))
        if o["geometry"] == "edge":
            mpm.crack([turn(-h, y), turn(a + shift, y)])
        else:
            mpm.crack([turn(*ends[0]), turn(*ends[1])])
        n = (-math.sin(angle) * t, math.cos(angle) * t, 0)
        # Eq 28 gives each loaded point t V_p / layer; with layer = h the band's force is t times
        # its points' area over h, which is W t along the grid but up to 6 % more on a turned one
        # (at 45 degrees the band of width h holds three diagonal rows of points): the layer is
        # set to that area over W, so that the force on each edge is W t at any angle.
        layers = [None, None] if angle == 0 else \
            [len(mpm.pointsIn(band)) * (h / int(o["ppc"])) ** 2 / W for band in (top, bottom)]
        mpm.traction(points=top, traction=n, rampTime=ramp, layer=layers[0])
        mpm.traction(points=bottom, traction=(-n[0], -n[1], 0), rampTime=ramp, layer=layers[1])
        er = em.EigenErosion(engine=mpm, Gc=o["Gc"], alpha=alpha, kappaOverH=o["kappaOverH"], iterPeriod=1)
        O.engines = [mpm, er]
        if int(o["kinkPoints"]) > 0:  # the energy balance during growth, every chunk of 20 steps
            O.engines = O.engines + [em.PlotRecorder(iterPeriod=20)]
        if checkpointEvery:
            O.engines = [em.Checkpoint(directory=checkpoints, iterPeriod=checkpointEvery)] + list(O.engines)
        O.dt = o["dtFraction"] * mpm.criticalTimeStep()
    steps = int(math.ceil(ramp / O.dt))
    start, first = time.time(), O.iter
    # Chunks of 20 steps from iteration 0 (a resumed run keeps the same boundaries), the erosion
    # checked at each boundary.
    end, chunk = runSteps(0), 20
    while O.iter < steps:
        end = runSteps(min(chunk - O.iter % chunk, steps - O.iter))
        if end.early or er.erodedCount() >= max(1, int(o["kinkPoints"])):
            break
    # With kinkPoints the energies at one time level (MpmEngine.energyBalance), as the
    # PlotRecorder kept them every 20 steps (checkpointed with the scene), and at the stop:
    # time, Ek, Ee, Psi_f (Eq 33), Wext, balance, eroded count.
    energy = []
    if int(o["kinkPoints"]) > 0:
        L, E = mpm.label, er.label
        keys = ("t", f"{L}_EkStep", f"{L}_Ee", f"{E}_Ef", f"{L}_Wext", f"{L}_balance", f"{E}_eroded")
        energy = [list(r) for r in zip(*(plot.data[k] for k in keys))] if plot.data else []
        b = mpm.energyBalance()
        energy.append([mpm.solver.time, b["Ek"], b["Ee"], b["Ef"], b["Wext"], b["balance"], er.erodedCount()])
    wall = time.time() - start
    events = er.core.events()
    summary = dict(griffith_stress_Pa=sG, a_over_h=a / h, alpha_used=er.core.alpha, ramp_time_s=ramp,
                   particles=int(mpm.solver.numPoints), steps=int(mpm.solver.steps), wall_time_s=wall,
                   eroded_at_stop=er.erodedCount(), h_m=h, W_m=W, a_m=a, dt_s=O.dt, resumed_from_iteration=first)
    if angle != 0 and not resume:
        summary.update(traction_layer_over_h=[v / h for v in layers])
    if events:
        _, step, ti = min(events, key=lambda e: e[1])
        first = [p for p, s, _ in events if s == step]
        x = mpm.solver.positions()[first]
        summary.update(initiation_time_s=ti, initiation_stress_Pa=t * min(ti / ramp, 1.0),
                       initiation_ratio=t * min(ti / ramp, 1.0) / sG,
                       first_eroded=[list(map(float, p[:2])) for p in x])
    else:
        summary.update(initiation_time_s=None, initiation_stress_Pa=None, initiation_ratio=None,
                       first_eroded=[])
    if int(o["kinkPoints"]) > 0 and events and o["crackAngle_deg"] == 0 and o["angle_deg"] == 0:
        summary.update(propagation(mpm, er, events, o, h, W, a, shift))
    if energy:
        summary.update(energyBalance(np.array(energy)))
    if o["geometry"] == "centre" and o["crackAngle_deg"] != 0:
        b = math.radians(o["crackAngle_deg"])
        rI = _eigenmpm.initiationRatio(2, o["E"], o["nu"], False, "spectral")
        rb = _eigenmpm.initiationRatio(2, o["E"], o["nu"], False, "spectral", mixity_deg=o["crackAngle_deg"])
        tb = math.tan(b)
        kink = 2 * math.atan((1 - math.sqrt(1 + 8 * tb * tb)) / (4 * tb))
        KI, KII = math.cos(b) ** 2, math.sin(b) * math.cos(b)
        keq = math.cos(kink / 2) * (KI * math.cos(kink / 2) ** 2 - 1.5 * KII * math.sin(kink))
        summary.update(pred_erosion_ratio=math.sqrt(rI / rb) / math.cos(b), pred_mts_ratio=1.0 / keq,
                       pred_mts_kink_deg=math.degrees(kink))
        if int(o["kinkPoints"]) > 0 and events:
            t = np.array([math.cos(b + angle), math.sin(b + angle)])
            n = np.array([-t[1], t[0]])
            rel = mpm.solver.positions()[[p for p, _, _ in events], :2] - tip
            u, v = rel @ t, rel @ n
            far = (np.hypot(u, v) > o["kappaOverH"] * h) & (u > -o["kappaOverH"] * h)
            summary.update(kink_deg=math.degrees(math.atan2(v[far].mean(), u[far].mean())) if far.any() else None,
                           kink_points=int(far.sum()))
            # The kink in the ring kappa < r <= 3 kappa about each tip (reference positions; the
            # left tip's points turned by 180 degrees about it, the plate's symmetry), from the
            # points eroded up to the step in which the branch first passed 3 kappa (later erosion,
            # the band widening on the faces, would blur it), and how far the branch reached.
            kap = o["kappaOverH"] * h
            ev = sorted(events, key=lambda e: e[1])
            x = mpm.referencePositions[[p for p, _, _ in ev], :2]
            stepOf = np.array([e[1] for e in ev])
            ring = {}
            for side, rel in (("right", x - tip), ("left", np.array(turn(*ends[0])[:2]) - x)):
                u, v = rel @ t, rel @ n
                r = np.hypot(u, v)
                ahead = u > -kap
                passed = np.flatnonzero(ahead & (r > 3 * kap))
                upto = stepOf <= stepOf[passed[0]] if len(passed) else np.ones(len(r), bool)
                sel = ahead & (r > kap) & (r <= 3 * kap) & upto
                ring[side] = (u[sel], v[sel], float(r[ahead].max() / kap) if ahead.any() else 0.0)
            ang = lambda u, v: math.degrees(math.atan2(v.mean(), u.mean())) if len(u) else None  # noqa: E731
            uu = np.concatenate([ring[k][0] for k in ring])
            vv = np.concatenate([ring[k][1] for k in ring])
            summary.update(kink_ring_deg=ang(uu, vv), kink_ring_points=int(len(uu)),
                           kink_ring_right_deg=ang(*ring["right"][:2]), kink_ring_left_deg=ang(*ring["left"][:2]),
                           kink_reach_right_over_kappa=ring["right"][2], kink_reach_left_over_kappa=ring["left"][2])
    return summary, end, energy


def main(argv):
    argv, resume, every = checkpointArgs("griffith_initiation", argv)
    o, out, quick = scriptArgs("griffith_initiation", DEFAULTS, QUICK, argv)
    summary, end, energy = run(o, os.path.join(out, "checkpoints"), every, resume)
    summary.update(parameters=o, quick=quick, **end.summary())
    os.makedirs(out, exist_ok=True)
    if energy:
        np.savetxt(os.path.join(out, "energy.csv"), np.array(energy), fmt="%.9g", delimiter=",",
                   header="t_s,Ek_J,Ee_J,Psi_f_J,Wext_J,balance_J,eroded", comments="")
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=1)
    print(json.dumps({k: summary[k] for k in ("initiation_ratio", "alpha_used", "a_over_h", "steps", "wall_time_s",
                                               "pred_erosion_ratio", "pred_mts_ratio", "pred_mts_kink_deg",
                                               "kink_deg", "grown_length_m", "dissipated_over_Gc_t_m",
                                               "C_kappa_over_2kappa_m", "energy_balance_max_abs_J",
                                               "growth_balance_drift_over_work") if k in summary}))
    finish(end, out)


if __name__ == "__main__":
    main(sys.argv[1:])
