"""Eigenerosion (paper Eqs 22-24, 33): closed-form onset, irreversibility, determinism,
energy bookkeeping and the neighbour search."""
import math
import warnings

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em

H = 0.01


def stretched_bar(rate, Gc=50.0, alpha=1.5, kappa=1.1 * H, threads=None):
    """A bar whose every grid node moves with v = (rate x, 0): uniform uniaxial strain rate."""
    mpm = em.MpmEngine(h=H, domain=((-0.05, -0.05, 0), (0.25, 0.1, 0)), threads=threads)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.25, rho=1000))
    for xi in np.unique(mpm.solver.nodePositions()[:, 0]):
        mpm.velocityBC(region=pack.inAlignedBox((xi - 1e-6, -1, -1), (xi + 1e-6, 1, 1)), components="xy",
                       velocity=(rate * xi, 0, 0))
    er = em.EigenErosion(engine=mpm, Gc=Gc, alpha=alpha, kappa=kappa, iterPeriod=1)
    O.engines = [mpm, er]
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm, er


def test_uniform_tension_erodes_when_alpha_kappa_H_reaches_Gc_within_one_step():
    Gc, alpha, kappa, rate = 50.0, 1.5, 1.1 * H, 1.0
    mpm, er = stretched_bar(rate, Gc, alpha, kappa)
    info = mpm.solver.materialInfo(0)
    # Uniaxial strain (eps, 0): psi+ = (lambda + 2 mu) eps^2 / 2 = H; G_p = alpha kappa H (Eq 23).
    eps_c = math.sqrt(2 * Gc / (alpha * kappa * (info["lambda"] + 2 * info["mu"])))
    step_c = math.ceil(eps_c / (rate * O.dt))  # the strain after step n is rate * n * dt
    O.run(step_c - 1, True)
    assert er.erodedCount() == 0
    O.run(3, True)
    steps = {s for _, s, _ in er.core.events()}
    assert steps == {step_c}
    assert er.erodedCount() == mpm.solver.numPoints
    assert np.all(mpm.solver.damage() == 0)


def test_pure_compression_never_erodes():
    mpm, er = stretched_bar(-1.0, Gc=1e-6)
    O.run(600, True)  # compressive strain 0.3 %, far beyond the tensile onset at this Gc
    assert er.erodedCount() == 0
    assert np.all(mpm.solver.history() == 0) and np.all(mpm.solver.damage() == 1)
    assert not er.core.searchedLastStep


def test_eroded_point_keeps_only_compressive_stress():
    mpm, er = stretched_bar(1.0)
    O.run(600, True)
    assert er.erodedCount() == mpm.solver.numPoints
    # Tension along x only (lateral strain held at 0): sigma- has no tensile principal part.
    s = mpm.solver.stress()
    assert np.all(np.linalg.eigvalsh(s[:, :2, :2]) <= 1e-9 * 1e9)


def test_dissipated_energy_is_Gc_over_2kappa_times_eroded_volume():
    mpm, er = stretched_bar(1.0)
    O.run(600, True)
    eroded = mpm.solver.damage() == 0
    assert er.dissipatedEnergy() == pytest.approx(50.0 / (2 * 1.1 * H) * np.sum(mpm.solver.volume()[eroded]),
                                                  rel=1e-12)


def notched_plate(threads):
    """A plate with an edge slit, pulled apart at top and bottom: a crack grows from the slit."""
    h = 0.002
    plate = pack.inAlignedBox((0, 0, 0), (0.1, 0.04, 0)) - pack.inAlignedBox((-1, 0.0195, -1), (0.03, 0.0205, 1))
    mpm = em.MpmEngine(h=h, threads=threads)
    mpm.fill(plate, em.ElasticMaterial(E=72e9, nu=0.22, rho=2440, planeStress=True))
    mpm.velocityBC(points=pack.inAlignedBox((-1, 0.039, -1), (1, 1, 1)), components="y", velocity=(0, 2.0, 0))
    mpm.velocityBC(points=pack.inAlignedBox((-1, -1, -1), (1, 0.001, 1)), components="y", velocity=(0, -2.0, 0))
    er = em.EigenErosion(engine=mpm, Gc=135.0, alpha=2.0, kappaOverH=1.1, iterPeriod=1)
    seen = []

    def monotone():
        d = mpm.solver.damage()
        if seen:
            assert np.all(d <= seen[-1]), "an eroded point healed"
        seen.append(d)

    O.engines = [mpm, er, em.callEvery(monotone)]
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm, er


