"""Parameters are declared once (eigenmpm.params.Param): the reference pages under doc/reference
are what the declarations give, help() shows them, and every declared parameter is validated by
its engine, method or function (the DEM comparison's too) from the declaration. The cases are
generated from the declarations themselves, so a new parameter is covered without editing this
file."""
import importlib.util
import math
import os

import numpy as np
import pytest
from yade import pack

import eigenmpm as em
from eigenmpm.params import Param, declared

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
_spec = importlib.util.spec_from_file_location("paramdoc", os.path.join(ROOT, "tools", "paramdoc.py"))
paramdoc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(paramdoc)

ENTRIES = paramdoc.documented()


def test_reference_pages_are_current():
    pages = paramdoc.pages()
    stale = [name for name, text in pages.items()
             if not os.path.exists(os.path.join(paramdoc.OUT, name))
             or open(os.path.join(paramdoc.OUT, name)).read() != text]
    orphans = sorted(set(f for f in os.listdir(paramdoc.OUT) if f.endswith(".md")) - set(pages))
    problems = [f"{name} differs from the declarations" for name in stale]
    problems += [f"{name} is declared by nothing (remove it)" for name in orphans]
    assert not problems, f"doc/reference is stale: {'; '.join(problems)}; run `make reference-doc` and commit"


def test_every_engine_and_material_has_a_page():
    names = {e.name for e in ENTRIES}
    assert {"MpmEngine", "EigenErosion", "ElasticMaterial", "VTKRecorder", "PlotRecorder", "Progress"} <= names
    assert {"velocityBC", "fix", "traction", "crack"} <= {n for n, _ in paramdoc.methods(em.MpmEngine)}


def test_the_dem_comparison_has_pages_and_reuses_the_mpm_declarations():
    from eigenmpm import dem
    names = {e.name for e in ENTRIES if e.group == "dem"}
    assert {"DemMpmPair", "calibrateDem", "uniaxialTension", "calibrateMeasured", "runToDisplacement"} <= names
    assert {"notch", "velocityBC", "fix", "setTimeStep", "summary"} <= {n for n, _ in paramdoc.methods(em.DemMpmPair)}
    # a constant of both models is one declaration, not a copy
    assert declared(em.DemMpmPair, "h") is declared(em.MpmEngine, "h")
    assert declared(em.DemMpmPair, "E") is declared(em.ElasticMaterial, "E") is declared(em.calibrateDem, "E")
    assert declared(em.DemMpmPair, "Gc") is declared(em.EigenErosion, "Gc")
    assert declared(em.DemMpmPair.velocityBC, "rampTime") is declared(em.MpmEngine.velocityBC, "rampTime")
    assert declared(em.DemMpmPair, "model").choices == dem.MODELS


# --- the cases, from the declarations -----------------------------------------------------------
def targets():
    """(class or function, method name or None, params, owner as the messages name it)."""
    for e in ENTRIES:
        yield e.obj, None, e.params, e.owner
        for name, m in paramdoc.methods(e):
            yield e.obj, name, m.params, f"{e.owner}.{name}"


# Where values sampled from the bounds make no object: a DEM pair needs E, ft, Gc and its radius
# to agree (the calibration rule refuses spheres too large for Gc). A required object parameter
# gets the first of OBJECTS its declaration accepts.
def _pair():
    return em.DemMpmPair(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), E=30e9, nu=0.2, rho=2400.0, Gc=100.0,
                         ft=3e6, h=0.01, radius=0.005, thickness=0.01, layers=1)


INSTANCES = {em.DemMpmPair: _pair}
OBJECTS = (lambda: [0], lambda: pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)),
           lambda: em.calibrateDem("cpm", 30e9, 0.2, 3e6, 100.0, 0.005), _pair)


def sample(p):
    """A value the declaration allows, for the required parameters around the one under test."""
    if not p.required:
        return p.default
    if p.choices is not None:
        return p.choices[0]
    if p.kind == "object":
        for make in OBJECTS:
            v = make()
            if p.checker(v):
                return v
        raise AssertionError(f"test_param_reference: no object in OBJECTS for {p.name} ({p.accepts})")
    if p.kind in ("float", "int"):
        lo, loIn, hi, hiIn = p.bounds
        v = (lo if loIn else lo + 1) if math.isfinite(lo) else (hi - 1 if math.isfinite(hi) else 1)
        return int(v) if p.kind == "int" else float(v)
    return {"vector": (1.0, 0.0, 0.0), "points": [(0.0, 0.0, 0.0), (0.01, 0.0, 0.0)], "str": "x",
            "bool": False}[p.kind]


