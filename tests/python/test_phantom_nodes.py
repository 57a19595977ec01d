"""Pre-existing cracks by phantom nodes (paper Section 3.3.1) through the Python API.

A cut bar pulled apart transmits no force and its halves separate at the imposed speed; momentum
is conserved; the material ahead of a tip in the middle of a cell stays continuous; an edge
crack concentrates stress at its tip, more so on a finer grid; inclined cracks in 2D and planar
cracks in 3D open along their normal; cracks move with a translating or rotating body; an edge
crack steers eigenerosion to its tip; the shipped example precracked_bar.py. The crossing rule,
marking and twin numbering are tested in tests/cpp/test_phantom_nodes.cpp.
"""
import json
import math
import os
import subprocess

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "examples", "verification", "precracked_bar.py")

E, NU, RHO = 1e8, 0.2, 1000.0
C = math.sqrt(E * (1 - NU) / ((1 + NU) * (1 - 2 * NU) * RHO))  # plane-strain P-wave speed, m/s


def material(E=E):
    return em.ElasticMaterial(E=E, nu=NU, rho=RHO)


def kabsch(p, q):
    """Best rigid motion x -> R (x - pc) + qc taking the points p onto q (least squares)."""
    pc, qc = p.mean(axis=0), q.mean(axis=0)
    u, _, vt = np.linalg.svd((p - pc).T @ (q - qc))
    d = np.ones(p.shape[1])
    d[-1] = np.sign(np.linalg.det(vt.T @ u.T))
    return vt.T @ np.diag(d) @ u.T, pc, qc


# ------------------------------------------------------------------------------------------
# Bars cut across and pulled apart
# ------------------------------------------------------------------------------------------

def pull_bar(cracks, h=0.01, v=1.0, transits=6.0, rampTransits=2.0, L=0.2, H=0.05):
    """Bar L x H, ends pulled apart at -v/+v (ramped over t0); cracks are x positions of through
    cracks. Returns the measurements at the end and the reactions' means over the second half."""
    O.reset()
    mpm = em.MpmEngine(dim=2, h=h, ppc=2, label="mpm")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (L, H, 0)), material())
    for xc in cracks:
        mpm.crack([(xc, -h, 0), (xc, H + h, 0)])
    t0 = rampTransits * L / C
    layer = 0.26 * h
    left = mpm.velocityBC(points=pack.inAlignedBox((-1, -1, -1), (layer, 1, 1)), components="x",
                          velocity=(-v, 0, 0), rampTime=t0)
    right = mpm.velocityBC(points=pack.inAlignedBox((L - layer, -1, -1), (1, 1, 1)), components="x",
                           velocity=(v, 0, 0), rampTime=t0)
    rec = []
    O.engines = [mpm, em.callEvery(lambda: rec.append((mpm.solver.time, right.reaction[0], -left.reaction[0])))]
    O.dt = 0.3 * mpm.criticalTimeStep()
    x0 = mpm.solver.positions().copy()
    O.run(int(math.ceil(transits * L / C / O.dt)), True)
    r = np.array(rec)
    t = mpm.solver.time
    second = r[:, 0] >= 0.5 * t
    # What the tests read, taken now: the next O.reset() frees this solver.
    return dict(twins=mpm.solver.numTwins, cracks=mpm.solver.numCracks, x0=x0, x=mpm.solver.positions(),
                sigma=mpm.solver.stress(), t=t, t0=t0, h=h, v=v, L=L,
                reaction=float(r[second, 1].mean()), reactionLeft=float(r[second, 2].mean()))


def gap(x, x0, xc):
    """Smallest x right of xc minus largest x left of it (points split by initial position)."""
    left = x0[:, 0] < xc
    return x[~left, 0].min() - x[left, 0].max()