def test_eroded_set_grows_only_and_is_identical_on_1_and_2_threads():
    runs = []
    for threads in (1, 2):
        O.reset()
        mpm, er = notched_plate(threads)
        O.run(400, True)
        runs.append((er.core.events(), mpm.solver.positions()))
    assert 0 < len(runs[0][0]) < 2000  # a crack has started but not cut through
    assert runs[0][0] == runs[1][0]
    assert np.array_equal(runs[0][1], runs[1][1])


def test_positions_of_a_few_points_are_their_rows_of_all_positions():
    """parallel.positionsOf (the crack diagnostics' read of the eroded points) reads only the
    given points (solver.positionsAt), the same rows as all positions; a bad index is named."""
    O.reset()
    mpm, _ = stretched_bar(1.0)
    O.run(3, True)
    ids = np.array([5, 0, 17, 5, len(mpm.solver.positions()) - 1], dtype=np.int64)
    assert np.array_equal(em.parallel.positionsOf(mpm, ids), mpm.solver.positions()[ids])
    assert em.parallel.positionsOf(mpm, np.array([], dtype=np.int64)).shape == (0, 3)
    with pytest.raises(Exception, match="point index"):
        mpm.solver.positionsAt(np.array([len(mpm.solver.positions())], dtype=np.int64))
    with pytest.raises(Exception, match="int64"):
        mpm.solver.positionsAt(np.array([1.0, 2.0]))


@pytest.mark.parametrize("dim", [2, 3])
def test_neighbour_search_equals_brute_force(dim):
    rng = np.random.default_rng(7)
    h = 0.013
    kappa = 1.17 * h  # not a multiple of h, nor of the point spacing
    mpm = em.MpmEngine(dim=dim, h=h)
    mat = em.ElasticMaterial(E=1e9, nu=0.2, rho=1000)
    n = 1500 if dim == 2 else 3000
    cloud = rng.uniform(0, 0.12 if dim == 2 else 0.06, size=(n, 3))
    if dim == 2:
        cloud[:, 2] = 0
    # Points exactly on the cell list's cell borders: a lattice of spacing kappa / 2 from the
    # cloud's lower corner puts every other lattice line on a border.
    lo = cloud.min(axis=0)
    k = np.arange(6) * 0.5 * kappa
    lat = np.stack(np.meshgrid(*([lo[0] + k, lo[1] + k] + ([lo[2] + k] if dim == 3 else [[0.0]])),
                               indexing="ij"), -1).reshape(-1, 3)
    mpm.addPoints(np.vstack([cloud, lat]), mat, volumes=rng.uniform(0.5, 2.0, len(cloud) + len(lat)) * 1e-6)
    # Random history through a random strain state: step once with random velocities.
    mpm.solver.setVelocities(rng.normal(0, 1.0, size=(mpm.solver.numPoints, 3)) * [1, 1, dim == 3])
    er = em.EigenErosion(engine=mpm, Gc=1e12, alpha=1.5, kappa=kappa)
    O.engines = [mpm, er]  # the erosion stage acts (and computes G) only from O.engines
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(3, True)
    assert np.all(mpm.solver.history() >= 0) and np.count_nonzero(mpm.solver.history()) > 100
    ids = list(range(mpm.solver.numPoints))
    fast = mpm.solver.energyReleaseRate(ids, bruteForce=False)
    brute = mpm.solver.energyReleaseRate(ids, bruteForce=True)
    assert fast == pytest.approx(brute, rel=1e-12, abs=0)
    assert er.erodedCount() == 0


def test_no_search_on_a_scene_that_never_breaks():
    mpm = em.MpmEngine(h=H)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000),
             velocity=(0, 1e-3, 0))
    er = em.EigenErosion(Gc=1e3, alpha=1.5, kappaOverH=1.1)
    O.engines = [mpm, er]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(50, True)
    assert mpm.solver.erosion is er.core  # attached through O.engines
    assert not er.core.searchedLastStep and er.core.candidatesLastStep == 0


@pytest.mark.parametrize("kw, name", [(dict(Gc=0.0, kappa=0.01), "Gc"), (dict(Gc=-1.0, kappa=0.01), "Gc"),
                                      (dict(Gc=10.0, alpha=0.0, kappa=0.01), "alpha"),
                                      (dict(Gc=10.0, kappa=-0.01), "kappa"),
                                      (dict(Gc=10.0, kappaOverH=0.0), "kappaOverH")])
