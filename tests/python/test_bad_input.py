"""Bad input, case by case. Each case is a constructor call, a method call, an assignment after
construction or a mistake in how a scene is put together, with the exception (or warning) it
must give and a fragment of its message: the parameter, the value and what is allowed. Every
case builds at most a small scene and runs a few steps, so the whole table takes seconds.
tests/python/test_param_reference.py adds the cases generated from the declarations."""
import math
import re

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em

BOX = pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0))
BOX3 = pack.inAlignedBox((0, 0, 0), (0.04, 0.04, 0.04))
FAR = pack.inAlignedBox((5, 5, -1), (6, 6, 1))


def mat(**kw):
    return em.ElasticMaterial(**{"E": 1e9, "nu": 0.2, "rho": 1000.0, **kw})


def engine(**kw):
    return em.MpmEngine(**{"h": 0.01, **kw})


def filled(**kw):
    mpm = engine(**kw)
    mpm.fill(BOX if mpm.dim == 2 else BOX3, mat())
    return mpm


def erosion(**kw):
    return em.EigenErosion(**{"Gc": 100.0, "kappaOverH": 1.1, **kw})


def run(engines, steps=2, dtFraction=0.5):
    O.engines = engines
    O.dt = dtFraction * em.criticalTimeStep()
    O.run(steps, True)


def assign(obj, name, value):
    setattr(obj, name, value)


def vtk(**kw):
    return em.VTKRecorder(**{"fileName": "/tmp/eigenmpm-bad-input-", "iterPeriod": 1000, **kw})


def twoErosions():
    mpm = filled()
    run([mpm, erosion(), erosion()])


def erosionForAnotherEngine():
    a, b = filled(label="a"), filled(label="b")
    run([b, erosion(engine=a)])


def defaultEngineAmongTwo():
    run([filled(label="a"), filled(label="b"), erosion()])


def usedAfterReset():
    mpm = filled()
    run([mpm])
    O.reset()
    mpm.kineticEnergy()


def crackOutside(dim=2):
    mpm = filled(dim=dim)
    if dim == 2:
        mpm.crack([(0.3, 0.3, 0), (0.4, 0.3, 0)])
    else:
        mpm.crack([(0.1, 0.1, 0.1), (0.2, 0.1, 0.1), (0.2, 0.2, 0.1)])
    run([mpm])


def crackAddedBeforeTheMaterial():
    mpm = engine()
    mpm.crack([(0.3, 0.3, 0), (0.4, 0.3, 0)])
    mpm.fill(BOX, mat())
    run([mpm])


def crackAddedWhileRunning():
    mpm = filled()
    run([mpm])
    mpm.crack([(0.3, 0.3, 0), (0.4, 0.3, 0)])


def velocityFunctionWithZ():
    mpm = filled()
    mpm.velocityBC(points=[0], velocity=lambda t: (0.0, 0.0, 1.0))
    run([mpm])


def velocityFunctionNaN():
    mpm = filled()
    mpm.velocityBC(points=[0], velocity=lambda t: (math.nan, 0.0))
    run([mpm])


def velocityFunctionNotAVector():
    mpm = filled()
    mpm.velocityBC(points=[0], velocity=lambda t: 3.0)
    run([mpm])


def duplicateConditionLabel():
    mpm = filled()
    mpm.fix(points=[0], label="load")
    mpm.velocityBC(points=[1], velocity=(1, 0), label="load")


def deadDtTooLarge():
    mpm = filled()
    run([mpm], dtFraction=1.5)


V = ValueError
T = TypeError
A = AttributeError
R = RuntimeError
W = UserWarning

