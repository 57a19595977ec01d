"""The two builds of the compiled module (eigenmpm/_isa.py): the x86-64-v2 one computes bitwise
what the baseline one does, and the package imports the one the processor runs."""
import os
import re
import subprocess

import pytest

import eigenmpm as em
from eigenmpm import _isa

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
V2 = _isa.processorLevel() == "x86-64-v2" and _isa._built("x86-64-v2")


def scenes(isa, threads, lanes="auto"):
    env = dict(os.environ, EIGENMPM_ISA=isa, EIGENMPM_LANES=lanes, OMP_NUM_THREADS=str(threads),
               PYTHONPATH=os.path.join(ROOT, "build", "python"))
    r = subprocess.run(["yade", "-n", "-j", str(threads), "-x", os.path.join(HERE, "isa_scenes.py")], env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    found = dict(re.findall(r"^SCENE (.+?): (\S+ eroded \d+ points \d+)$", r.stdout, re.M))
    assert len(found) == 6, r.stdout[-2000:]
    return found


@pytest.mark.skipif(not V2, reason="this processor or build has no x86-64-v2 module")
def test_the_x86_64_v2_module_computes_bitwise_what_the_baseline_module_does():
    """Six scenes (2D and 3D, uGIMP and linear, FLIP and APIC, small-strain and co-rotational
    updates, erosion that erodes part of each, a phantom-node crack): the sha256 of each solver's
    saved state after its steps is the same for the baseline module on one thread with the
    baseline's lane loops and the v2 module on two with the widest lanes the processor has (so
    this also checks the thread count and pkg/Lanes.hpp)."""
    base, v2 = scenes("x86-64", 1, "baseline"), scenes("x86-64-v2", 2)
    for name in base:
        print(f"[ measured ] {name}: {base[name]}")
        eroded = int(base[name].split()[2])
        assert 0 < eroded < int(base[name].split()[4]), f"{name}: the scene should erode part of its points"
    assert v2 == base


def test_the_package_imports_the_module_the_processor_runs():
    assert em.isa == _isa.choose()
    assert em._eigenmpm.__name__ == {"x86-64": "eigenmpm._eigenmpm", "x86-64-v2": "eigenmpm._eigenmpm_v2"}[em.isa]
    if "EIGENMPM_ISA" not in os.environ:
        assert em.isa == ("x86-64-v2" if V2 else "x86-64")


def test_the_choice_follows_the_processor_and_the_request():
    v2flags = _isa.V2_FLAGS | {"sse", "sse2"}
    assert _isa.processorLevel(v2flags, "x86_64") == "x86-64-v2"
    assert _isa.processorLevel(v2flags - {"sse4_2"}, "x86_64") == "x86-64"
    assert _isa.processorLevel(v2flags, "aarch64") == "x86-64"
    built = lambda level: True  # noqa: E731
    assert _isa.choose("auto", "x86-64-v2", built) == "x86-64-v2"
    assert _isa.choose("auto", "x86-64", built) == "x86-64"
    assert _isa.choose("auto", "x86-64-v2", lambda level: level == "x86-64") == "x86-64"
    assert _isa.choose("x86-64", "x86-64-v2", built) == "x86-64"
    with pytest.raises(ImportError, match="EIGENMPM_ISA=x86-64-v2 is invalid on this processor"):
        _isa.choose("x86-64-v2", "x86-64", built)
    with pytest.raises(ImportError, match="no _eigenmpm_v2 module"):
        _isa.choose("x86-64-v2", "x86-64-v2", lambda level: level == "x86-64")
    with pytest.raises(ImportError, match="EIGENMPM_ISA='sse9' is invalid; allowed: auto, x86-64, x86-64-v2"):
        _isa.choose("sse9", "x86-64-v2", built)


def test_the_lane_width_is_the_processors_and_can_be_set():
    """pkg/Lanes.hpp: the lane loops run in the widest vectors the processor has unless
    EIGENMPM_LANES caps them; setLaneIsa caps a request at the processor's width and names a wrong
    width's value and the allowed ones."""
    flags = _isa.cpuFlags()
    widest = "avx512" if {"avx512f", "avx512dq"} <= flags else "avx2" if "avx2" in flags else "baseline"
    assert em.setLaneIsa("auto") == widest
    if "EIGENMPM_LANES" not in os.environ:
        assert em.laneIsa() == widest
    assert em.setLaneIsa("baseline") == "baseline"
    assert em.laneIsa() == "baseline"
    assert em.setLaneIsa("avx512") == widest
    with pytest.raises(ValueError, match="lanes = sse9 is invalid; allowed: 'auto', 'avx512', 'avx2' or 'baseline'"):
        em.setLaneIsa("sse9")
    em.setLaneIsa("auto")


@pytest.mark.parametrize("name", ["_eigenmpm", "_eigenmpm_v2"])
def test_the_module_exports_only_its_init_and_none_of_its_own_code(name):
    """The module's symbols are hidden (CMakeLists.txt): it exports PyInit only, so that the
    plugins YADE loads before it, which define the same Eigen and standard-library templates
    compiled with other flags, cannot stand in for its own (the dynamic linker had bound its QR
    solve to YADE's _minieigenHP). The standard library's templates keep default visibility;
    -Bsymbolic-functions binds the module's calls to them to its own copies."""
    path = os.path.join(ROOT, "build", "python", "eigenmpm", name + ".so")
    if not os.path.exists(path):
        pytest.skip(f"{name} is not built here")
    r = subprocess.run(["nm", "-D", "-C", "--defined-only", path], capture_output=True, text=True, check=True)
    exported = [line.split(" ", 2)[2] for line in r.stdout.splitlines() if line.count(" ") >= 2]
    assert f"PyInit_{name}" in exported
    ours = [s for s in exported if re.search(r"\bemp::|\bEigen::|boost::python::", s)]
    assert ours == [], ours[:5]
    # No call of the module goes through the PLT to a function it defines itself.
    defined = set(subprocess.run(["nm", "-D", "--defined-only", "--format=just-symbols", path], capture_output=True,
                                 text=True, check=True).stdout.split())
    r = subprocess.run(["readelf", "-r", "--wide", path], capture_output=True, text=True, check=True)
    slots = {line.split()[4].split("@")[0] for line in r.stdout.splitlines() if "JUMP_SLOT" in line}
    assert slots and not slots & defined, sorted(slots & defined)[:5]