def test_parameters_validated(kw, name):
    with pytest.raises(ValueError, match=f"{name} = .* is invalid; allowed: {name} > 0"):
        em.EigenErosion(**kw)


def test_warns_when_kappa_holds_only_the_point_itself():
    mpm = em.MpmEngine(h=H)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000))
    with pytest.warns(UserWarning, match="only the point itself"):
        em.EigenErosion(engine=mpm, Gc=10.0, kappaOverH=0.3)
    with pytest.warns(UserWarning, match="Appendix A"):
        em.EigenErosion(engine=mpm, Gc=10.0, kappaOverH=2.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        em.EigenErosion(engine=mpm, Gc=10.0, kappaOverH=1.1)


def test_stray_erosion_far_away_is_not_part_of_the_main_crack():
    class Core:
        kappa = 0.001

    er = em.EigenErosion(Gc=1.0, kappa=0.001)
    er.core = Core()
    crack = [(0.01 + 0.0005 * i, 0.02, 0.0) for i in range(20)]   # a crack from (0.01, 0.02)
    stray = [(0.09, 0.001, 0.0), (0.0905, 0.001, 0.0)]           # erosion under a far support
    x = np.array(crack + stray)
    main = er._mainCrack(x, np.array([0.01, 0.02, 0.0]))
    assert np.flatnonzero(main).tolist() == list(range(20))


# --- the erosion acts only while its engine is in O.engines ----------------------------------------
def pulled_plate():
    """A pre-cracked plate pulled apart (edges at +-2 m/s) that erodes within 100 steps at Gc = 1."""
    mpm = em.MpmEngine(h=0.002)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.05, 0.02, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000))
    mpm.crack([(-0.001, 0.01, 0), (0.02, 0.01, 0)])
    mpm.velocityBC(points=pack.inAlignedBox((-1, 0.019, -1), (1, 1, 1)), components="y", velocity=(0, 2, 0))
    mpm.velocityBC(points=pack.inAlignedBox((-1, -1, -1), (1, 0.001, 1)), components="y", velocity=(0, -2, 0))
    er = em.EigenErosion(engine=mpm, Gc=1.0, kappaOverH=1.1, iterPeriod=1000)
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm, er


def test_an_erosion_engine_never_in_o_engines_does_not_erode():
    mpm, er = pulled_plate()
    O.engines = [mpm]
    O.run(150, True)
    assert mpm.solver.erosion is None and er.erodedCount() == 0 and np.all(mpm.solver.damage() > 0)
    O.reset()
    mpm, er = pulled_plate()  # the same scene with the engine in O.engines erodes
    O.engines = [mpm, er]
    O.run(150, True)
    assert er.erodedCount() > 0


def test_an_erosion_engine_attached_by_hand_does_not_act_outside_o_engines():
    mpm, er = pulled_plate()
    er.attach(mpm)
    assert mpm.solver.erosion is er.core
    O.engines = [mpm]
    O.run(150, True)
    assert mpm.solver.erosion is None and er.erodedCount() == 0


def test_an_erosion_engine_attached_by_hand_between_steps_is_detached_at_the_next_step():
    """MpmEngine._syncPhysics keeps the attachments while O.engines and the solver stay the same;
    a stage attached by hand in between still changes what it checks (the attached stages)."""
    mpm, er = pulled_plate()
    O.engines = [mpm]
    O.run(5, True)
    er.attach(mpm)
    assert mpm.solver.erosion is er.core
    O.run(1, True)
    assert mpm.solver.erosion is None and not mpm.physics


@pytest.mark.parametrize("how", ["removed", "dead"])
def test_an_erosion_engine_stops_when_removed_or_dead_and_resumes_when_back(how):
    mpm, er = pulled_plate()
    O.engines = [mpm, er]
    O.run(100, True)
    assert mpm.solver.erosion is er.core and "erosion_Ef" in mpm.plotData()
    if how == "removed":
        O.engines = [mpm]
    else:
        er.dead = True
    count, damage = er.erodedCount(), mpm.solver.damage().copy()
    O.run(50, True)
    assert mpm.solver.erosion is None and er.erodedCount() == count
    assert np.array_equal(mpm.solver.damage(), damage) and "erosion_Ef" not in mpm.plotData()
    if how == "removed":
        O.engines = [mpm, er]
    else:
        er.dead = False
    O.run(1, True)
    assert mpm.solver.erosion is er.core


