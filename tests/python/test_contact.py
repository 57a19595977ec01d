"""Contact with YADE's bodies (eigenmpm.BodyContact, issue 16): the verification scripts' quick
modes against their closed forms, forces both ways in the same step (spheres, walls, facets,
boxes, clumps; 2D and 3D), the energy balance with the contact's work, save/load continuing
bitwise, and clear refusals."""
import json
import os
import subprocess

import numpy as np
import pytest
from yade import O, pack, utils
from yade.wrapper import Box, ForceEngine, ForceResetter, FrictMat, NewtonIntegrator, Sphere, State

import eigenmpm as em

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run_example(name, tmp_path, *args):
    script = os.path.join(ROOT, "examples", "verification", name + ".py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", script, "--out", str(tmp_path), *args], env=env,
                         capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return json.load(open(tmp_path / "summary.json"))


def test_sliding_block_decelerates_at_mu_g(tmp_path):
    s = run_example("sliding_block", tmp_path, "--quick", "plot=0")
    # measured at h = 4 mm: 1.00001, stop 1.013 (fitted line: 1.000003), normal force 1.0024
    assert abs(s["deceleration_over_mu_g"] - 1) < 0.01
    assert abs(s["stop_time_over_closed_form"] - 1) < 0.03
    assert abs(s["stop_time_fit_over_closed_form"] - 1) < 0.01
    assert abs(s["mean_normal_force_over_weight"] - 1) < 0.03


def test_frictionless_block_keeps_sliding(tmp_path):
    s = run_example("sliding_block", tmp_path, "--quick", "plot=0", "mu=0")
    assert abs(s["deceleration_m_s2"]) < 1e-3 * 9.81
    assert s["stop_time_s"] is None


def test_sphere_impact_conserves_momentum_and_energy(tmp_path):
    s = run_example("sphere_impact", tmp_path, "--quick", "plot=0")
    assert s["momentum_change_rel"] < 1e-12  # the impulses are exchanged exactly
    assert abs(s["energy_change_rel"]) < 0.01  # measured -0.2 % at h = 1 mm (the quick mode)
    assert s["peak_force_N"] > 0 and s["contact_time_s"] > 0


def block2d(h=0.002, **kw):
    mpm = em.MpmEngine(dim=2, h=h, thickness=0.01, label="block",
                       domain=((-0.02, -0.02, 0), (0.06, 0.06, 0)), **kw)
    mpm.fill(pack.inAlignedBox((0, 0, -1), (0.04, 0.02, 1)), em.ElasticMaterial(E=1e7, nu=0.3, rho=1000))
    return mpm


def test_a_falling_clump_lands_on_the_block_and_pushes_it():
    mpm = block2d()
    steel = O.materials.append(FrictMat(density=7800, young=2e11))
    a = utils.sphere((0.015, 0.026, 0), 0.004, material=steel)
    b = utils.sphere((0.025, 0.026, 0), 0.004, material=steel)
    clump, members = O.bodies.appendClumped([a, b])
    O.bodies[clump].state.vel = (0, -2.0, 0)
    contact = em.BodyContact(engine=mpm)
    O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0)]
    O.dt = 0.4 * mpm.criticalTimeStep()
    p0 = O.bodies[clump].state.mass * np.array(O.bodies[clump].state.vel)[:2] + np.array(mpm.linearMomentum())[:2]
    for _ in range(300):
        O.run(1, True)
        assert O.bodies[clump].state.pos[1] - 0.004 > 0.02 - 0.002  # never deep into the block
    # The clump was stopped (by the forces on the clump itself), the block took its momentum.
    assert O.bodies[clump].state.vel[1] > -1.0
    assert mpm.linearMomentum()[1] < -0.1 * abs(p0[1])
    p = O.bodies[clump].state.mass * np.array(O.bodies[clump].state.vel)[:2] + np.array(mpm.linearMomentum())[:2]
    assert np.allclose(p, p0, rtol=0, atol=1e-9 * abs(p0[1]))
    assert contact.history and max(abs(f[1]) for _, f, _ in contact.history) > 0


