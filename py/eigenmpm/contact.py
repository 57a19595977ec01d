"""Contact between an MpmEngine's material points and YADE's own bodies (doc/contact.md).

``BodyContact`` makes spheres, walls, facets and boxes of ``O.bodies`` (and the clumps they
form) touch the continuum in the same ``O.run``: before each MPM step it hands the bodies'
positions and velocities to the solver's contact stage (``pkg/BodyContact.hpp``), which
exchanges impulses with the grid nodes after the forces (frictionless or Coulomb friction); after
the step it adds the opposite forces and their moments to ``O.forces``, so that YADE's
``NewtonIntegrator`` moves the bodies with them in the same iteration. The stage has no
stiffness: the critical time step is unchanged.
"""
import numpy as np
from yade import O, PyRunner, Vector3

from . import _eigenmpm
from . import engines as _engines
from .engines import ENGINE, _register, _Released, findEngine, mpmEngines
from .fracture import sameStage
from .params import Param, apply, declare

SHAPES = ("Sphere", "Wall", "Facet", "Box")
# The count of Python calls that change O.bodies' bodies, a body's state, shape or dynamic flag
# or a state's blocked DOFs (watchBodies): the spheres' objects and flags kept between steps
# (_eigenmpm.BodyCache) are read again after any.
_bodiesVersion = [0]
# The methods of O.bodies that erase, replace or regroup bodies (not append: a new body changes
# no other; not the read-only ones).
_BODY_CHANGES = ("clear", "erase", "replace", "insertAtId", "clump", "addToClump", "releaseFromClump",
                 "replaceByClumps", "deleteClumpMember", "deleteClumpBody", "updateClumpProperties")
_ZERO = (0.0, 0.0, 0.0)
_ZERO3 = (_ZERO, _ZERO, _ZERO)


def _newton():
    """The NewtonIntegrator of O.engines and its index, or (None, None)."""
    for i, e in enumerate(O.engines):
        if type(e).__name__ == "NewtonIntegrator":
            return i, e
    return None, None


def _bumpBodies():
    _bodiesVersion[0] += 1


def watchBodies():
    """Makes the methods of O.bodies that erase, replace or regroup bodies (_BODY_CHANGES), the
    setters of a body's state, shape and dynamic flag and of a state's blocked DOFs, and
    Serializable.updateAttrs (which can set them) raise _bodiesVersion, each wrapped once at class
    level (the package calls it at import)."""
    from yade.wrapper import Body, BodyContainer, Serializable, State

    for name in _BODY_CHANGES:
        _engines.watchMethod(BodyContainer, name, _bumpBodies)
    _engines.watchSetter(Body, "state", _bumpBodies)
    _engines.watchSetter(Body, "shape", _bumpBodies)
    _engines.watchSetter(Body, "dynamic", _bumpBodies)
    _engines.watchSetter(State, "blockedDOFs", _bumpBodies)
    _engines.watchMethod(Serializable, "updateAttrs", _bumpBodies)


def _quatMatrix(q):
    """Rotation matrix of a YADE Quaternion, as a numpy array."""
    m = q.toRotationMatrix()
    return np.array([[m[i, j] for j in range(3)] for i in range(3)])