@pytest.mark.parametrize("how", ["dead", "assigned", "updateAttrs"])
def test_an_erosion_engine_stopped_inside_a_run_is_detached_at_the_next_step(how):
    """MpmEngine._syncPhysics does not read O.engines while nothing has changed it (the count of
    engines.watchEngines): a change made by an engine inside O.run, through any of the paths,
    still detaches the stage at the next step."""
    mpm, er = pulled_plate()
    seen = []

    def probe():  # (after the MpmEngine's step of each iteration)
        seen.append(mpm.solver.erosion is er.core)
        if O.iter == 60:
            if how == "dead":
                er.dead = True
            elif how == "assigned":
                O.engines = [e for e in O.engines if e is not er]
            else:
                er.updateAttrs({"dead": True})

    O.engines = [mpm, er, em.callEvery(probe)]
    O.run(70, True)
    assert len(seen) == 70 and all(seen[:61]) and not any(seen[61:])


def test_two_erosion_engines_for_one_solver_are_refused():
    mpm, er = pulled_plate()
    O.engines = [mpm, er, em.EigenErosion(engine=mpm, Gc=1.0, kappaOverH=1.1)]
    with pytest.raises(RuntimeError, match="one EigenErosion per MpmEngine in O.engines"):
        O.run(1, True)


def test_summary_and_tip_speed_figure_share_one_window():
    class Core:
        kappa, dissipatedEnergy, erodedCount = 0.001, 0.0, 3

        def events(self):
            return [(0, 1, 1e-6)]

    er = em.EigenErosion(Gc=1.0, kappa=0.001)
    er.core = Core()
    rng = np.random.default_rng(1)
    front = np.cumsum(rng.uniform(0, 2e-4, 60))  # a front advancing by uneven steps
    er.history = [(1e-7 * i, 0.0, 3, float(d), []) for i, d in enumerate(front)]
    t, v = er.tipSpeed()  # what crack_branching.py draws in tip_speed.png
    s = er.summary()
    assert er.tipSpeedWindow() == pytest.approx(5e-7) and s["tip_speed_window_us"] == pytest.approx(0.5)
    assert s["max_tip_speed_m_s"] == float(np.max(v))
    assert np.max(er.tipSpeed(window=1e-6)[1]) != s["max_tip_speed_m_s"]  # another window differs


def test_alpha_griffith_is_one_over_the_initiation_ratio_of_the_material():
    """EigenErosion(alpha='griffith'): 1 / initiationRatio for the engine's material (mode I,
    neighbourhood on the tip; pkg/ErosionCalibration.hpp), fixed when the stage is made; the
    same stage with a number keeps the number."""
    for planeStress, split in ((False, "spectral"), (True, "spectral"), (False, "volumetric")):
        mpm = em.MpmEngine(h=H, domain=((-0.05, -0.05, 0), (0.25, 0.1, 0)))
        mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.05, 0)),
                 em.ElasticMaterial(E=32e9, nu=0.2, rho=2450, planeStress=planeStress, split=split))
        er = em.EigenErosion(engine=mpm, Gc=3.0, alpha="Griffith", kappaOverH=1.1)
        r = em._eigenmpm.initiationRatio(2, 32e9, 0.2, planeStress, split)
        assert er.core.alpha == pytest.approx(1.0 / r, rel=1e-12)
        assert 5.0 < er.core.alpha < 6.5  # glass-like nu = 0.2: ratio 0.16-0.18
    # Plane strain, spectral, nu = 0.2: 0.168, i.e. alpha = 2 starts cracks at 1.72 x Griffith's stress.
    r = em._eigenmpm.initiationRatio(2, 32e9, 0.2, False, "spectral")
    assert r == pytest.approx(0.168, abs=0.002)
    assert em._eigenmpm.initiationRatio(3, 32e9, 0.2, False, "spectral") > r  # a ball around a front


def test_alpha_griffith_waits_for_the_material_and_refuses_mixed_materials():
    mpm = em.MpmEngine(h=H, domain=((-0.05, -0.05, 0), (0.25, 0.1, 0)))
    er = em.EigenErosion(engine=mpm, Gc=3.0, alpha="griffith", kappaOverH=1.1)
    assert er.core is None  # no material yet: made when the engine first acts
    with pytest.raises(ValueError, match="needs the material"):
        er.attach(mpm)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=32e9, nu=0.2, rho=2450))
    mpm.fill(pack.inAlignedBox((0.1, 0, 0), (0.2, 0.05, 0)), em.ElasticMaterial(E=32e9, nu=0.3, rho=2450))
    with pytest.raises(ValueError, match="one value per erosion stage"):
        er.attach(mpm)
    for bad in ("grifith", -1.0, float("nan"), True, None, "1.5"):
        with pytest.raises((TypeError, ValueError), match="alpha"):
            em.EigenErosion(engine=mpm, Gc=3.0, alpha=bad, kappaOverH=1.1)


