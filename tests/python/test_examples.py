"""The README's quick start runs as shipped and gives the elastic energy of the pulled bar."""
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_quickstart_runs_and_writes_its_outputs(tmp_path):
    script = os.path.join(ROOT, "examples", "quickstart.py")
    readme = open(os.path.join(ROOT, "README.md")).read()
    shipped = open(script).read()
    code = readme.split("```python\n# examples/quickstart.py\n")[1].split("```")[0]
    assert code in shipped, "README snippet and examples/quickstart.py differ"
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade", "-n", "-x", script], cwd=tmp_path, env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    for name in ("bar-00000000.vtp", "bar-00001000.vtp", "bar-series.pvd", "energy.png"):
        assert (tmp_path / "out" / name).exists(), name