@pytest.mark.parametrize("shape", ["facet", "box", "wall"])
def test_each_shape_holds_a_block_under_gravity(shape):
    mpm = block2d(gravity=(0, -9.81, 0))
    # Each shape's top at y = 0, under the block's face.
    if shape == "facet":  # a triangle in the plane y = 0 crossing the plane z = 0
        body = O.bodies.append(utils.facet([(-0.05, 0, -1), (0.1, 0, -1), (0.02, 0, 1)], fixed=True))
    elif shape == "box":
        body = O.bodies.append(utils.box((0.02, -0.01, 0), (0.05, 0.01, 0.05), fixed=True))
    else:
        body = O.bodies.append(utils.wall((0, 0, 0), axis=1, sense=0))
    contact = em.BodyContact(engine=mpm)
    O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0)]
    O.dt = 0.4 * mpm.criticalTimeStep()
    O.run(2000, True)
    y = mpm.solver.positions()[:, 1]
    assert y.min() > 0  # resting on it, not through it
    weight = np.sum(mpm.solver.mass()) * 9.81
    forces = [f[1] for _, f, _ in contact.history[-500:]]
    assert abs(-np.mean(forces) / weight - 1) < 0.1
    assert abs(contact.force(body)[1]) > 0 or any(forces)


def test_a_sphere_bounces_off_a_3d_block():
    mpm = em.MpmEngine(dim=3, h=0.004, label="cube", domain=((-0.01, -0.01, -0.01), (0.03, 0.05, 0.03)))
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.02, 0.012, 0.02)), em.ElasticMaterial(E=1e7, nu=0.3, rho=1000))
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 0.0001, 1)))
    steel = O.materials.append(FrictMat(density=7800, young=2e11))
    ball = O.bodies.append(utils.sphere((0.01, 0.012 + 0.006, 0.01), 0.005, material=steel))
    O.bodies[ball].state.vel = (0, -1.0, 0)
    contact = em.BodyContact(engine=mpm, friction=0.2)
    O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0)]
    O.dt = 0.4 * mpm.criticalTimeStep()
    O.run(1500, True)
    assert O.bodies[ball].state.vel[1] > 0  # bounced
    assert O.bodies[ball].state.pos[1] > 0.012
    assert any(f[1] > 0 for _, f, _ in contact.history)  # the block pushed the ball up


def test_contact_work_enters_the_energy_balance():
    mpm = block2d()
    steel = O.materials.append(FrictMat(density=7800, young=2e11))
    ball = O.bodies.append(utils.sphere((0.02, 0.0265, 0), 0.006, material=steel))
    O.bodies[ball].state.vel = (0, -3.0, 0)
    O.engines = [ForceResetter(), mpm, em.BodyContact(engine=mpm), NewtonIntegrator(damping=0)]
    O.dt = 0.4 * mpm.criticalTimeStep()
    ek0 = 0.5 * O.bodies[ball].state.mass * 9.0
    O.run(400, True)
    b = mpm.energyBalance()
    ek = 0.5 * O.bodies[ball].state.mass * O.bodies[ball].state.vel.squaredNorm()
    assert b["Wext"] > 0.1 * ek0  # the sphere did work on the block
    assert abs(b["balance"]) < 0.02 * b["Wext"]  # the block's energy is that work
    assert abs((ek0 - ek) - b["Wext"]) < 0.05 * ek0  # what the sphere lost (time levels differ)


def test_save_and_load_continue_bitwise_with_contact():
    def scene():
        mpm = block2d(gravity=(0, -9.81, 0))
        O.bodies.append(utils.wall((0, 0, 0), axis=1, sense=1))
        steel = O.materials.append(FrictMat(density=7800, young=2e11))
        O.bodies.append(utils.sphere((0.02, 0.027, 0), 0.006, material=steel))
        O.bodies[1].state.vel = (0.5, -2.0, 0)
        O.engines = [ForceResetter(), mpm, em.BodyContact(engine=mpm, friction=0.4),
                     NewtonIntegrator(damping=0, gravity=(0, -9.81, 0))]
        O.dt = 0.4 * mpm.criticalTimeStep()
        return mpm

    def result():
        mpm = em.findEngine("block")
        return np.concatenate([mpm.solver.positions().ravel(), mpm.solver.velocities().ravel(),
                               np.array(O.bodies[1].state.pos), np.array(O.bodies[1].state.vel),
                               [mpm.externalWork()]])

    scene()
    O.run(300, True)
    straight = result()
    O.reset()
    scene()
    O.run(150, True)
    O.saveTmp("mid")
    O.run(50, True)
    O.loadTmp("mid")
    O.run(150, True)
    assert np.array_equal(result(), straight)