class _Eroded:
    """Stand-ins for an MpmEngine and its erosion state that hold given eroded points, all eroded
    at time `now`: enough for EigenErosion's crack diagnostics."""

    def __init__(self, x, kappa, now=1e-6):
        self.x, self.kappa, self.now = np.asarray(x, float), kappa, now
        self.solver = self
        self.ranks = 1
        self.time = now

    def positions(self):
        return self.x

    def positionsAt(self, indices):
        return self.x[np.asarray(indices, dtype=np.int64)].reshape(-1, 3)

    def events(self):
        return [(i, 1, self.now) for i in range(len(self.x))]

    def eventPoints(self):
        return np.arange(len(self.x), dtype=np.int64)

    def eventTimes(self):
        return np.full(len(self.x), self.now)


def _throughThickness(branches, layers=16, h=0.5e-3):
    """Eroded points of a crack through a 3D plate 4 mm thick (along y, `layers` point layers
    h/2 apart) from (0.01, y, 0.02), one straight band per branch direction (unit x-z vectors),
    its front 38 point spacings from the start in every layer."""
    return np.array([(0.01 + d[0] * i * h / 2, (k + 0.5) * h / 2, 0.02 + d[1] * i * h / 2)
                     for d in branches for k in range(layers) for i in range(39)])


@pytest.mark.parametrize("branches", [[(1.0, 0.0)], [(0.8, 0.6), (0.8, -0.6)]])
def test_a_front_through_the_thickness_is_one_tip_per_branch_with_through_axis(branches):
    h = 0.5e-3
    x = _throughThickness(branches, h=h)
    fronts = {}
    for axis in (None, "y"):
        er = em.EigenErosion(Gc=1.0, kappa=1.1 * h, throughAxis=axis, origin=(0.01, 0.002, 0.02))
        fake = _Eroded(x, 1.1 * h)
        er.core, er._mpm = fake, fake
        fronts[axis] = (er.tips(), er.frontDistance())
    tips, front = fronts["y"]
    assert len(tips) == len(branches)
    for t in tips:
        assert t[1] == 0.0
        assert math.hypot(t[0] - 0.01, t[2] - 0.02) == pytest.approx(38 * h / 2)
    assert front == pytest.approx(38 * h / 2, rel=1e-12)
    # In 3D distances from the origin at mid-thickness, a face's points lie farther than the
    # points inside at the same front: each face, more than 6 kappa from the other, has its own
    # tip (a branching that is not), and the front distance takes in the offset.
    assert len(fronts[None][0]) > len(branches)
    assert fronts[None][1] > front


def test_through_axis_is_refused_in_2d_and_checked():
    mpm = em.MpmEngine(h=H)
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.2, rho=1000))
    with pytest.raises(ValueError, match=r"throughAxis = 'z' is invalid for the 2D MpmEngine .* allowed: None in 2D"):
        em.EigenErosion(engine=mpm, Gc=10.0, kappaOverH=1.1, throughAxis="z")
    with pytest.raises(ValueError, match="throughAxis = 'w' is invalid; allowed: 'x', 'y' or 'z'"):
        em.EigenErosion(Gc=10.0, kappaOverH=1.1, throughAxis="w")
    assert em.EigenErosion(Gc=10.0, kappaOverH=1.1, throughAxis="Y").throughAxis == "y"


def test_front_profile_gives_each_layer_its_front():
    """A front tunnelling through a 4 mm plate: the layers inside lead the faces."""
    h = 0.5e-3
    lead = [30, 32, 34, 36, 38, 38, 38, 38, 38, 38, 38, 38, 36, 34, 32, 30]
    x = np.array([(0.01 + i * h / 2, (k + 0.5) * h / 2 + 1e-9 * i, 0.02) for k in range(16) for i in range(lead[k] + 1)])
    er = em.EigenErosion(Gc=1.0, kappa=1.1 * h, throughAxis="y", origin=(0.01, 0.002, 0.02))
    fake = _Eroded(x, 1.1 * h)
    fake.h, fake.ppc = h, 2
    er.core, er._mpm = fake, fake
    along, front = er.frontProfile()
    assert along == pytest.approx([(k + 0.5) * h / 2 for k in range(16)], abs=1e-7)
    assert front == pytest.approx([n * h / 2 for n in lead], rel=1e-12)
    assert er.frontDistance() == pytest.approx(38 * h / 2, rel=1e-12)
    with pytest.raises(ValueError, match="frontProfile needs throughAxis"):
        em.EigenErosion(Gc=1.0, kappa=1.1 * h).frontProfile(fake)