# (id, what, exception or warning, message fragment)
CASES = [
    # --- MpmEngine(...) ----------------------------------------------------------------------
    ("engine h=0", lambda: engine(h=0.0), V, "h = 0.0 is invalid; allowed: h > 0 [m] (MpmEngine)"),
    ("engine h<0", lambda: engine(h=-0.01), V, "h = -0.01 is invalid; allowed: h > 0"),
    ("engine h=nan", lambda: engine(h=math.nan), V, "h = nan is invalid; allowed: h > 0"),
    ("engine h=inf", lambda: engine(h=math.inf), V, "h = inf is invalid; allowed: h > 0"),
    ("engine h=str", lambda: engine(h="0.01"), T, "h = '0.01' is invalid; allowed: h > 0"),
    ("engine h=None", lambda: engine(h=None), T, "h = None is invalid; allowed: h > 0"),
    ("engine h missing", lambda: em.MpmEngine(), T, "h is required (MpmEngine)"),
    ("engine ppc=2.7", lambda: engine(ppc=2.7), V, "ppc = 2.7 is invalid; allowed: integer, 1 <= ppc <= 64"),
    ("engine ppc=np2.5", lambda: engine(ppc=np.float64(2.5)), V, "ppc = 2.5 is invalid; allowed: integer"),
    ("engine ppc=0", lambda: engine(ppc=0), V, "ppc = 0 is invalid; allowed: integer, 1 <= ppc <= 64"),
    ("engine ppc=65", lambda: engine(ppc=65), V, "ppc = 65 is invalid; allowed: integer, 1 <= ppc <= 64"),
    ("engine ppc=str", lambda: engine(ppc="2"), T, "ppc = '2' is invalid"),
    ("engine ppc=True", lambda: engine(ppc=True), T, "ppc = True is invalid"),
    ("engine dim=4", lambda: engine(dim=4), V, "dim = 4 is invalid; allowed: 2 or 3"),
    ("engine dim=2.5", lambda: engine(dim=2.5), V, "dim = 2.5 is invalid; allowed: 2 or 3"),
    ("engine dim=str", lambda: engine(dim="3"), T, "dim = '3' is invalid; allowed: 2 or 3"),
    ("engine shape", lambda: engine(shape="quadratic"), V, "shape = 'quadratic' is invalid; allowed: 'linear' or"),
    ("engine shape=1", lambda: engine(shape=1), T, "shape = 1 is invalid"),
    ("engine transfer", lambda: engine(transfer="PIC"), V, "transfer = 'PIC' is invalid; allowed: 'FLIP' or 'APIC'"),
    ("engine stressUpdate", lambda: engine(stressUpdate="jaumann"), V,
     "stressUpdate = 'jaumann' is invalid; allowed: 'smallStrain' or 'corotational'"),
    ("engine APIC with linear", lambda: engine(shape="linear", transfer="APIC"), V,
     "transfer = 'APIC' with shape 'linear' is invalid; allowed: 'FLIP' with this shape"),
    ("engine thickness=0", lambda: engine(thickness=0.0), V, "thickness = 0.0 is invalid; allowed: thickness > 0"),
    ("engine thickness 3D", lambda: engine(dim=3, thickness=0.5), V,
     "thickness = 0.5 is invalid in 3D: it is the out-of-plane thickness of a 2D model"),
    ("engine gravity nan", lambda: engine(gravity=(0, math.nan)), V, "gravity = (0, nan) is invalid"),
    ("engine gravity str", lambda: engine(gravity="down"), T, "gravity = 'down' is invalid; allowed: vector"),
    ("engine gravity 1D", lambda: engine(gravity=(1.0,)), V, "gravity = (1.0,) is invalid; allowed: vector of 2 or 3"),
    ("engine gravity z in 2D", lambda: engine(gravity=(0, 0, -9.81)), V,
     "gravity = (0.0, 0.0, -9.81) is invalid in 2D: the z component does not apply"),
    ("engine domain 3 corners", lambda: engine(domain=((0, 0), (1, 1), (2, 2))), T,
     "domain = ((0, 0), (1, 1), (2, 2))"),
    ("engine domain inf", lambda: engine(domain=((0, 0), (math.inf, 1))), V, "domain = ((0, 0), (inf, 1)) is invalid"),
    ("engine domain reversed", lambda: engine(domain=((1, 1, 0), (0, 0, 0))), V,
     "domain extent in direction 0 = -1 is invalid; allowed: hi > lo"),
    ("engine padding=0", lambda: engine(padding=0), V, "padding = 0 is invalid; allowed: integer, padding >= 1"),
    ("engine padding=2.5", lambda: engine(padding=2.5), V, "padding = 2.5 is invalid; allowed: integer"),
    ("engine massCutoff=1", lambda: engine(massCutoff=1.0), V,
     "massCutoff = 1.0 is invalid; allowed: 0 <= massCutoff < 1"),
    ("engine massCutoff<0", lambda: engine(massCutoff=-0.1), V, "massCutoff = -0.1 is invalid"),
    ("engine threads=0", lambda: engine(threads=0), V, "threads = 0 is invalid; allowed: integer, threads >= 1"),
    ("engine threads=1.5", lambda: engine(threads=1.5), V, "threads = 1.5 is invalid; allowed: integer"),
    ("engine rebalance=0.5", lambda: engine(rebalance=0.5), V, "rebalance = 0.5 is invalid; allowed: "),
    ("engine rebalancePeriod=-1", lambda: engine(rebalancePeriod=-1), V, "rebalancePeriod = -1 is invalid; allowed: "),
    ("engine label=3", lambda: engine(label=3), T, "label = 3 is invalid; allowed: string"),
    ("engine unknown", lambda: engine(hh=2), T, "unknown parameter(s) hh (MpmEngine)"),
    # --- ElasticMaterial(...) ----------------------------------------------------------------
    ("material E=0", lambda: mat(E=0.0), V, "E = 0.0 is invalid; allowed: E > 0 [Pa] (ElasticMaterial)"),
    ("material E<0", lambda: mat(E=-5.0), V, "E = -5.0 is invalid; allowed: E > 0"),
    ("material E=nan", lambda: mat(E=math.nan), V, "E = nan is invalid; allowed: E > 0"),
    ("material E=str", lambda: mat(E="72e9"), T, "E = '72e9' is invalid; allowed: E > 0"),
    ("material E missing", lambda: em.ElasticMaterial(rho=1000), T, "E is required (ElasticMaterial)"),
    ("material E overflows", lambda: mat(E=1.7e308, nu=0.22), V,
     "E = 1.7e+308 is invalid with nu = 0.22: the P-wave modulus"),
    ("material c overflows", lambda: mat(E=1e10, rho=1e-300), V,
     "rho = 1e-300 is invalid with E = 10000000000.0 and nu = 0.2: the wave speed sqrt(M / rho) overflows"),
    ("material c underflows", lambda: mat(E=5e-324, nu=0.0, rho=1e10), V,
     "E = 5e-324 is invalid with rho = 10000000000.0: the wave speed sqrt(M / rho) is 0"),
    ("material nu=0.5", lambda: mat(nu=0.5), V, "nu = 0.5 is invalid; allowed: -1 < nu < 0.5"),
    ("material nu=-1", lambda: mat(nu=-1.0), V, "nu = -1.0 is invalid; allowed: -1 < nu < 0.5"),
    ("material nu=str", lambda: mat(nu="0.2"), T, "nu = '0.2' is invalid"),
    ("material rho=0", lambda: mat(rho=0.0), V, "rho = 0.0 is invalid; allowed: rho > 0 [kg/m3]"),
    ("material rho=inf", lambda: mat(rho=math.inf), V, "rho = inf is invalid; allowed: rho > 0"),
    ("material planeStress=1", lambda: mat(planeStress=1), T, "planeStress = 1 is invalid; allowed: True or False"),
    ("material planeStress=str", lambda: mat(planeStress="yes"), T, "planeStress = 'yes' is invalid"),
    ("material split", lambda: mat(split="deviatoric"), V, "split = 'deviatoric' is invalid; allowed:"),
    ("material split=0", lambda: mat(split=0), T, "split = 0 is invalid"),
    ("material unknown", lambda: mat(G=1e9), T, "unknown parameter(s) G (ElasticMaterial)"),
    # --- EigenErosion(...) -------------------------------------------------------------------
    ("erosion Gc=0", lambda: erosion(Gc=0.0), V, "Gc = 0.0 is invalid; allowed: Gc > 0 [J/m2] (EigenErosion)"),
    ("erosion Gc<0", lambda: erosion(Gc=-1.0), V, "Gc = -1.0 is invalid; allowed: Gc > 0"),
    ("erosion Gc=str", lambda: erosion(Gc="135"), T, "Gc = '135' is invalid; allowed: Gc > 0"),
    ("erosion Gc=nan", lambda: erosion(Gc=np.float64("nan")), V, "Gc = nan is invalid; allowed: Gc > 0"),
    ("erosion Gc missing", lambda: em.EigenErosion(kappa=0.01), T, "Gc is required (EigenErosion)"),
    ("erosion alpha=0", lambda: erosion(alpha=0.0), V, "alpha = 0.0 is invalid; allowed: alpha > 0"),
    ("erosion alpha=inf", lambda: erosion(alpha=math.inf), V, "alpha = inf is invalid"),
    ("erosion alpha='grifith'", lambda: erosion(alpha="grifith"), T,
     "alpha = 'grifith' is invalid; allowed: alpha > 0, or 'griffith'"),
    ("erosion kappa<0", lambda: erosion(kappaOverH=None, kappa=-0.01), V,
     "kappa = -0.01 is invalid; allowed: kappa > 0"),
    ("erosion kappa and kappaOverH", lambda: erosion(kappa=0.01), T, "give exactly one of kappa (m) or kappaOverH"),
    ("erosion neither kappa", lambda: erosion(kappaOverH=None), T, "give exactly one of kappa (m) or kappaOverH"),
    ("erosion kappaOverH=0", lambda: erosion(kappaOverH=0.0), V, "kappaOverH = 0.0 is invalid"),
    ("erosion origin nan", lambda: erosion(origin=(math.nan, 0)), V, "origin = (nan, 0) is invalid"),
    ("erosion origin 1D", lambda: erosion(origin=(1.0,)), V, "origin = (1.0,) is invalid"),
    ("erosion origin z in 2D", lambda: erosion(engine=filled(), origin=(0.05, 0.02, 0.01)), V,
     "origin = (0.05, 0.02, 0.01) is invalid in 2D"),
    ("erosion tipWindow=0", lambda: erosion(tipWindow=0.0), V, "tipWindow = 0.0 is invalid; allowed: tipWindow > 0"),
    ("erosion iterPeriod=0", lambda: erosion(iterPeriod=0), V, "iterPeriod = 0 is invalid; allowed: integer"),
    ("erosion iterPeriod=2.5", lambda: erosion(iterPeriod=2.5), V, "iterPeriod = 2.5 is invalid; allowed: integer"),
    ("erosion engine=3.5", lambda: erosion(engine=3.5), T,
     "engine = 3.5 is invalid; allowed: an MpmEngine or its label"),
    ("erosion label=None", lambda: erosion(label=None), T, "label = None is invalid; allowed: string"),
    ("erosion kappa below spacing", lambda: erosion(engine=filled(), kappaOverH=0.3), W, "only the point itself"),
    ("erosion kappa beyond Appendix A", lambda: erosion(engine=filled(), kappaOverH=2.5), W,
     "outside the range"),
    # --- recorders ---------------------------------------------------------------------------
    ("vtk no period", lambda: em.VTKRecorder(), V, "give iterPeriod or virtPeriod (> 0) (VTKRecorder)"),
    ("vtk fileName empty", lambda: vtk(fileName=""), V, "fileName = '' is invalid; allowed: non-empty string"),
    ("vtk iterPeriod<0", lambda: vtk(iterPeriod=-1), V, "iterPeriod = -1 is invalid"),
    ("vtk iterPeriod=1.5", lambda: vtk(iterPeriod=1.5), V, "iterPeriod = 1.5 is invalid; allowed: integer"),
    ("plot virtPeriod=nan", lambda: em.PlotRecorder(virtPeriod=math.nan), V, "virtPeriod = nan is invalid"),
    ("plot no period", lambda: em.PlotRecorder(), V, "give iterPeriod or virtPeriod (> 0) (PlotRecorder)"),
    ("progress no end", lambda: em.Progress(), V, "Progress needs endIter or endTime"),
    ("progress endIter=0", lambda: em.Progress(endIter=0), V, "endIter = 0 is invalid"),
    ("progress realPeriod=0", lambda: em.Progress(endIter=10, realPeriod=0.0), V, "realPeriod = 0.0 is invalid"),
    ("progress stream=3", lambda: em.Progress(endIter=10, stream=3), T, "stream = 3 is invalid"),
    # --- MpmEngine.fill / addPoints ----------------------------------------------------------
    ("fill material=str", lambda: engine().fill(BOX, "steel"), T,
     "material = 'steel' is invalid; allowed: an ElasticMaterial (MpmEngine.fill)"),
    ("fill material=None", lambda: engine().fill(BOX, None), T, "material = None is invalid"),
    ("fill velocity nan", lambda: engine().fill(BOX, mat(), velocity=(math.nan, 0, 0)), V,
     "velocity = (nan, 0, 0) is invalid"),
    ("fill velocity z in 2D", lambda: engine().fill(BOX, mat(), velocity=(0, 0, 1)), V,
     "velocity = (0.0, 0.0, 1.0) is invalid in 2D"),
    ("fill velocity str", lambda: engine().fill(BOX, mat(), velocity="up"), T, "velocity = 'up' is invalid"),
    ("fill predicate str", lambda: engine().fill("box", mat()), T, "is not a yade.pack predicate"),
    ("fill predicate empty", lambda: engine().fill(pack.inAlignedBox((0, 0, 0), (0.001, 0.001, 0)), mat()), V,
     "holds no lattice point at h = 0.01, ppc = 2"),
    ("fill planeStress in 3D", lambda: engine(dim=3).fill(BOX3, mat(planeStress=True)), V,
     "planeStress = True is invalid in 3D (MpmEngine 'mpm' has dim = 3)"),
    ("fill volume underflows", lambda: engine(h=1e-200).fill(BOX, mat()), V,
     "h = 1e-200 is invalid with ppc = 2, thickness = 1.0: the point volume"),
    ("fill dt would be 0", lambda: engine(h=1e-310).addPoints([(0, 0, 0)], mat(), 1e-6), V,
     "h = 1e-310 is invalid with this material (wave speed c = 1054.09 m/s): the critical time step h / c"),
    ("addPoints shape", lambda: engine().addPoints(np.zeros((3, 4)), mat(), 1e-6), V,
     "positions of shape (3, 4) is invalid; allowed: an n x 3 array (or n x 2)"),
    ("addPoints n x 2 in 3D", lambda: engine(dim=3).addPoints(np.zeros((3, 2)), mat(), 1e-6), V,
     "positions of shape (3, 2) is invalid; allowed: an n x 3 array of coordinates"),
    ("addPoints str", lambda: engine().addPoints("abc", mat(), 1e-6), T, "positions = 'abc' is invalid"),
    ("addPoints volumes count", lambda: engine().addPoints(np.zeros((3, 3)), mat(), [1e-6, 1e-6]), V,
     "volumes of shape (2,) is invalid; allowed: one volume or 3"),
    ("addPoints volume=0", lambda: engine().addPoints(np.zeros((3, 3)), mat(), 0.0), V,
     "volume of point 0 (m^dim) = 0 is invalid; allowed: volume > 0"),
    ("addPoints volume<0", lambda: engine().addPoints(np.zeros((3, 3)), mat(), -1e-6), V, "volume > 0"),
    ("addPoints position nan", lambda: engine().addPoints([(0, 0, 0), (math.nan, 0, 0)], mat(), 1e-6), V,
     "position of point 1 = non-finite is invalid"),
    ("addPoints velocities count", lambda: engine().addPoints(np.zeros((3, 3)), mat(), 1e-6, np.zeros((2, 3))), V,
     "velocities of shape (2, 3) is invalid; allowed: one vector or n x 3 with n = 3"),
    ("addPoints velocity z in 2D", lambda: engine().addPoints(np.zeros((3, 3)), mat(), 1e-6, (0, 0, 1)), V,
     "velocities with a non-zero z component are invalid in 2D"),
    ("addPoints mass overflows", lambda: engine().addPoints([(0, 0, 0)], mat(rho=1e10), 1e300), V,
     "the point mass overflows"),
    ("addPoints material", lambda: engine().addPoints([(0, 0, 0)], "steel", 1e-6), T,
     "material = 'steel' is invalid; allowed: an ElasticMaterial (MpmEngine.addPoints)"),
    # --- velocityBC / fix / traction ---------------------------------------------------------
    ("bc region and points", lambda: filled().velocityBC(region=BOX, points=[0]), V,
     "needs exactly one of region= or points="),
    ("bc neither", lambda: filled().fix(), V, "needs exactly one of region= or points="),
    ("bc components letter", lambda: filled().fix(points=[0], components="w"), V, "components = 'w' is invalid"),
    ("bc components empty", lambda: filled().fix(points=[0], components=""), V, "components = '' is invalid"),
    ("bc components z in 2D", lambda: filled().fix(points=[0], components="z"), V,
     "components = 'z' is invalid; allowed: letters of 'xy' in 2D"),
    ("bc velocity str", lambda: filled().velocityBC(points=[0], velocity="fast"), T, "velocity = 'fast' is invalid"),
    ("bc velocity z in 2D", lambda: filled().velocityBC(points=[0], velocity=(0, 0, 1)), V,
     "velocity = (0.0, 0.0, 1.0) is invalid in 2D"),
    ("bc rampTime<0", lambda: filled().velocityBC(points=[0], rampTime=-1.0), V, "rampTime = -1.0 is invalid"),
    ("bc selects nothing", lambda: filled().fix(points=FAR), V,
     "selects no point of MpmEngine 'mpm'; allowed: a selection holding one"),
    ("bc point id", lambda: filled().fix(points=[10 ** 6]), V, "point id = 1000000 is invalid"),
    ("bc ids float", lambda: filled().fix(points=[0.5]), T, "points = [0.5] is invalid"),
    ("bc region=3.5", lambda: filled().fix(region=3.5), T, "region = 3.5 is invalid"),
    ("bc duplicate label", duplicateConditionLabel, V,
     "label = 'load' is invalid; allowed: a label no other condition of MpmEngine 'mpm' has"),
    ("bc function z in 2D", velocityFunctionWithZ, R, "velocity(t) = (0.0, 0.0, 1.0) is invalid in 2D"),
    ("bc function nan", velocityFunctionNaN, R, "velocity(t) = (nan, 0.0, 0.0) at t = 0.0 s is invalid"),
    ("bc function scalar", velocityFunctionNotAVector, R, "velocity(t) must be a vector"),
    ("traction nan", lambda: filled().traction(points=BOX, traction=(0, math.nan)), V,
     "traction = (0, nan) is invalid"),
    ("traction missing", lambda: filled().traction(points=BOX), T, "traction is required (MpmEngine.traction)"),
    ("traction layer=0", lambda: filled().traction(points=BOX, traction=(0, 1), layer=0.0), V,
     "layer = 0.0 is invalid"),
    ("traction z in 2D", lambda: filled().traction(points=BOX, traction=(0, 0, 1)), V,
     "traction = (0.0, 0.0, 1.0) is invalid in 2D"),
    ("traction selects nothing", lambda: filled().traction(points=FAR, traction=(0, 1)), V,
     "traction selects no point"),
    # --- crack -------------------------------------------------------------------------------
    ("crack one vertex", lambda: filled().crack([(0, 0, 0)]), V, "crack 0 vertex count = 1 is invalid; allowed: >= 2"),
    ("crack str", lambda: filled().crack("ab"), T, "vertices = 'ab' is invalid"),
    ("crack nan", lambda: filled().crack([(0, 0), (math.nan, 1)]), V, "vertices = [(0, 0), (nan, 1)] is invalid"),
    ("crack 3D segment", lambda: filled(dim=3).crack([(0, 0, 0), (1, 0, 0)]), V,
     "crack 0 vertex count = 2 is invalid; allowed: >= 3 (a planar polygon)"),
    ("crack id", lambda: filled().crackVertices(5), V, "crack id = 5 is invalid"),
    ("crack cuts no material", crackOutside, W, "crack 0 with vertices [[0.3, 0.3], [0.4, 0.3]] cuts no material"),
    ("crack cuts no material 3D", lambda: crackOutside(dim=3), W, "cuts no material"),
    ("crack before the material", crackAddedBeforeTheMaterial, W, "cuts no material"),
    ("crack added while running", crackAddedWhileRunning, W, "crack 0 with vertices"),
    # --- assignments after construction ------------------------------------------------------
    ("set ppc", lambda: assign(engine(), "ppc", 2.7), A,
     "ppc = 2.7 cannot be assigned; ppc is fixed once the MpmEngine"),
    ("set h", lambda: assign(engine(), "h", 0.02), A, "h = 0.02 cannot be assigned; h is fixed"),
    ("set dim", lambda: assign(engine(), "dim", 3), A, "dim = 3 cannot be assigned"),
    ("set shape", lambda: assign(engine(), "shape", "linear"), A, "shape = 'linear' cannot be assigned"),
    ("set thickness", lambda: assign(engine(), "thickness", 2.0), A, "thickness = 2.0 cannot be assigned"),
    ("set domain", lambda: assign(engine(), "domain", ((0, 0), (1, 1))), A, "domain = ((0, 0), (1, 1)) cannot"),
    ("set padding", lambda: assign(engine(), "padding", 4), A, "padding = 4 cannot be assigned"),
    ("set massCutoff", lambda: assign(engine(), "massCutoff", 0.0), A, "massCutoff = 0.0 cannot be assigned"),
    ("set threads=0", lambda: assign(engine(), "threads", 0), V,
     "threads = 0 is invalid; allowed: integer, threads >= 1"),
    ("set threads=str", lambda: assign(engine(), "threads", "2"), T, "threads = '2' is invalid"),
    ("set gravity nan", lambda: assign(engine(), "gravity", (0, math.nan)), V, "gravity = (0, nan) is invalid"),
    ("set gravity z in 2D", lambda: assign(engine(), "gravity", (0, 0, 1)), V,
     "gravity = (0.0, 0.0, 1.0) is invalid in 2D"),
    ("set label=5", lambda: assign(engine(), "label", 5), T, "label = 5 is invalid; allowed: string"),
    ("set E", lambda: assign(mat(), "E", 2e9), A,
     "E = 2000000000.0 cannot be assigned; E is fixed once the ElasticMaterial"),
    ("set planeStress", lambda: assign(mat(), "planeStress", True), A, "planeStress = True cannot be assigned"),
    ("set Gc", lambda: assign(erosion(), "Gc", 200.0), A, "Gc = 200.0 cannot be assigned; Gc is fixed"),
    ("set kappaOverH", lambda: assign(erosion(), "kappaOverH", 1.5), A, "kappaOverH = 1.5 cannot be assigned"),
    ("set erosion iterPeriod=0", lambda: assign(erosion(), "iterPeriod", 0), V, "iterPeriod = 0 is invalid"),
    ("set erosion iterPeriod=2.5", lambda: assign(erosion(), "iterPeriod", 2.5), V, "iterPeriod = 2.5 is invalid"),
    ("set tipWindow<0", lambda: assign(erosion(), "tipWindow", -1.0), V, "tipWindow = -1.0 is invalid"),
    ("set vtk iterPeriod<0", lambda: assign(vtk(), "iterPeriod", -1), V, "iterPeriod = -1 is invalid"),
    ("set vtk fileName empty", lambda: assign(vtk(), "fileName", ""), V, "fileName = '' is invalid"),
    ("set progress realPeriod", lambda: assign(em.Progress(endIter=5), "realPeriod", 0), V,
     "realPeriod = 0 is invalid"),
    # --- the scene ---------------------------------------------------------------------------
    ("scene dt above critical", deadDtTooLarge, R, "s is above the critical time step; allowed: 0 < dt <="),
    ("scene two erosions", twoErosions, R, "cannot act on MpmEngine 'mpm': EigenErosion 'erosion' already does"),
    ("scene erosion for an engine elsewhere", erosionForAnotherEngine, R,
     "engine = MpmEngine 'a' is invalid; allowed: an MpmEngine in O.engines"),
    ("scene erosion without engine among two", defaultEngineAmongTwo, R, "2 MpmEngine(s) match None in O.engines"),
    ("scene erosion label unknown", lambda: run([filled(), erosion(engine="nosuch")]), R,
     "0 MpmEngine(s) match 'nosuch' in O.engines"),
    ("scene criticalTimeStep without engine", lambda: em.criticalTimeStep(), V, "no MpmEngine in O.engines"),
    ("scene engine used after reset", usedAfterReset, R, "the solver of MpmEngine 'mpm' was freed by O.reset()"),
]


