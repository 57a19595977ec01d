"""Example regression: run a shipped example script in its coarse mode and compare its
summary.json with a stored reference, quantity by quantity.

A reference (``examples/reference/<name>.json``) reads::

    {"script": "examples/crack_branching.py", "args": ["--quick"],
     "quantities": {"initiation_time_us": {"value": 10.48, "rel": 0.05},
                    "tips_at_end": {"value": 2, "abs": 0}}}

``rel`` is a relative and ``abs`` an absolute tolerance (either or both; a quantity passes when
it is within either). tests/python/test_regression.py runs every reference. Record or refresh a
reference with::

    make reference NAMES="crack_branching ..."
    /usr/bin/python3.11 tools/regression.py record crack_branching ...     (the same)

Scripts and references are found in the repository this file lies in (tools/..).
"""
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))


def run(reference, root=ROOT, timeout=600):
    """Runs the reference's script into a temporary directory; returns its summary dict."""
    with tempfile.TemporaryDirectory() as out:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [os.path.join(root, "build", "python"),
                                                          env.get("PYTHONPATH")]))
        cmd = ["yade", "-n", "-x", os.path.join(root, reference["script"])] + reference.get("args", []) + ["--out", out]
        res = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True, timeout=timeout,
                             stdin=subprocess.DEVNULL)
        if res.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stdout[-3000:]}\n{res.stderr[-3000:]}")
        with open(os.path.join(out, "summary.json")) as f:
            return json.load(f)


def compare(reference, summary):
    """List of failure messages (empty when every quantity is within its tolerance)."""
    failures = []
    for key, spec in reference["quantities"].items():
        if key not in summary:
            failures.append(f"{key}: missing from summary.json")
            continue
        got, want = summary[key], spec["value"]
        if isinstance(want, str) or want is None or got is None:
            if got != want:
                failures.append(f"{key}: {got!r}, reference {want!r}")
            continue
        diff = abs(got - want)
        ok = ("abs" in spec and diff <= spec["abs"]) or ("rel" in spec and diff <= spec["rel"] * abs(want))
        if not ok:
            tol = ", ".join(f"{k} {spec[k]}" for k in ("rel", "abs") if k in spec)
            failures.append(f"{key}: {got!r}, reference {want!r} ({tol})")
    return failures


def record(name, root=ROOT):
    """Runs the reference `name` and rewrites its values from the run (tolerances kept)."""
    path = os.path.join(root, "examples", "reference", name + ".json")
    with open(path) as f:
        reference = json.load(f)
    summary = run(reference, root)
    for key, spec in reference["quantities"].items():
        spec["value"] = summary[key]
    with open(path, "w") as f:
        json.dump(reference, f, indent=2)
        f.write("\n")
    return reference


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "record":
        for n in sys.argv[2:]:
            print(json.dumps(record(n), indent=2))
    else:
        raise SystemExit("usage: make reference NAMES=\"NAME ...\", or tools/regression.py record NAME ...")