def test_wrong_engine_order_and_bad_input_are_refused():
    mpm = block2d()
    O.bodies.append(utils.wall((0, 0, 0), axis=1, sense=1))
    O.engines = [ForceResetter(), NewtonIntegrator(), mpm, em.BodyContact(engine=mpm)]
    O.dt = 0.4 * mpm.criticalTimeStep()
    with pytest.raises(Exception, match="before NewtonIntegrator"):
        O.run(1, True)
    with pytest.raises(ValueError, match="friction"):
        em.BodyContact(engine=mpm, friction=-0.1)
    O.reset()
    mpm = block2d()
    O.bodies.append(utils.wall((0, 0, 0), axis=1, sense=1))
    O.engines = [ForceResetter(), mpm, em.BodyContact(engine=mpm, bodies=[5]), NewtonIntegrator()]
    O.dt = 0.4 * mpm.criticalTimeStep()
    with pytest.raises(Exception, match="not a body of O.bodies"):
        O.run(1, True)


def cut_block(crackContact, friction=0.0):
    """Two halves of a block across a phantom-node crack, pushed together."""
    mpm = em.MpmEngine(dim=2, h=0.002, thickness=0.01, label="cut", crackContact=crackContact,
                       crackFriction=friction, domain=((-0.01, -0.01, 0), (0.05, 0.05, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, -1), (0.04, 0.02, 1)), em.ElasticMaterial(E=1e7, nu=0.3, rho=1000))
    mpm.crack([(-0.002, 0.0101, 0), (0.042, 0.0101, 0)])
    x = mpm.solver.positions()
    v = np.zeros_like(x)
    v[:, 1] = np.where(x[:, 1] > 0.0101, -2.0, 2.0)
    v[:, 0] = np.where(x[:, 1] > 0.0101, 1.0, -1.0)
    mpm.solver.setVelocities(np.ascontiguousarray(v))
    O.engines = [mpm]
    O.dt = 0.4 * mpm.criticalTimeStep()
    return mpm, x[:, 1] > 0.0101


@pytest.mark.parametrize("contact", [False, True])
def test_crack_faces_touch_with_crack_contact(contact):
    mpm, upper = cut_block(contact)
    gaps = []
    for _ in range(60):
        O.run(5, True)
        y = mpm.solver.positions()[:, 1]
        gaps.append(y[upper].min() - y[~upper].max())
    if contact:
        assert min(gaps) > 0  # the faces close but never cross
        assert mpm.solver.crackContactPairs >= 0
    else:
        assert min(gaps) < -0.001  # the paper's phantom nodes: the faces pass through


def test_crack_friction_slows_the_sliding_faces():
    slides = []
    for mu in (0.0, 0.5):
        O.reset()
        mpm, upper = cut_block(True, mu)
        O.run(200, True)
        v = mpm.solver.velocities()
        slides.append(np.mean(v[upper, 0]) - np.mean(v[~upper, 0]))
    assert slides[1] < slides[0] - 0.1  # friction takes relative sliding out


def test_crack_contact_survives_save_and_load():
    mpm, _ = cut_block(True, 0.2)
    O.run(50, True)
    O.saveTmp("c")
    O.run(50, True)
    straight = mpm.solver.positions().copy()
    O.loadTmp("c")
    mpm = em.findEngine("cut")
    assert mpm.crackContact and mpm.crackFriction == 0.2
    O.run(50, True)
    assert np.array_equal(mpm.solver.positions(), straight)