def _param(case):
    name, what, error, fragment = case
    return pytest.param(what, error, fragment, id=name)


def _pattern(fragment):
    """The fragment as a regex in which a default label ('mpm', 'erosion') may carry the number
    that keeps it unique: engines of earlier tests stay alive in YADE, holding the plain one."""
    return re.sub(r"'(mpm|erosion)'", r"'\1\\d*'", re.escape(fragment))


@pytest.mark.parametrize("what, error, fragment", [_param(c) for c in CASES])
def test_bad_input(what, error, fragment):
    if issubclass(error, Warning):
        with pytest.warns(error, match=_pattern(fragment)):
            what()
    else:
        with pytest.raises(error, match=_pattern(fragment)):
            what()


def test_the_table_is_large_and_its_names_unique():
    names = [c[0] for c in CASES]
    assert len(names) >= 100 and len(set(names)) == len(names)


# --- what is accepted ------------------------------------------------------------------------------
def test_numpy_numbers_are_accepted_as_the_numbers_they_hold():
    mpm = em.MpmEngine(h=np.float32(0.01), ppc=np.int64(3), dim=np.int64(2), threads=np.float64(2.0))
    assert (mpm.h, mpm.ppc, mpm.dim, mpm.threads) == (float(np.float32(0.01)), 3, 2, 2)
    er = em.EigenErosion(Gc=np.int64(100), kappaOverH=np.float64(1.1), iterPeriod=np.int32(10))
    assert type(er.Gc) is float and er.Gc == 100.0 and er.iterPeriod == 10
    assert em.ElasticMaterial(E=np.int64(72_000_000_000), rho=np.float64(2440), planeStress=np.bool_(True)).E == 72e9