def test_cut_bar_separates_freely_and_transmits_no_force():
    xc = 0.1013
    cut, whole = pull_bar([xc]), pull_bar([])
    h, v, t, t0, L = cut["h"], cut["v"], cut["t"], cut["t0"], cut["L"]
    expected = 2 * v * (t - 0.5 * t0)
    # The halves separate at the imposed relative velocity.
    growth = gap(cut["x"], cut["x0"], xc) - gap(cut["x0"], cut["x0"], xc)
    assert growth == pytest.approx(expected, rel=0.02)  # measured 6.019 mm against 6.018 mm
    assert gap(whole["x"], whole["x0"], xc) - gap(whole["x0"], whole["x0"], xc) < 0.05 * expected
    # The intact bar carries sigma_xx = E/(1-nu^2) eps (plane strain, free lateral faces).
    near = np.abs(cut["x0"][:, 0] - xc) < 1.5 * h
    sigmaIntact = float(whole["sigma"][near, 0, 0].mean())
    assert sigmaIntact == pytest.approx(E / (1 - NU ** 2) * expected / L, rel=0.05)
    assert whole["reaction"] > 0 and whole["reaction"] == pytest.approx(whole["reactionLeft"], rel=1e-6)
    # Across the crack: no stress, and no force at the pulled ends once the ramp is over.
    assert abs(float(cut["sigma"][near, 0, 0].mean())) < 0.01 * sigmaIntact   # measured 2.6e-3
    assert abs(cut["reaction"]) < 0.01 * whole["reaction"]                    # measured 6e-4
    assert abs(cut["reactionLeft"]) < 0.01 * whole["reaction"]
    assert cut["twins"] > 0 and whole["twins"] == 0


def test_two_cracks_cut_the_bar_in_three_free_pieces():
    L = 0.2
    a, b = L / 3 + 0.0013, 2 * L / 3 + 0.0013
    cut = pull_bar([a, b], L=L)
    assert cut["cracks"] == 2
    x, x0, t, t0, v, h = cut["x"], cut["x0"], cut["t"], cut["t0"], cut["v"], cut["h"]
    each = v * (t - 0.5 * t0)
    for xc in (a, b):
        assert gap(x, x0, xc) - gap(x0, x0, xc) == pytest.approx(each, rel=0.03)
    middle = (x0[:, 0] > a) & (x0[:, 0] < b)
    assert abs(float((x - x0)[middle, 0].mean())) < 0.02 * each   # the middle piece stays put
    assert np.abs(cut["sigma"][middle, 0, 0]).max() < 1e-3 * E * each / L


def test_momentum_conserved_with_phantom_nodes():
    O.reset()
    mpm = em.MpmEngine(dim=2, h=0.01, ppc=2, massCutoff=0.0, label="mpm")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.08, 0)), material())
    mpm.crack([(0.0513, -0.01, 0), (0.0513, 0.0461, 0)])                    # edge crack
    mpm.crack([(0.1107, 0.0309, 0), (0.1402, 0.0517, 0), (0.1611, 0.0433, 0)])  # interior, kinked
    rng = np.random.default_rng(3)
    vel = rng.uniform(-1, 1, (mpm.solver.numPoints, 3))
    vel[:, 2] = 0
    mpm.solver.setVelocities(vel)
    m = mpm.solver.mass()
    p0 = (m[:, None] * mpm.solver.velocities()).sum(axis=0)
    scale = float((m * np.linalg.norm(mpm.solver.velocities(), axis=1)).sum())
    O.engines = [mpm]
    O.dt = 0.4 * mpm.criticalTimeStep()
    for _ in range(5):
        O.run(10, True)
        assert mpm.solver.numTwins > 0
        p = (m[:, None] * mpm.solver.velocities()).sum(axis=0)
        assert np.linalg.norm(p - p0) < 1e-12 * scale
    assert np.abs(mpm.solver.stress()).max() > 1e3  # the body did deform