def test_hertz_impact_quick_is_near_hertz(tmp_path):
    s = run_example("hertz_impact", tmp_path, "--quick", "plot=0")
    # h = 1 mm (the contact radius is 1.3 h), measured: smoothed peak 1.28 x Hertz, contact time
    # 0.71 x, restitution 0.82, impulse 0.911 of 2 m v = (1 + e)/2 to 0.1 %. Finer runs converge
    # (doc/contact.md); here: the momentum bookkeeping and a loose bracket.
    assert abs(s["impulse_over_2mv"] - 0.5 * (1 + s["restitution"])) < 0.02
    assert 0.7 < s["restitution"] <= 1.0
    assert 0.8 < s["peak_force_smoothed_over_hertz"] < 1.5
    assert 0.6 < s["contact_time_over_hertz"] < 1.1


def test_a_box_moved_by_a_kinematic_engine_pushes_the_block():
    from yade.wrapper import TranslationEngine
    mpm = block2d()
    box = O.bodies.append(utils.box((-0.006, 0.01, 0), (0.005, 0.02, 0.05), fixed=True))
    push = TranslationEngine(ids=[box], translationAxis=(1, 0, 0), velocity=0.5)
    contact = em.BodyContact(engine=mpm)
    O.engines = [ForceResetter(), push, mpm, contact, NewtonIntegrator(damping=0)]
    O.dt = 0.4 * mpm.criticalTimeStep()
    for _ in range(15):
        O.run(100, True)
        face = O.bodies[box].state.pos[0] + 0.005
        assert mpm.solver.positions()[:, 0].min() > face - 1e-4  # the box's face never passes the points
    # A free elastic block struck by a piston moving at v leaves at up to 2 v (elastic): measured 0.9 m/s
    v = mpm.solver.velocities()
    assert 0.5 < np.mean(v[:, 0]) < 1.05
    assert contact.force(box)[0] < 0 or any(f[0] < 0 for _, f, _ in contact.history)