def call(cls, method, params, **kw):
    """Builds cls or calls the function (or calls method of a cls built) with the required
    parameters sampled and kw on top."""
    given = {p.name: sample(p) for p in params if p.required and p.name not in kw}
    given.update(kw)
    if method is None:
        return cls(**given)
    obj = INSTANCES[cls]() if cls in INSTANCES else cls(**{p.name: sample(p) for p in cls.params if p.required})
    return getattr(obj, method)(**given)


def outside(p):
    """Values just beyond each finite end of the bounds."""
    lo, loIn, hi, hiIn = p.bounds
    step = (lambda x: 1) if p.kind == "int" else (lambda x: 1e-9 * max(1.0, abs(x)))
    out = []
    if math.isfinite(lo):
        out.append(lo - step(lo) if loIn else lo)
    if math.isfinite(hi):
        out.append(hi + step(hi) if hiIn else hi)
    return [int(v) if p.kind == "int" else float(v) for v in out]


def inside(p):
    """Values on or just inside each finite end of the bounds."""
    lo, loIn, hi, hiIn = p.bounds
    step = (lambda x: 1) if p.kind == "int" else (lambda x: 1e-9 * max(1.0, abs(x)))
    out = []
    if math.isfinite(lo):
        out.append(lo if loIn else lo + step(lo))
    if math.isfinite(hi):
        out.append(hi if hiIn else hi - step(hi))
    return [int(v) if p.kind == "int" else float(v) for v in out]


def refusals():
    """(target, param, bad value, expected exception) for every declared parameter."""
    cases = []
    for cls, method, params, owner in targets():
        for p in params:
            bad = []
            if p.kind in ("float", "int"):
                bad += [(v, ValueError) for v in (outside(p) if p.bounds else [])]
                bad += [("1", TypeError), (True, TypeError), (math.nan, ValueError), (math.inf, ValueError)]
                if p.kind == "int":
                    bad.append((sample(p) + 0.5 if p.required else (p.default or 1) + 0.5, ValueError))
            elif p.kind == "bool":
                bad += [(1, TypeError), ("yes", TypeError)]
            elif p.kind == "vector" and not p.function:
                bad += [((1.0,), ValueError), ("ab", TypeError), ((math.nan, 0.0), ValueError)]
            elif p.kind == "vector":
                bad += [((1.0,), ValueError), ("ab", TypeError)]
            elif p.kind == "points":
                bad += [([(0.0,)], ValueError), (3.5, TypeError)]
            elif p.kind == "box":
                bad += [(((0, 0), (1, 1), (2, 2)), TypeError), (((0, 0), (math.inf, 1)), ValueError)]
            elif p.kind == "object":
                bad.append((3.5, TypeError))
            elif p.kind == "str":
                bad.append((3, TypeError))
                if p.checker is not None and not p.checker(""):
                    bad.append(("", ValueError))
            if p.choices is not None:
                bad.append(("not-a-choice" if p.kind == "str" else max(p.choices) + 1, ValueError))
            if p.required:
                bad.append((None, TypeError))
            cases += [pytest.param(cls, method, params, owner, p, v, err, id=f"{owner}.{p.name}={v!r}")
                      for v, err in bad]
    return cases


@pytest.mark.parametrize("cls, method, params, owner, p, value, error", refusals())
def test_every_declared_parameter_refuses_what_its_declaration_does_not_allow(cls, method, params, owner, p,
                                                                           value, error):
    with pytest.raises(error) as err:
        call(cls, method, params, **{p.name: value})
    msg = str(err.value)
    assert msg.startswith(f"EigenMPM: {p.name} = "), msg
    assert f"is invalid; allowed: {p.allowed()}" in msg and f"({owner})" in msg, msg
    shown = repr(value.item() if hasattr(value, "item") else value)
    assert shown in msg, msg