def test_scene_without_cracks_has_no_twins():
    O.reset()
    mpm = em.MpmEngine(dim=2, h=0.01, ppc=2, label="mpm")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), material(), velocity=(0.1, 0, 0))
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(5, True)
    assert mpm.solver.numTwins == 0
    assert mpm.solver.numCracks == 0
    assert list(mpm.solver.markedNodes()) == []
    # The same scene with a crack has twins, on the nodes it marks.
    O.reset()
    mpm = em.MpmEngine(dim=2, h=0.01, ppc=2, label="mpm")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), material(), velocity=(0.1, 0, 0))
    assert mpm.crack([(0.0513, -0.01, 0), (0.0513, 0.06, 0)]) == 0
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(1, True)
    marked = list(mpm.solver.markedNodes())
    assert mpm.solver.numCracks == 1 and mpm.solver.numTwins == len(marked) > 0
    nodes = mpm.solver.nodePositions()[marked]
    assert np.abs(nodes[:, 0] - 0.0513).max() < 2.5 * 0.01  # cut cells plus one ring (uGIMP)


# ------------------------------------------------------------------------------------------
# Edge-cracked plate: the tip
# ------------------------------------------------------------------------------------------

def edge_plate(h, crack=True, W=0.1, v=0.5, transits=6.0, rampTransits=3.0, erosion=None):
    """Square plate W x W, edge crack from the left edge to a tip in the middle of a cell at
    x = W/2 + h/2 (y slightly above mid-height), top and bottom pulled apart at +-v."""
    O.reset()
    mpm = em.MpmEngine(dim=2, h=h, ppc=2, label="mpm")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (W, W, 0)), material())
    yc, tip = 0.5 * W + 0.1 * h, 0.5 * W + 0.5 * h
    if crack:
        mpm.crack([(-h, yc, 0), (tip, yc, 0)])
    e = 0.26 * h
    t0 = rampTransits * W / C
    mpm.velocityBC(points=pack.inAlignedBox((-1, W - e, -1), (1, 1, 1)), components="y", velocity=(0, v, 0),
                   rampTime=t0)
    mpm.velocityBC(points=pack.inAlignedBox((-1, -1, -1), (1, e, 1)), components="y", velocity=(0, -v, 0),
                   rampTime=t0)
    engines = [mpm]
    if erosion is not None:
        engines.append(em.EigenErosion(engine=mpm, **erosion))
    O.engines = engines
    O.dt = 0.5 * mpm.criticalTimeStep()
    x0 = mpm.solver.positions().copy()
    O.run(int(transits * W / C / O.dt), True)
    return dict(mpm=mpm, x0=x0, yc=yc, tip=tip, h=h, W=W, strain=2 * v * (mpm.solver.time - 0.5 * t0) / W,
                engines=engines)


def test_material_ahead_of_the_tip_stays_continuous():
    r = edge_plate(0.005)
    mpm, x0, yc, tip, h = r["mpm"], r["x0"], r["yc"], r["tip"], r["h"]
    u = mpm.solver.positions() - x0
    above = (x0[:, 1] > yc) & (x0[:, 1] < yc + 0.5 * h)   # the rows of points next to the crack line
    below = (x0[:, 1] < yc) & (x0[:, 1] > yc - 0.5 * h)
    opening = {}
    for xp in np.unique(x0[above, 0]):
        a = above & (x0[:, 0] == xp)
        b = below & (x0[:, 0] == xp)
        opening[(xp - tip) / h] = float(u[a, 1].mean() - u[b, 1].mean())
    nominal = r["strain"] * 0.5 * h  # stretch of the 0.5 h between the two rows at the nominal strain
    ahead = [d for s, d in opening.items() if s >= 1.0]
    behind = [d for s, d in opening.items() if s <= -1.0]
    assert len(ahead) >= 8 and len(behind) >= 8
    # Ahead of the tip the two rows stay together: only elastic stretch (measured 1.4x nominal
    # at 1.25 h, falling to 0.8x); behind it the faces gape (measured 23x to 43x nominal).
    assert max(ahead) < 2.5 * nominal
    assert min(ahead) > 0
    assert min(behind) > 10 * nominal
    assert min(behind) > 8 * max(ahead)
    # The opening grows away from the tip along the crack.
    behindSorted = [opening[s] for s in sorted(opening) if s <= -1.0]
    assert all(a >= b for a, b in zip(behindSorted, behindSorted[1:]))


