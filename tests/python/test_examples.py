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


def test_yade_batch_table_runs_each_line(tmp_path):
    table = tmp_path / "bar.table"
    table.write_text("cells shape plot\n10 'uGIMP' 0\n20 'linear' 0\n")
    script = os.path.join(ROOT, "examples", "verification", "vibrating_bar.py")
    env = dict(os.environ, PYTHONPATH=os.path.join(ROOT, "build", "python"))
    res = subprocess.run(["yade-batch", "-j", "1", "--log", "job%.log", str(table), script],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
                         stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    import json
    a = json.load(open(tmp_path / "out" / "vibrating_bar" / "cells=10,shape=uGIMP,plot=0" / "summary.json"))
    b = json.load(open(tmp_path / "out" / "vibrating_bar" / "cells=20,shape=linear,plot=0" / "summary.json"))
    assert (a["cells_along_bar"], a["shape"]) == (10, "uGIMP")
    assert (b["cells_along_bar"], b["shape"]) == (20, "linear")
    assert not (tmp_path / "out" / "vibrating_bar" / "tip_displacement.png").exists()