def test_impact_showcase_quick(tmp_path):
    script = os.path.join(ROOT, "examples", "impact.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", script, "--quick", "--out", str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    s = json.load(open(tmp_path / "summary.json"))
    assert s["eroded_count"] > 0 and s["notch_crack_length_mm"] > 5  # the beam cracks from its notch
    assert s["impactor_velocity_end_m_s"] > 0  # the sphere bounced off
    start, end = s["energy_start_J"]["total"], s["energy_end_J"]["total"]
    # both sides energies: measured -12 % (first touches, and Eq 33 booking less than erosion
    # releases with alpha = 2: doc/validation.md, propagation energy)
    assert 0.75 * start < end <= 1.01 * start
    import xml.etree.ElementTree as ET
    parts = {d.get("part") for d in ET.parse(tmp_path / "scene.pvd").getroot().iter("DataSet")}
    assert parts == {"0", "1"}  # the beam and YADE's spheres in one ParaView collection
    for name in ("damage.png", "energy.png", "energy.csv"):
        assert (tmp_path / name).exists(), name


@pytest.mark.parametrize("interface", ["bodies", "crack"])
def test_colliding_bars_exchange_their_velocities(tmp_path, interface):
    s = run_example("colliding_bars", tmp_path, "--quick", "plot=0", f"interface={interface}")
    # h = 2 mm measured, either interface: contact 1.019 x 2L/c, velocities after -0.942 / +0.942 v0,
    # energy -0.27 %
    assert abs(s["contact_time_over_2L_c"] - 1) < 0.03
    va, vb = s["velocity_after_over_v0"]
    assert va < -0.9 and vb > 0.9
    assert abs(s["energy_change_rel"]) < 0.01
    assert s["momentum_change_abs"] < 1e-12


@pytest.mark.parametrize("crackContact", [False, True])
def test_contact_results_do_not_depend_on_the_thread_count(crackContact):
    def run(threads):
        O.reset()
        mpm = em.MpmEngine(dim=2, h=0.002, thickness=0.01, label="block", threads=threads, crackContact=crackContact,
                           domain=((-0.02, -0.02, 0), (0.06, 0.06, 0)))
        mpm.fill(pack.inAlignedBox((0, 0, -1), (0.04, 0.02, 1)), em.ElasticMaterial(E=1e7, nu=0.3, rho=1000))
        mpm.crack([(0.02, -0.003, 0), (0.02, 0.01, 0)])
        steel = O.materials.append(FrictMat(density=7800, young=2e11))
        ball = O.bodies.append(utils.sphere((0.02, 0.0265, 0), 0.006, material=steel))
        O.bodies[ball].state.vel = (0.5, -3.0, 0)
        O.bodies.append(utils.wall((0, 0, 0), axis=1, sense=1))
        O.engines = [ForceResetter(), mpm, em.BodyContact(engine=mpm, friction=0.3), NewtonIntegrator(damping=0)]
        O.dt = 0.4 * mpm.criticalTimeStep()
        O.run(300, True)
        return np.concatenate([mpm.solver.positions().ravel(), mpm.solver.velocities().ravel(),
                               np.array(O.bodies[ball].state.vel)])
    assert np.array_equal(run(1), run(2))


def test_bodies_of_one_engine_touch_separate_and_restart_bitwise(tmp_path):
    """Two blocks of one MpmEngine filled with different body ids (issue 16 item 2): pressed
    together they bounce apart (no bonding, no interpenetration); the run saves and loads
    bitwise; bad body ids and a crack among bodies are refused."""
    def scene():
        O.reset()
        mpm = em.MpmEngine(dim=2, h=0.002, thickness=0.01, label="blocks", bodyFriction=0.2,
                           domain=((-0.02, -0.02, 0), (0.06, 0.06, 0)))
        mat = em.ElasticMaterial(E=1e7, nu=0.3, rho=1000)
        low = mpm.fill(pack.inAlignedBox((0, 0, -1), (0.04, 0.01, 1)), mat, velocity=(0, 2.0, 0))
        up = mpm.fill(pack.inAlignedBox((0, 0.01, -1), (0.04, 0.02, 1)), mat, velocity=(0, -2.0, 0), body=1)
        O.engines = [mpm]
        O.dt = 0.3 * mpm.criticalTimeStep()
        return mpm, low, up

    mpm, low, up = scene()
    assert mpm.solver.pointBody(int(up[0])) == 1 and mpm.solver.pointBody(int(low[0])) == 0
    O.run(100, True)
    f = str(tmp_path / "blocks.yade")
    O.save(f)
    O.run(300, True)
    x, v = mpm.solver.positions().copy(), mpm.solver.velocities().copy()
    assert v[up, 1].mean() > 1.0 and v[low, 1].mean() < -1.0  # bounced apart
    assert x[up, 1].min() > x[low, 1].max()                    # never through each other
    assert mpm.solver.bodyContactPairs == 0
    O.load(f)
    mpm = em.findEngine("blocks")
    O.run(300, True)
    assert np.array_equal(mpm.solver.positions(), x) and np.array_equal(mpm.solver.velocities(), v)

    mpm, _, _ = scene()
    with pytest.raises(ValueError, match="body = 64 is invalid"):
        mpm.fill(pack.inAlignedBox((0, 0.03, -1), (0.01, 0.04, 1)), em.ElasticMaterial(E=1e7, nu=0.3, rho=1000), body=64)
    with pytest.raises(ValueError, match="crack"):
        mpm.crack([(0.02, -0.003, 0), (0.02, 0.01, 0)])


def spheres_on_a_block(n=24):
    """A fixed block with a row of spheres on its top (some touching, some a little apart) and
    spheres far above it; a clump, a fixed sphere and one with blocked DOFs among them."""
    O.reset()
    mpm = em.MpmEngine(dim=2, h=0.002, thickness=0.01, label="block", gravity=(0, -9.81, 0),
                       domain=((-0.02, -0.02, 0), (0.08, 0.08, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, -1), (0.06, 0.02, 1)), em.ElasticMaterial(E=1e7, nu=0.3, rho=1000))
    mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (2, 0.001, 1)), components="xy", label="base")
    steel = O.materials.append(FrictMat(density=7800, young=2e11))
    row = [O.bodies.append(utils.sphere((0.001 + 0.0024 * i, 0.0205 + 0.0006 + 0.0003 * (i % 3), 0),
                                        0.0006, material=steel)) for i in range(n)]
    far = [O.bodies.append(utils.sphere((0.005 * i, 0.06, 0), 0.001, material=steel)) for i in range(8)]
    O.bodies[row[3]].dynamic = False
    O.bodies[row[5]].state.blockedDOFs = "xZ"
    clump, _ = O.bodies.appendClumped([utils.sphere((0.03, 0.026, 0), 0.002, material=steel),
                                       utils.sphere((0.034, 0.026, 0), 0.002, material=steel)])
    O.bodies[clump].state.vel = (0, -1.0, 0)
    contact = em.BodyContact(engine=mpm, friction=0.3)
    O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0, gravity=(0, -9.81, 0))]
    O.dt = 0.4 * mpm.criticalTimeStep()
    return mpm, contact, row, far