@declare
class BodyContact(PyRunner):
    """Contact of an MpmEngine's points with YADE bodies (spheres, walls, facets, boxes, and the
    clumps they form), frictionless or with Coulomb friction; forces act both ways in the same
    step. The work happens inside the MpmEngine's step, while this engine is in O.engines; the
    MpmEngine must come after YADE's ForceResetter and before its NewtonIntegrator, so that the
    bodies get the contact forces in the same iteration.

    Example::

        mpm = em.MpmEngine(dim=2, h=1e-3, label='plate')
        ...
        ball = O.bodies.append(sphere((0, 0.02, 0), 0.005, material=steel))
        O.engines = [ForceResetter(), mpm, em.BodyContact(engine=mpm, friction=0.3),
                     NewtonIntegrator(damping=0, gravity=(0, -9.81, 0))]

    In 2D the points lie in the plane z = 0 and a body acts through its section by that plane (a
    sphere centred there as a disc of its radius); forces are those of the 2D model's thickness.
    """

    params = (
        Param("label", "contact", "", "YADE label of the engine; it prefixes the keys of plotData()"),
        Param(ENGINE.name, ENGINE.default, ENGINE.unit, ENGINE.doc, kind=ENGINE.kind, accepts=ENGINE.accepts,
              check=ENGINE.checker, fixed=True),
        Param("friction", 0.0, "", "Coulomb friction coefficient mu between the points and the bodies",
              bounds="[0, inf)", fixed=True),
        Param("bodies", None, "", "ids of the YADE bodies that touch the points (a clump's member "
                                  "ids, or the clump's id for all its members); default: every "
                                  "body of O.bodies with a Sphere, Wall, Facet or Box shape",
              kind="object", accepts="a list of body ids", check=lambda b: b is None or (
                  isinstance(b, (list, tuple, np.ndarray)) and all(isinstance(i, (int, np.integer)) for i in b))),
        Param("iterPeriod", 1, "iterations", "period of the force record (history)", bounds="[1, inf)"),
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "BodyContact")
        self.initRun = True
        self.command = _register(self)
        self.core = None
        self._mpm = None
        self._bodyIds = []  # YADE id of each core body, in core order (the dynamic body: a clump)
        self._selection = None  # (key, sphere ids, other ids) of the bodies that touch the points
        self._cache = None  # the spheres' YADE objects kept between steps (_eigenmpm.BodyCache)
        self._cleared = None  # (engines' version, MpmEngine id, whether a ForceResetter runs just before it)
        self.history = []  # (time, total force on the bodies (3), points in contact)

    # --- the stage --------------------------------------------------------------------------
    def attach(self, mpm=None):
        """Attaches the contact stage to `mpm`'s solver and loads the bodies' current state (the
        MpmEngine does it before each of its steps while this engine is in O.engines)."""
        mpm = findEngine(mpm if mpm is not None else self.engine)
        if getattr(self, "_released", False):
            self.core._fail()
        if self._mpm is not None and self._mpm is not mpm:
            raise ValueError(f"EigenMPM: BodyContact {self.label!r} was built for MpmEngine {self._mpm.label!r}, "
                             f"not {mpm.label!r}; build one per engine")
        self._checkOrder(mpm)
        if self.core is None:
            self.core = (_eigenmpm.Contact2 if mpm.dim == 2 else _eigenmpm.Contact3)(friction=self.friction)
            self._mpm = mpm
        attached = mpm.solver.contact
        if not sameStage(attached, self.core):
            if attached is not None:
                raise ValueError(f"EigenMPM: BodyContact {self.label!r} cannot act on MpmEngine {mpm.label!r}: "
                                 "another BodyContact already does; allowed: one BodyContact per MpmEngine "
                                 "(list all the bodies in it)")
            mpm.solver.setContact(self.core)
        mpm.physics[self.label] = self
        self._load(mpm)
        return mpm

    def beforeStep(self, mpm):
        """Loads the bodies' current state (called by the MpmEngine before each of its steps
        while the stage stays attached)."""
        self._load(mpm)

    def detach(self, mpm):
        if sameStage(mpm.solver.contact, self.core):
            mpm.solver.setContact(None)
        for label, e in list(mpm.physics.items()):
            if e is self:
                del mpm.physics[label]

    def afterStep(self, mpm):
        """Adds the last step's contact forces and moments to O.forces (called by the MpmEngine
        after its step)."""
        self.core.applyForces(O.forces)

    def _restored(self):
        """After eigenmpm.state restored this engine: what it kept of this process's objects
        (YADE's spheres, the engines' count, the MpmEngine's id) is read again."""
        self._cache = self._cleared = None

    def _release(self):
        self.core = _Released(f"the contact stage of BodyContact {self.label!r}")
        self._mpm, self._bodyIds, self.history, self._released = None, [], [], True
        self._cache = self._cleared = None

    def _checkOrder(self, mpm):
        engines = list(O.engines)
        where = next((i for i, e in enumerate(engines) if e is mpm), None)
        newton, _ = _newton()
        reset = next((i for i, e in enumerate(engines) if type(e).__name__ == "ForceResetter"), None)
        if where is None or newton is None or newton < where or (reset is not None and reset > where):
            raise ValueError(f"EigenMPM: O.engines order is invalid for BodyContact {self.label!r}: MpmEngine "
                             f"{mpm.label!r} must come after ForceResetter and before NewtonIntegrator, so "
                             "that the bodies receive the contact forces in the same iteration; allowed: "
                             "[ForceResetter(), ..., MpmEngine, ..., NewtonIntegrator()]")

    def _selected(self):
        """The ids of the bodies that touch the points, as (spheres that are no clump members,
        the others); cached until O.bodies changes length."""
        key = (len(O.bodies), None if self.bodies is None else tuple(self.bodies))
        if getattr(self, "_selection", None) is None or self._selection[0] != key:
            chosen = self._select()
            spheres = [b.id for b in chosen if type(b.shape).__name__ == "Sphere" and not b.isClumpMember]
            fast = set(spheres)
            self._selection = (key, spheres, [b.id for b in chosen if b.id not in fast])
        return self._selection[1], self._selection[2]

    def _select(self):
        if self.bodies is None:
            return [b for b in O.bodies if b is not None and b.shape is not None
                    and type(b.shape).__name__ in SHAPES]
        out = []
        for i in self.bodies:
            b = O.bodies[int(i)] if 0 <= int(i) < len(O.bodies) else None
            if b is None:
                raise ValueError(f"EigenMPM: bodies contains {i!r}, which is not a body of O.bodies (BodyContact)")
            if b.isClump:
                out.extend(O.bodies[m] for m in sorted(b.shape.members.keys()))
            elif type(b.shape).__name__ in SHAPES:
                out.append(b)
            else:
                raise ValueError(f"EigenMPM: body {i} has shape {type(b.shape).__name__}, which BodyContact cannot "
                                 f"touch; allowed: {', '.join(SHAPES)} (or a clump of them)")
        return out

    def _load(self, mpm):
        """Refills the stage with the selected bodies, each with the velocity it would have at
        the middle of the step without this contact (the leapfrog's v^{n+1/2}: its velocity plus
        O.dt times the forces already in O.forces and the NewtonIntegrator's gravity). YADE's
        Python API reads one body at a time; the common case (a free sphere) is read in C++
        (Contact.addFreeSpheres), the others here (doc/contact.md, "Cost"). Given mpm's solver,
        addFreeSpheres reads further and adds only the spheres that touch one of its points: the
        others receive no impulse in this step. It keeps the spheres' objects and flags from one
        step to the next while they provably stand (self._cache, _bodiesVersion) and reads no
        force when O.forces holds none (_forcesBefore; doc/contact.md, "Session 35")."""
        core, dt = self.core, O.dt
        core.clear()
        _, newton = _newton()
        gravity = Vector3(newton.gravity) if newton is not None else Vector3.Zero
        spheres, others = self._selected()
        if self._cache is None:
            self._cache = _eigenmpm.BodyCache()
        added, rest = core.addFreeSpheres(O.bodies, spheres, O.forces, gravity, dt, mpm.solver, self._cache,
                                          _bodiesVersion[0], self._forcesBefore(mpm))
        self._bodyIds = list(added)
        index = {}
        for i in list(rest) + others:
            b = O.bodies[i]
            if b is None:  # erased since the selection
                continue
            owner = O.bodies[b.clumpId] if b.isClumpMember else b
            k = index.get(owner.id)
            if k is None:
                k = index[owner.id] = self._addBody(owner, gravity, dt)
                self._bodyIds.append(owner.id)
            shape = b.shape
            kind = type(shape).__name__
            if kind == "Sphere":
                core.addSphere(k, b.state.pos, shape.radius)
            elif kind == "Wall":
                normal = [0.0, 0.0, 0.0]
                normal[shape.axis] = -1.0 if shape.sense < 0 else 1.0
                core.addWall(k, b.state.pos, normal, shape.sense == 0)
            elif kind == "Facet":
                pos, R = np.array(b.state.pos), _quatMatrix(b.state.ori)
                v = [pos + R @ np.array(x) for x in shape.vertices]
                core.addFacet(k, v[0], v[1], v[2])
            else:
                core.addBox(k, b.state.pos, shape.extents, _quatMatrix(b.state.ori))

    def _forcesBefore(self, mpm):
        """Whether O.forces may hold forces on the bodies when mpm steps: not when YADE's
        ForceResetter (alive) runs just before it and no permanent force is set (all zero then,
        as each step's velocity needs them: Contact.addFreeSpheres skips reading them)."""
        key = (_engines._enginesVersion[0], id(mpm))
        if self._cleared is None or self._cleared[0] != key:
            engines = list(O.engines)
            where = next((i for i, e in enumerate(engines) if e is mpm), 0)
            before = engines[where - 1] if where > 0 else None
            self._cleared = (key, type(before).__name__ == "ForceResetter" and not before.dead)
        return not self._cleared[1] or O.forces.getPermForceUsed()

    def _addBody(self, b, gravity, dt):
        s = b.state
        if not (b.dynamic and s.mass > 0):  # fixed or moved by kinematic engines: infinite mass
            return self.core.addBody(s.pos, s.vel, s.angVel, _ZERO, _ZERO3, b.id)
        blocked, inertia, m = s.blockedDOFs, s.inertia, s.mass
        if not blocked and not b.isClump and inertia[0] == inertia[1] == inertia[2] > 0:
            # Any body of isotropic inertia: no rotation of the inertia needed.
            i = 1.0 / inertia[0]
            vel = s.vel + (O.forces.f(b.id) / m + gravity) * dt
            angVel = s.angVel + O.forces.t(b.id) * (dt * i)
            return self.core.addBody(s.pos, vel, angVel, (1.0 / m, 1.0 / m, 1.0 / m),
                                     ((i, 0.0, 0.0), (0.0, i, 0.0), (0.0, 0.0, i)), b.id)
        free = np.array([c not in blocked for c in "xyz"], dtype=float)
        force, torque = self._forceOn(b)
        vel = np.array(s.vel) + dt * free * (force / m + np.array(gravity))
        R = _quatMatrix(s.ori)
        local = np.diag([1.0 / i if i > 0 else 0.0 for i in inertia])
        invInertia = R @ local @ R.T
        for k, c in enumerate("XYZ"):
            if c in blocked:
                invInertia[k, :] = 0
                invInertia[:, k] = 0
        angVel = np.array(s.angVel) + dt * invInertia @ torque
        return self.core.addBody(s.pos, vel, angVel, free / m, invInertia, b.id)

    @staticmethod
    def _forceOn(b):
        """Force and moment on body b already in O.forces (a clump: with its members')."""
        f, t = np.array(O.forces.f(b.id)), np.array(O.forces.t(b.id))
        if b.isClump:
            for m in b.shape.members.keys():
                fm = np.array(O.forces.f(m))
                f += fm
                t += np.array(O.forces.t(m)) + np.cross(np.array(O.bodies[m].state.pos) - np.array(b.state.pos), fm)
        return f, t

    # --- engine ------------------------------------------------------------------------------
    def _action(self):
        mpm = findEngine(self.engine)
        if not any(mpm is e for e in mpmEngines()):  # (O.engines read only after a change)
            raise ValueError(f"EigenMPM: engine = MpmEngine {mpm.label!r} is invalid; allowed: an MpmEngine in "
                             f"O.engines (BodyContact {self.label!r} acts only on an engine of the scene)")
        core = self.core
        if core is not None and O.iter % self.iterPeriod == 0:
            self.history.append((mpm.solver.time, core.totalForce, core.pointsInContact))

    # --- diagnostics -------------------------------------------------------------------------
    def force(self, bodyId):
        """Force of the points on YADE body `bodyId` (a clump for its members) in the last step, N."""
        if self.core is None or bodyId not in self._bodyIds:
            return np.zeros(3)
        return np.array(self.core.force(self._bodyIds.index(bodyId)))

    def totalForce(self):
        """Sum of the contact forces on all the bodies in the last step, N."""
        if self.core is None:
            return np.zeros(3)
        return np.array(self.core.totalForce)

    def pointsInContact(self):
        return self.core.pointsInContact if self.core is not None else 0

    def plotData(self):
        """'Fx', 'Fy'[, 'Fz']: the total contact force on the bodies (N); 'points': the points in
        contact."""
        dim = self._mpm.dim if self._mpm is not None else 3
        f = self.totalForce()
        d = {f"{self.label}_F{'xyz'[k]}": f[k] for k in range(dim)}
        d[f"{self.label}_points"] = self.pointsInContact()
        return d