def stress_ratio_at_tip(r):
    """sigma_yy of the points in the cell ahead of the tip (max) and along the ligament (mean),
    over the far-field sigma_yy (mean over the points more than 0.3 W from the crack line)."""
    s, x0, yc, tip, h, W = r["mpm"].solver.stress(), r["x0"], r["yc"], r["tip"], r["h"], r["W"]
    far = float(s[np.abs(x0[:, 1] - yc) > 0.3 * W, 1, 1].mean())
    rows = np.abs(x0[:, 1] - yc) < 0.5 * h
    ahead = rows & (x0[:, 0] > tip) & (x0[:, 0] < tip + h)
    ligament = rows & (x0[:, 0] > tip)
    return float(s[ahead, 1, 1].max()) / far, float(s[ligament, 1, 1].mean()) / far, far


def test_edge_crack_concentrates_stress_at_the_tip_more_on_a_finer_grid():
    coarse, cLig, far = stress_ratio_at_tip(edge_plate(0.005))
    fine, fLig, _ = stress_ratio_at_tip(edge_plate(0.0025))
    intact, _, farIntact = stress_ratio_at_tip(edge_plate(0.005, crack=False))
    # Measured: 4.43 at h, 5.83 at h/2 (ratio 1.32; 8.17 at h/4), sqrt(2) = 1.41 for a
    # 1/sqrt(r) field sampled at r ~ h; intact plate 1.0.
    assert far > 0 and farIntact > 0
    assert coarse > 3.0
    assert 1.15 * coarse < fine < 1.6 * coarse
    assert intact < 1.2
    # Force balance: the ligament (half the width) carries about twice the far-field stress.
    assert 1.7 < cLig < 2.7 and 1.7 < fLig < 2.7


def test_eigenerosion_starts_at_the_crack_tip():
    erosion = dict(Gc=100.0, alpha=2.0, kappaOverH=1.1)
    h = 0.005

    def first_eroded(crack):
        r = edge_plate(h, crack=crack, transits=8.0, rampTransits=8.0, erosion=erosion)
        events = r["engines"][1].core.events()
        assert events, "nothing eroded"
        step = min(e[1] for e in events)
        ids = [e[0] for e in events if e[1] == step]
        return np.linalg.norm(r["x0"][ids, :2] - np.array([r["tip"], r["yc"]]), axis=1) / h, len(events)

    dist, count = first_eroded(True)
    assert dist.max() < 2.0   # measured 0.76 h and 0.83 h, 78 points eroded by the end
    assert count > 2
    # Without the crack the first points erode elsewhere (measured 12 h to 13 h from the tip's
    # place): the test can tell.
    distIntact, _ = first_eroded(False)
    assert distIntact.min() > 4.0


# ------------------------------------------------------------------------------------------
# Inclined cracks
# ------------------------------------------------------------------------------------------