def plainRead(plain):
    """Contact.addFreeSpheres as it reads YADE without shortcuts: every sphere in full (no solver
    to test which touch a point), its objects read again at every step (no BodyCache), the forces
    read from O.forces."""
    def read(core, bodies, ids, forces, gravity, dt, solver=None, cache=None, version=0, readForces=True):
        return plain(core, bodies, ids, forces, gravity, dt)
    return read


def test_spheres_that_touch_no_point_are_skipped_without_changing_the_results(monkeypatch):
    """Contact.addFreeSpheres reads the velocity, mass and forces only of the spheres that touch
    a point (doc/contact.md, "Cost"): the run is bitwise the one that reads every sphere, also
    when a script grows a sphere's radius in place, moves one, gives one a box shape, replaces one
    at its id, fixes and frees them, or changes a mass between steps."""
    def run(skip):
        mpm, contact, row, far = spheres_on_a_block()
        steel = O.bodies[row[0]].material
        out, read = [], []
        for step in range(90):
            if step == 30:
                O.bodies[far[2]].shape.radius = 0.045  # now reaches the block's top
                O.bodies[far[4]].state.pos = (0.02, 0.0208, 0)  # onto the block
            if step == 31:
                # In the step the radius grew, the sphere touched the block and felt its force.
                assert np.linalg.norm(contact.force(far[2])) > 0 and np.linalg.norm(contact.force(far[4])) > 0
            if step == 40:  # a shape without a radius now: the general path takes it
                O.bodies[far[6]].shape = Box(extents=(0.002, 0.001, 0.002))
                O.bodies[far[6]].state.pos = (0.045, 0.0209, 0)
            if step == 41:
                assert np.linalg.norm(contact.force(far[6])) > 0
            if step == 50:
                O.bodies[row[3]].dynamic = True
                O.bodies[row[7]].dynamic = False
                O.bodies[row[9]].state.mass *= 4
                O.bodies.erase(row[11])
                O.bodies.insertAtId(utils.sphere((0.0275, 0.0214, 0), 0.0012, material=steel), row[11])
            O.run(1, True)
            read.append(contact.core.numBodies)
            out.append(np.concatenate([contact.totalForce(), [contact.core.work, contact.pointsInContact()]]))
        states = [list(b.state.pos) + list(b.state.vel) + list(b.state.angVel) for b in O.bodies]
        return np.array(out), np.array(states), mpm.solver.positions().copy(), mpm.solver.velocities().copy(), read

    skipped = run(True)
    plain = em._eigenmpm.Contact2.addFreeSpheres
    monkeypatch.setattr(em._eigenmpm.Contact2, "addFreeSpheres", plainRead(plain))  # every sphere read
    every = run(False)
    for a, b in zip(skipped[:4], every[:4]):
        assert np.array_equal(a, b)
    assert np.abs(skipped[0][:, 1]).max() > 0 and np.abs(skipped[0][:, 3]).max() > 0  # forces, work
    # Skipping happened: fewer bodies in the stage than the plain read, from the second step on.
    assert all(s < e for s, e in zip(skipped[4][1:], every[4][1:]))