# --- the crack diagnostics against their plain forms ----------------------------------------------
def _plainLinked(x, seed, radius):
    """The flood fill that linked() replaced: one k-d tree ball query per reached point."""
    from scipy.spatial import cKDTree
    tree = cKDTree(x)
    seen = np.zeros(len(x), bool)
    seen[seed] = True
    todo = [seed]
    while todo:
        for j in tree.query_ball_point(x[todo.pop()], radius):
            if not seen[j]:
                seen[j] = True
                todo.append(j)
    return seen


def _plainMainCrack(x, origin, R):
    """The breadth-first search over the occupied cells of size R that _mainCrack replaced."""
    cell = np.floor(x / R).astype(np.int64)
    occupied = {tuple(c) for c in cell}
    start = tuple(cell[np.argmin(np.sum((x - origin) ** 2, axis=1))])
    reached, stack = {start}, [start]
    offsets = list(np.ndindex(3, 3, 3))
    while stack:
        c = stack.pop()
        for o in offsets:
            n = (c[0] + o[0] - 1, c[1] + o[1] - 1, c[2] + o[2] - 1)
            if n in occupied and n not in reached:
                reached.add(n)
                stack.append(n)
    return np.array([tuple(c) in reached for c in cell])


def _plainTips(x, times, now, window, origin, main, R2):
    """The loop that tips() replaced: every main-crack point tested against each recent one."""
    recent = main & (times >= now - window)
    if not np.any(recent):
        return []
    xm, xr = x[main], x[recent]
    r = np.sum((xm - origin) ** 2, axis=1)
    rr = np.sum((xr - origin) ** 2, axis=1)
    tips = []
    for k in np.argsort(-rr, kind="stable"):
        p = xr[k]
        near = np.sum((xm - p) ** 2, axis=1) <= R2
        if np.any(r[near] > rr[k]):
            continue
        if all(np.sum((p - t) ** 2) > R2 for t in tips):
            tips.append(p.copy())
    return tips


def _randomCrack(rng, dim, s, R):
    """Eroded points on a lattice of spacing s: a branching band from (0, 0), each branch perhaps
    continued after a gap of about R (the tip radius), stray clusters and scattered points, some
    of them exactly a lattice step from the next (borderline distances)."""
    pts = []
    for d in ([1.0, 0.0], [0.8, 0.6], [0.8, -0.6])[: rng.integers(1, 4)]:
        n = int(rng.integers(20, 120))
        steps = list(range(n))
        if rng.uniform() < 0.6:  # a second piece beyond a gap of 0.85 R to 1.15 R
            gap = int(round(rng.uniform(0.85, 1.15) * R / s))
            steps += list(range(n - 1 + gap, n - 1 + gap + int(rng.integers(1, 10))))
        for i in steps:
            for w in range(rng.integers(1, 4)):
                pts.append([i * s * d[0] + w * s * d[1], i * s * d[1] - w * s * d[0], 0.0])
    for _ in range(rng.integers(0, 4)):  # stray clusters
        c = rng.uniform(-60 * s, 60 * s, 3)
        pts += [list(c + s * np.array([i, j, 0])) for i in range(3) for j in range(3)]
    x = np.array(pts)
    if dim == 3:  # layers through a thickness
        x = np.concatenate([x + [0, 0, k * s] for k in range(rng.integers(1, 9))])
        x = x[:, [0, 2, 1]]
    else:
        x[:, 2] = 0.0
    x[:, :dim] += rng.normal(0.0, 0.05 * s, (len(x), dim)) * (rng.uniform(size=(len(x), 1)) < 0.5)
    return x