def test_parameters_that_act_while_running_can_be_assigned_and_are_converted():
    mpm = filled()
    mpm.threads = np.int64(1)
    mpm.gravity = (0, -9.81)
    assert mpm.threads == 1 and type(mpm.threads) is int
    assert mpm.gravity == (0.0, -9.81, 0.0) and tuple(mpm.solver.gravity) == (0.0, -9.81, 0.0)
    er = erosion(engine=mpm)
    er.iterPeriod, er.tipWindow, er.label = 5.0, 1e-6, "crack"
    assert er.iterPeriod == 5 and type(er.iterPeriod) is int and er.label == "crack"


def test_default_labels_are_unique_and_given_labels_are_kept():
    # Engines of earlier tests may stay alive in YADE and hold 'mpm', 'mpm1', ...: the labels are
    # compared with each other, not with fixed names.
    a, b, c = engine(), engine(), engine(label="plate")
    assert re.fullmatch(r"mpm\d*", a.label) and re.fullmatch(r"mpm\d+", b.label) and a.label != b.label
    assert c.label == "plate"
    first, second = (erosion().label for _ in range(2))
    assert first == second and re.fullmatch(r"erosion\d*", first)  # the first was freed at once
    e1, e2 = erosion(), erosion()
    assert e1.label == first and e2.label != e1.label and re.fullmatch(r"erosion\d+", e2.label)
    freed = b.label
    del b
    assert engine().label == freed  # freed with its engine
    O.engines = [a, c]
    taken = a.label
    O.reset()  # the engines of the scene are released: their labels are free again
    assert engine().label == taken


def test_a_crack_through_the_material_gives_no_warning():
    import warnings
    mpm = filled()
    mpm.crack([(-0.01, 0.025, 0), (0.05, 0.025, 0)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run([mpm])