def test_the_spheres_kept_between_steps_follow_what_yade_changes(monkeypatch):
    """Contact.addFreeSpheres keeps each sphere's Body, State and Shape objects from one step to
    the next (BodyCache) and does not read O.forces while YADE's ForceResetter runs just before
    the MpmEngine (doc/contact.md, "Session 35"): the run is bitwise the plain read's, also when
    a sphere that touches the block is erased or given a new shape unseen by the count of
    O.bodies' changes (as YADE's C++ would: the reference counts see it), a script erases one or
    gives one a new State while keeping the old object (the count sees it, the reference counts do
    not), blocks one or fixes one (the count sees it: their flags are kept with their objects), or
    an engine adds forces before the MpmEngine."""
    held = []

    def run(cached):
        mpm, contact, row, far = spheres_on_a_block()
        for i in row:  # onto the block: they touch it from about step 25 to 65
            O.bodies[i].state.vel = (0, -3.0, 0)
        out = []
        for step in range(80):
            if step == 28 and cached:  # the free spheres' objects are kept (those made in Python)
                assert contact._cache.cached == len(contact._selected()[0])
                assert not contact._forcesBefore(mpm)
            if step == 30:
                assert row[9] in contact._bodyIds and row[12] in contact._bodyIds
                type(O.bodies).erase.__wrapped__(O.bodies, row[9])  # YADE's own erase
            if step == 35:
                held.append(O.bodies[row[12]])  # its object lives on, its count unchanged
                O.bodies.erase(row[12])
            if step == 45:
                assert row[16] in contact._bodyIds
                old = O.bodies[row[16]].state
                new = State()
                new.pos, new.vel, new.mass, new.inertia = old.pos, old.vel, old.mass, old.inertia
                O.bodies[row[16]].state = new
            if step == 50:
                assert row[14] in contact._bodyIds or row[19] in contact._bodyIds
                push = ForceEngine(ids=[row[14], row[19]], force=(0, -30.0, 0))
                O.engines = [O.engines[0], push] + list(O.engines[1:])
            if step == 51 and cached:
                assert contact._forcesBefore(mpm)
            if step == 55:  # a new shape, unseen by the count: the reference counts see it
                assert row[11] in contact._bodyIds
                type(O.bodies[row[11]]).shape.fset.__wrapped__(O.bodies[row[11]], Sphere(radius=0.0009))
            if step in (57, 59):  # the flags kept with the objects are read again after a counted change
                pushed = [i for i in row if O.bodies[i] is not None and O.bodies[i].dynamic
                          and not O.bodies[i].state.blockedDOFs and np.linalg.norm(contact.force(i)) > 0]
                assert pushed
                if step == 57:  # a kinematic impactor now (YADE zeroes its velocity as it fixes it)
                    O.bodies[pushed[0]].dynamic = False
                    O.bodies[pushed[0]].state.vel = (0, -3.0, 0)
                else:
                    O.bodies[pushed[0]].state.blockedDOFs = "y"
            O.run(1, True)
            out.append(np.concatenate([contact.totalForce(), [contact.core.work, contact.pointsInContact()]]))
        assert O.bodies[row[9]] is None and O.bodies[row[12]] is None
        states = [list(b.state.pos) + list(b.state.vel) for b in O.bodies if b is not None]
        return np.array(out), np.array(states), mpm.solver.positions().copy(), mpm.solver.velocities().copy()

    kept = run(True)
    monkeypatch.setattr(em._eigenmpm.Contact2, "addFreeSpheres", plainRead(em._eigenmpm.Contact2.addFreeSpheres))
    plain = run(False)
    for a, b in zip(kept, plain):
        assert np.array_equal(a, b)
    assert np.abs(kept[0][:, 1]).max() > 0