@pytest.mark.parametrize("cls, method, params, owner", [pytest.param(*t, id=t[3]) for t in targets()])
def test_declared_bounds_admit_their_ends_and_numpy_scalars(cls, method, params, owner):
    for p in params:
        if p.default is not None:
            assert p.validate(p.default, owner) == p.default
        if p.kind in ("float", "int") and p.bounds:
            for v in inside(p):
                got = p.validate(v, owner)
                assert got == v and type(got) is (float if p.kind == "float" else int)
                wrapped = np.float64(v) if p.kind == "float" else np.int64(v)
                got = p.validate(wrapped, owner)
                assert got == v and type(got) is (float if p.kind == "float" else int), (p.name, type(got))
        if p.kind == "str" and p.choices:
            for c in p.choices:
                assert p.validate(c.swapcase(), owner) == c


@pytest.mark.parametrize("cls, method, params, owner", [pytest.param(*t, id=t[3]) for t in targets()])
def test_required_and_unknown_parameters_are_named(cls, method, params, owner):
    for p in params:
        if p.required:
            given = {q.name: sample(q) for q in params if q.required and q is not p}
            with pytest.raises(TypeError, match=rf"EigenMPM: {p.name} is required \({owner}\)"):
                call(cls, method, (), **given)
    with pytest.raises(TypeError, match=rf"unknown parameter\(s\) noSuchParameter \({owner}\)"):
        call(cls, method, params, noSuchParameter=1)


@pytest.mark.parametrize("cls, method, params, owner", [pytest.param(*t, id=t[3]) for t in targets()])
def test_help_shows_the_declarations(cls, method, params, owner):
    doc = (cls if method is None else getattr(cls, method)).__doc__
    for p in params:
        assert p.line() in doc, p.name


# --- what the declarations mean for the engines ---------------------------------------------------
def test_values_are_converted_to_plain_python_types():
    mpm = em.MpmEngine(h=np.float64(0.01), ppc=np.int64(3), shape="LINEAR", gravity=np.array([0.0, -9.81]),
                       massCutoff=np.float32(1e-12), threads=2.0)
    assert type(mpm.h) is float and type(mpm.ppc) is int and type(mpm.threads) is int
    assert mpm.shape == "linear" and mpm.gravity == (0.0, -9.81, 0.0)
    assert type(mpm.solver).__name__ == "Solver2Linear"
    mat = em.ElasticMaterial(E=np.int64(200_000_000_000), nu=np.float64(0.3), rho=7800, planeStress=np.bool_(True))
    assert type(mat.E) is float and type(mat.rho) is float and mat.planeStress is True
    assert repr(mat) == "ElasticMaterial(E=200000000000.0, nu=0.3, rho=7800.0, planeStress=True, split='spectral')"


@pytest.mark.parametrize("ppc", [2.7, 1.5, "2", True])
def test_points_per_cell_is_never_truncated(ppc):
    with pytest.raises((ValueError, TypeError), match=f"EigenMPM: ppc = {ppc!r} is invalid; allowed: integer"):
        em.MpmEngine(h=0.01, ppc=ppc)


def test_a_string_choice_with_a_default_declares_like_the_coming_split():
    split = Param("split", "spectral", "", "tension/compression split of the strain energy",
                  choices=("spectral", "volumetric", "none"))
    assert split.kind == "str" and split.default == "spectral"
    assert split.validate("Volumetric", "ElasticMaterial") == "volumetric"
    with pytest.raises(ValueError, match=r"EigenMPM: split = 'deviatoric' is invalid; allowed: 'spectral', "
                                         r"'volumetric' or 'none' \(any case\) \(ElasticMaterial\)"):
        split.validate("deviatoric", "ElasticMaterial")


@pytest.mark.parametrize("kw, problem", [
    (dict(default=0.0, bounds="(0, inf)"), "is invalid"),   # a default outside its own bounds
    (dict(default=1.0, bounds="0 < x"), "not an interval"),
    (dict(default=1.0, bounds="[2, 1]"), "empty"),
    (dict(default="a", bounds="(0, 1)"), "need kind float or int"),
    (dict(default=None), "give kind="),
    (dict(default=None, kind="object"), "needs check="),
    (dict(default=1.0, required=True), "has no default"),
])
def test_a_bad_declaration_fails_when_it_is_made(kw, problem):
    with pytest.raises(ValueError, match=problem):
        Param("x", doc="", unit="", **kw)