def test_inclined_crack_opens_along_its_normal_2d():
    """Plate cut through by a 30 degree crack; the parts far from the crack are pulled apart
    along its normal n (left of its direction t): the faces separate along +-n, on the right sides."""
    W, h, v = 0.1, 0.005, 0.5
    c0 = np.array([0.5 * W + 0.13 * h, 0.5 * W + 0.07 * h])
    t = np.array([math.cos(math.pi / 6), math.sin(math.pi / 6)])
    n = np.array([-t[1], t[0]])
    out = {}
    for cracked in (True, False):
        O.reset()
        mpm = em.MpmEngine(dim=2, h=h, ppc=2, label="mpm")
        mpm.fill(pack.inAlignedBox((0, 0, 0), (W, W, 0)), material())
        if cracked:
            mpm.crack([tuple(c0 - 0.09 * t) + (0,), tuple(c0 + 0.09 * t) + (0,)])
        x0 = mpm.solver.positions().copy()
        dist = (x0[:, :2] - c0) @ n
        t0 = 3 * W / C
        mpm.velocityBC(points=np.where(dist > 0.03)[0], components="xy", velocity=(v * n[0], v * n[1], 0), rampTime=t0)
        mpm.velocityBC(points=np.where(dist < -0.03)[0], components="xy", velocity=(-v * n[0], -v * n[1], 0),
                       rampTime=t0)
        O.engines = [mpm]
        O.dt = 0.5 * mpm.criticalTimeStep()
        O.run(300, True)
        u = (mpm.solver.positions() - x0)[:, :2]
        s = mpm.solver.stress()[:, :2, :2]
        near = (np.abs(dist) < h) & (np.abs((x0[:, :2] - c0) @ t) < 0.02)
        pos, neg = near & (dist > 0), near & (dist < 0)
        du = u[pos].mean(axis=0) - u[neg].mean(axis=0)
        out[cracked] = dict(du=du, upos=u[pos].mean(axis=0), uneg=u[neg].mean(axis=0),
                            snn=float(np.einsum("i,pij,j->p", n, s, n)[near].mean()),
                            expected=2 * v * (mpm.solver.time - 0.5 * t0))
    cut, whole = out[True], out[False]
    assert cut["du"] @ n == pytest.approx(cut["expected"], rel=0.03)   # measured 1.801 against 1.800 mm
    assert abs(cut["du"] @ t) < 0.01 * cut["expected"]                # no slip along the faces
    assert cut["upos"] @ n > 0.4 * cut["expected"] and cut["uneg"] @ n < -0.4 * cut["expected"]
    assert whole["du"] @ n < 0.15 * whole["expected"]
    assert abs(cut["snn"]) < 0.01 * whole["snn"]                       # measured 4e-4