@pytest.mark.parametrize("dim", [2, 3])
def test_frictionless_spheres_are_central_and_agree_with_the_general_path(dim, monkeypatch):
    """Without friction a free sphere centred in the model is central (RigidBody::central): every
    impulse lies along a radius, so addFreeSpheres reads neither its spin nor its inertia nor its
    torque and applyForces writes no moment (doc/contact.md, "Cost"). Spinning spheres strike the
    block and keep their spin bit for bit; a 2D sphere centred off the plane z = 0 is not central
    (its forces act in the plane, off its centre) and gets a moment. The run agrees to round-off
    with the general path, which reads every sphere in full (BodyContact._addBody)."""
    def run():
        O.reset()
        if dim == 2:
            mpm = block2d()
            centres = [(0.008, 0.0265, 0), (0.02, 0.0265, 0), (0.032, 0.0265, 0.002)]
        else:
            mpm = em.MpmEngine(dim=3, h=0.004, label="cube", domain=((-0.01, -0.01, -0.01), (0.05, 0.05, 0.03)))
            mpm.fill(pack.inAlignedBox((0, 0, 0), (0.04, 0.012, 0.02)), em.ElasticMaterial(E=1e7, nu=0.3, rho=1000))
            centres = [(0.01, 0.0185, 0.01), (0.03, 0.0185, 0.01)]
        mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (1, 0.0001, 1)))
        steel = O.materials.append(FrictMat(density=7800, young=2e11))
        balls = [O.bodies.append(utils.sphere(c, 0.006, material=steel)) for c in centres]
        for k, b in enumerate(balls):
            O.bodies[b].state.vel = (0.3 * k, -2.0, 0)
            O.bodies[b].state.angVel = (10.0 * k, -20.0, 300.0 + 50 * k)
        contact = em.BodyContact(engine=mpm)
        O.engines = [ForceResetter(), mpm, contact, NewtonIntegrator(damping=0)]
        O.dt = 0.4 * mpm.criticalTimeStep()
        pushed = np.zeros(len(balls))
        for _ in range(150):
            O.run(1, True)
            pushed += [np.linalg.norm(contact.force(b)) for b in balls]
        assert all(pushed > 0)  # every sphere struck the block
        read.update(calls)
        states = np.array([list(O.bodies[b].state.pos) + list(O.bodies[b].state.vel) for b in balls])
        spins = np.array([list(O.bodies[b].state.angVel) for b in balls])
        return states, spins, mpm.solver.positions().copy(), mpm.solver.velocities().copy()

    # Count the reads of the spin, inertia and torque and the moments written (YADE's API).
    from yade.wrapper import ForceContainer, State
    calls, read = {"angVel": 0, "inertia": 0, "t": 0, "addT": 0}, {}

    def counted(name, kind):
        plain = (State if kind == "property" else ForceContainer).__dict__[name]

        def count():
            calls[name] += 1
        if kind == "property":
            return property(lambda st: (count(), plain.__get__(st))[1], plain.__set__)
        return lambda self, *a: (count(), plain(self, *a))[1]
    for name in ("angVel", "inertia"):
        monkeypatch.setattr(State, name, counted(name, "property"))
    for name in ("t", "addT"):
        monkeypatch.setattr(ForceContainer, name, counted(name, "method"))
    fast = run()
    monkeypatch.undo()
    # Only the off-plane sphere (2D) is read in full and gets moments; the NewtonIntegrator reads in
    # C++. (Its torque is not read: the ForceResetter runs just before the MpmEngine, so O.forces
    # holds none, BodyContact._forcesBefore.)
    if dim == 3:
        assert read == {"angVel": 0, "inertia": 0, "t": 0, "addT": 0}
    else:
        assert 0 < read["angVel"] <= 150 and read["t"] == 0 and 0 < read["addT"] <= 150
    initial = np.array([(10.0 * k, -20.0, 300.0 + 50 * k) for k in range(len(fast[1]))])
    central = slice(0, 2)  # in 2D the third sphere is centred off the plane
    assert np.array_equal(fast[1][central], initial[central])
    if dim == 2:
        assert np.abs(fast[1][2] - initial[2]).max() > 1e-3  # the off-plane sphere was turned
    monkeypatch.setattr(getattr(em._eigenmpm, f"Contact{dim}"), "addFreeSpheres",
                        lambda core, bodies, ids, forces, gravity, dt, *rest: ([], list(ids)))
    general = run()
    for a, b in ((fast[0], general[0]), (fast[2], general[2])):
        assert np.allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
    for a, b in ((fast[3], general[3]),):
        assert np.allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max())
    assert np.allclose(fast[1], general[1], rtol=0, atol=1e-9 * np.abs(general[1]).max())