def test_a_farther_neighbour_exactly_R_away_takes_the_tip():
    """The tips' test is |x_j - x_i|^2 <= R^2, R = 6 kappa, at the threshold too: a recent point
    whose only farther eroded point lies exactly R away is no tip; a hair farther, it is one
    (numbers exact in binary)."""
    kappa = 0.125  # R = 0.75
    x = np.array([[1.0, 0.0, 0.0], [1.75, 0.0, 0.0]])
    fake = _Eroded(x, kappa, now=1e-6)
    fake.eventTimes = lambda: np.array([1e-6, 0.0])  # the farther point is old: never a tip itself
    er = em.EigenErosion(Gc=1.0, kappa=kappa, tipWindow=3e-7, origin=(0.0, 0.0, 0.0))
    er.core, er._mpm = fake, fake
    assert er.tips() == []
    fake.x = np.array([[1.0, 0.0, 0.0], [1.7501, 0.0, 0.0]])
    assert [t.tolist() for t in er.tips()] == [[1.0, 0.0, 0.0]]


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("dim,axis", [(2, None), (3, None), (3, "y")])
def test_crack_diagnostics_are_those_of_their_plain_forms(dim, axis, seed):
    """_mainCrack (the C++ flood fill over the occupied cells), tips() (the C++ search for a
    farther neighbour within R) and linked() (components of the pairs within a radius) give
    exactly what the plain searches they replaced give, on 40 random cracks each (branches,
    strays, layers, borderline spacings)."""
    rng = np.random.default_rng(7 + dim + 100 * seed)
    s = 0.25e-3
    kappa = 2.2 * s
    R = 6.0 * kappa
    for trial in range(40):
        x = _randomCrack(rng, dim, s, R)
        now = 1e-6
        times = now - rng.uniform(0.0, 2e-7, len(x)) * (rng.uniform(size=len(x)) < 0.3) - 1e-6 * (
            rng.uniform(size=len(x)) >= 0.3)
        fake = _Eroded(x, kappa, now)
        fake.eventTimes = lambda t=times: t
        er = em.EigenErosion(Gc=1.0, kappa=kappa, throughAxis=axis, tipWindow=3e-7,
                             origin=(0.0, 0.0, 0.0))
        er.core, er._mpm = fake, fake
        xp = er._inPlane(x)
        origin = np.zeros(3)
        main = er._mainCrack(xp, origin)
        assert np.array_equal(main, _plainMainCrack(xp, origin, R)), trial
        tips = er.tips()
        plain = _plainTips(xp, times, now, 3e-7, origin, main, R ** 2)
        assert len(tips) == len(plain) and all(np.array_equal(a, b) for a, b in zip(tips, plain)), trial
        assert er.frontDistance() == float(np.sqrt(np.max(np.sum((xp[main] - origin) ** 2, axis=1))))
        for radius in (s, 2 * kappa):  # s: the lattice neighbours exactly at the radius
            seed = int(rng.integers(len(x)))
            assert np.array_equal(em.fracture.linked(xp[:, :dim], seed, radius),
                                  _plainLinked(xp[:, :dim], seed, radius)), trial


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_crack_searches_far_from_the_rest_are_those_of_their_plain_forms(seed):
    """The searches find their cells through a table over the points' box of cells, or through
    a hash map when that box is far larger than the points (a point flung far off, a long
    diagonal crack in 3D): both give the plain forms' answers. Here points on a diagonal and a far
    cluster make the box huge, and the farther-neighbour search gets candidates on both sides."""
    rng = np.random.default_rng(11 + seed)
    s = 0.25e-3
    R = 6.0 * 2.2 * s
    diagonal = np.array([[i, i, i] for i in range(300)], float) * (0.4 * R)  # neighbours 0.69 R apart
    far = 1e4 * R + rng.uniform(-2 * R, 2 * R, (30, 3))
    x = np.concatenate([diagonal, far, rng.uniform(-3 * R, 3 * R, (40, 3))])
    origin = np.zeros(3)
    from eigenmpm import _eigenmpm
    main, xm, r = _eigenmpm.crackMain(x, origin, R)
    assert np.array_equal(main, _plainMainCrack(x, origin, R))
    assert np.array_equal(xm, x[main]) and np.array_equal(r, np.sum((x[main] - origin) ** 2, axis=1))
    rall = np.sum((x - origin) ** 2, axis=1)
    pick = rng.choice(len(x), 25, replace=False)
    got = _eigenmpm.crackFartherWithin(x, rall, x[pick], rall[pick], R, R * R)
    plain = [np.any((rall > rall[k]) & (np.sum((x - x[k]) ** 2, axis=1) <= R * R)) for k in pick]
    assert got.tolist() == plain and any(plain) and not all(plain)