def test_planar_crack_opens_along_its_normal_3d():
    """Block cut through by a plane tilted 30 degrees from the yz plane (normal n in xz); its
    ends pulled apart along +-n."""
    L, B, h, v = 0.06, 0.04, 0.005, 0.5
    c0 = np.array([0.5 * L + 0.13 * h, 0.5 * B + 0.07 * h, 0.5 * B + 0.11 * h])
    n = np.array([math.cos(math.pi / 6), 0.0, math.sin(math.pi / 6)])
    e1 = np.array([0.0, 1.0, 0.0])
    e2 = np.cross(n, e1)
    O.reset()
    mpm = em.MpmEngine(dim=3, h=h, ppc=2, label="mpm")
    mpm.fill(pack.inAlignedBox((0, 0, 0), (L, B, B)), material())
    R = 0.04
    mpm.crack([tuple(c0 + R * (a * e1 + b * e2)) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    x0 = mpm.solver.positions().copy()
    dist = (x0 - c0) @ n
    t0 = 3 * L / C
    mpm.velocityBC(points=np.where(x0[:, 0] > L - 1.5 * h)[0], velocity=tuple(v * n), rampTime=t0)
    mpm.velocityBC(points=np.where(x0[:, 0] < 1.5 * h)[0], velocity=tuple(-v * n), rampTime=t0)
    O.engines = [mpm]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(200, True)
    expected = 2 * v * (mpm.solver.time - 0.5 * t0)
    u = mpm.solver.positions() - x0
    centre = (np.abs((x0 - c0) @ e1) < 0.01) & (np.abs((x0 - c0) @ e2) < 0.01)
    near = (np.abs(dist) < h) & centre
    pos, neg = near & (dist > 0), near & (dist < 0)
    assert pos.sum() > 20 and neg.sum() > 20
    du = u[pos].mean(axis=0) - u[neg].mean(axis=0)
    assert du @ n == pytest.approx(expected, rel=0.03)   # measured 1.239 against 1.230 mm
    assert abs(du @ e1) < 0.02 * expected and abs(du @ e2) < 0.03 * expected
    assert u[pos].mean(axis=0) @ n > 0.4 * expected and u[neg].mean(axis=0) @ n < -0.4 * expected
    snn = np.einsum("i,pij,j->p", n, mpm.solver.stress(), n)
    assert abs(float(snn[near].mean())) < 0.01 * E * expected / L   # uncut: ~E expected / L


# ------------------------------------------------------------------------------------------
# Cracks moving with the material
# ------------------------------------------------------------------------------------------

def test_crack_translates_with_the_body_and_still_separates():
    h, L, H = 0.01, 0.2, 0.05
    V = np.array([2.0, 1.0, 0.0])
    O.reset()
    mpm = em.MpmEngine(dim=2, h=h, ppc=2, label="mpm", domain=((-0.05, -0.05, 0), (0.4, 0.15, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, 0), (L, H, 0)), material(), velocity=tuple(V))
    xc = 0.1013
    # Ends three cells outside the bar, out of reach of its material.
    cid = mpm.crack([(xc, -0.03, 0), (xc, H + 0.03, 0)])
    v0 = np.array(mpm.crackVertices(cid))
    x0 = mpm.solver.positions().copy()
    O.engines = [mpm]
    O.dt = 0.3 * mpm.criticalTimeStep()
    O.run(int(math.ceil(5 * h / np.linalg.norm(V) / O.dt)), True)   # five cells
    t1 = mpm.solver.time
    assert np.linalg.norm(V) * t1 >= 5 * h
    assert np.abs(np.array(mpm.crackVertices(cid)) - v0 - V * t1).max() < 1e-9 * h
    assert np.abs(mpm.solver.stress()).max() < 1e-6   # Pa: a rigid translation is stress free
    # Then pull the ends apart (relative +-1 m/s along x, ramped over t0 from now): the halves
    # separate.
    ids = np.arange(len(x0))
    t0 = 2 * L / C
    ramp = lambda t: min(1.0, max(0.0, (t - t1) / t0))  # noqa: E731
    mpm.velocityBC(points=ids[x0[:, 0] < 0.26 * h], components="xy",
                   velocity=lambda t: tuple(V - [ramp(t), 0, 0]))
    mpm.velocityBC(points=ids[x0[:, 0] > L - 0.26 * h], components="xy",
                   velocity=lambda t: tuple(V + [ramp(t), 0, 0]))
    g0 = gap(mpm.solver.positions(), x0, xc)
    O.run(400, True)
    t2 = mpm.solver.time - t1
    growth = gap(mpm.solver.positions(), x0, xc) - g0
    assert growth == pytest.approx(2 * (t2 - 0.5 * t0), rel=0.03)
    near = np.abs(x0[:, 0] - xc) < 1.5 * h
    strain = 2 * (t2 - 0.5 * t0) / L
    assert abs(float(mpm.solver.stress()[near, 0, 0].mean())) < 0.01 * E * strain


def test_crack_rotates_with_the_body():
    """A bar with an edge crack (outer end 2.5 cells outside the bar) spins 90 degrees with
    v = omega x r and no conditions: the crack's vertices follow the material's rigid motion, no
    stress appears beyond that of the intact bar, and the crack still opens when pulled."""
    h, L, H, omega = 0.01, 0.2, 0.05, 10.0
    Esoft = 1e6
    out = {}
    for cracked in (True, False):
        O.reset()
        mpm = em.MpmEngine(dim=2, h=h, ppc=2, label="mpm", domain=((-0.05, -0.1, 0), (0.25, 0.15, 0)))
        mpm.fill(pack.inAlignedBox((0, 0, 0), (L, H, 0)), material(Esoft))
        x0 = mpm.solver.positions().copy()
        c = x0[:, :2].mean(axis=0)
        r = x0[:, :2] - c
        vel = np.zeros_like(x0)
        vel[:, 0], vel[:, 1] = -omega * r[:, 1], omega * r[:, 0]
        mpm.solver.setVelocities(vel)
        xc, tipY = 0.1013, 0.5 * H + 0.1 * h
        if cracked:
            cid = mpm.crack([(xc, -2.5 * h, 0), (xc, tipY, 0)])
            v0 = np.array(mpm.crackVertices(cid))[:, :2]
        smax = [0.0]
        O.engines = [mpm, em.callEvery(lambda: smax.__setitem__(0, max(smax[0], np.abs(mpm.solver.stress()).max())),
                                       iterPeriod=20)]
        O.dt = 0.3 * mpm.criticalTimeStep()
        O.run(int(round(0.5 * math.pi / omega / O.dt)), True)
        x = mpm.solver.positions()[:, :2]
        R, pc, qc = kabsch(x0[:, :2], x)
        angle = math.degrees(math.atan2(R[1, 0], R[0, 0]))
        residual = np.abs((R @ (x0[:, :2] - pc).T).T + qc - x).max()
        out[cracked] = dict(smax=smax[0], angle=angle, residual=residual)
        if cracked:
            v1 = np.array(mpm.crackVertices(cid))[:, :2]
            expect = (R @ (v0 - pc).T).T + qc
            out["vertexError"] = np.abs(v1 - expect).max()
            # Pull: the two sides of the crack get +-vp along the bar's current axis.
            axis = R @ np.array([1.0, 0.0])
            vp = 0.5
            side = np.where(x0[:, 0] < xc, -1.0, 1.0)
            newVel = np.zeros_like(x0)
            newVel[:, :2] = vp * side[:, None] * axis
            mpm.solver.setVelocities(newVel)
            xa, tp = mpm.solver.positions()[:, :2].copy(), mpm.solver.time
            O.run(60, True)
            du = (mpm.solver.positions()[:, :2] - xa) @ axis
            rows = np.abs(x0[:, 0] - xc) < 0.5 * h
            lft, rgt = rows & (x0[:, 0] < xc), rows & (x0[:, 0] > xc)
            mouth = x0[:, 1] < 0.5 * h
            ahead = x0[:, 1] > tipY + 1.5 * h
            out["mouth"] = du[rgt & mouth].mean() - du[lft & mouth].mean()
            out["ahead"] = du[rgt & ahead].mean() - du[lft & ahead].mean()
            out["free"] = 2 * vp * (mpm.solver.time - tp)
    cut, whole = out[True], out[False]
    assert cut["angle"] > 80 and whole["angle"] > 80          # a large rotation (measured 85.7 degrees)
    assert cut["residual"] < 0.1 * h and whole["residual"] < 0.1 * h   # both bodies stay rigid
    assert out["vertexError"] < 0.1 * h                       # measured 0.02 h
    assert cut["smax"] < 2.0 * whole["smax"]                  # measured 1.35x
    # The crack still cuts the bar: the mouth opens freely, the ligament holds.
    assert out["mouth"] > 0.5 * out["free"]
    assert out["ahead"] < 0.2 * out["mouth"]


# ------------------------------------------------------------------------------------------
# The shipped example
# ------------------------------------------------------------------------------------------

KEYS = {"gap_m", "gap_expected_m", "reaction_cracked_N", "reaction_intact_N", "stress_at_crack_cracked_Pa",
        "stress_at_crack_intact_Pa", "stress_intact_expected_Pa", "particles", "steps", "wall_time_s",
        "particle_steps_per_s"}


def test_precracked_bar_script_quick(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", SCRIPT, "--quick", "--out", str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    s = json.load(open(tmp_path / "summary.json"))
    assert KEYS <= set(s)
    assert s["gap_m"] == pytest.approx(s["gap_expected_m"], rel=0.02)
    assert s["gap_expected_m"] > 0.005
    assert abs(s["reaction_cracked_N"]) < 0.01 * s["reaction_intact_N"]
    assert abs(s["stress_at_crack_cracked_Pa"]) < 0.01 * s["stress_at_crack_intact_Pa"]
    assert s["stress_at_crack_intact_Pa"] == pytest.approx(s["stress_intact_expected_Pa"], rel=0.05)
    assert s["particles"] > 0 and s["steps"] > 0 and s["particle_steps_per_s"] > 0 and s["twins"] > 0
    assert (tmp_path / "precracked_bar.png").stat().st_size > 10000