def _notched_3d_plate():
    """notched_plate through a thickness of three cells (3D)."""
    h = 0.004
    plate = pack.inAlignedBox((0, 0, 0), (0.1, 0.04, 0.012)) - pack.inAlignedBox((-1, 0.019, -1), (0.03, 0.021, 1))
    mpm = em.MpmEngine(dim=3, h=h)
    mpm.fill(plate, em.ElasticMaterial(E=72e9, nu=0.22, rho=2440))
    mpm.velocityBC(points=pack.inAlignedBox((-1, 0.038, -1), (1, 1, 1)), components="y", velocity=(0, 4.0, 0))
    mpm.velocityBC(points=pack.inAlignedBox((-1, -1, -1), (1, 0.002, 1)), components="y", velocity=(0, -4.0, 0))
    er = em.EigenErosion(engine=mpm, Gc=135.0, alpha=2.0, kappaOverH=1.1, iterPeriod=1, throughAxis="z",
                         tipWindow=5 * 0.5 * mpm.criticalTimeStep(), origin=(0.03, 0.02, 0.006))
    O.engines = [mpm, er]
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm, er


@pytest.mark.parametrize("dim", [2, 3])
def test_a_record_of_one_process_is_that_of_the_numpy_steps(dim):
    """record() in one process takes its front and tips from one C++ call (solver.crackRecord);
    under mpiexec it takes them from the numpy steps of _crack, _frontOf and _tipsOf. Both give
    the same numbers, bit for bit, at every step of a growing crack: from its first eroded point
    (the origin taken from it, 2D) or a given origin, with one tip or several (a short tip window
    in 3D, the front through the thickness: throughAxis)."""
    O.reset()
    if dim == 2:
        mpm, er = notched_plate(1)
        er.tipWindow = 3 * O.dt
        steps = 200
    else:
        mpm, er = _notched_3d_plate()
        steps = 160
    compared, tipsSeen = 0, 0
    for _ in range(steps):
        O.run(1, True)
        fast = er._recordOfOneProcess(mpm, mpm.solver)
        crack = er._crack(mpm)
        slow = er._frontOf(crack), er._tipsOf(mpm, crack)
        assert fast[0] == slow[0] and type(fast[0]) is float
        assert len(fast[1]) == len(slow[1]) and all(np.array_equal(a, b) for a, b in zip(fast[1], slow[1]))
        compared += crack is not None
        tipsSeen = max(tipsSeen, len(slow[1]))
    assert compared > 20 and tipsSeen >= 2, (compared, tipsSeen)
    assert er.history[-1][3] == slow[0] and er.history[-1][4] == [t.tolist() for t in slow[1]]


def test_the_tips_merged_in_cpp_are_those_of_the_numpy_merge():
    """crackMergedTips (the record's merge in C++, crackfront::mergedTips) keeps the rows
    EigenErosion._mergedTips keeps, in the same order, bit for bit, on random recent points
    (clusters within and beyond R of each other, distances at R exactly, candidates at the same
    distance from the origin: of those the first row is taken first); with a NaN distance it
    declines (None) and the numpy merge runs."""
    rng = np.random.default_rng(11)
    R = 0.75
    R2 = R * R
    ties = 0
    for trial in range(300):
        n = int(rng.integers(0, 40))
        x = np.zeros((n, 3))
        x[:, :2] = np.round(rng.uniform(-3, 3, (n, 2)) * 4) / 4  # on a grid of 1/4: distances at R exactly
        if trial % 3 == 0:
            x[:, 2] = rng.uniform(-0.1, 0.1, n)
        rr = np.sum(x ** 2, axis=1)
        farther = rng.uniform(size=n) < 0.5
        merged = em._eigenmpm.crackMergedTips(x, rr, farther, R2)
        assert merged == [t.tolist() for t in em.EigenErosion._mergedTips(x, rr, farther, R2)], trial
        candidates = rr[~farther]
        ties += len(np.unique(candidates)) < len(candidates)
    assert ties > 50
    # two candidates at one distance on either side of the axis, within R: the first row is the tip
    x = np.array([[1.0, 0.25, 0.0], [1.0, -0.25, 0.0], [0.2, 0.0, 0.0]])
    rr = np.sum(x ** 2, axis=1)
    assert em._eigenmpm.crackMergedTips(x, rr, np.array([False, False, True]), R2) == [[1.0, 0.25, 0.0]]
    assert em._eigenmpm.crackMergedTips(x[[1, 0, 2]], rr[[1, 0, 2]], np.array([False, False, True]), R2) == [
        [1.0, -0.25, 0.0]]
    rr[0] = np.nan
    assert em._eigenmpm.crackMergedTips(x, rr, np.array([False, False, True]), R2) is None
