"""Every example with a stored reference (examples/reference/*.json) runs as shipped in its
coarse mode and must reproduce each recorded quantity within that quantity's tolerance."""
import glob
import json
import os

import pytest

import regression  # tools/regression.py (conftest puts tools/ on sys.path)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
REFERENCES = sorted(glob.glob(os.path.join(ROOT, "examples", "reference", "*.json")))


@pytest.mark.parametrize("path", REFERENCES, ids=[os.path.basename(p)[:-5] for p in REFERENCES])
def test_example_matches_its_reference(path):
    reference = json.load(open(path))
    assert os.path.exists(os.path.join(ROOT, reference["script"]))
    summary = regression.run(reference, ROOT)
    failures = regression.compare(reference, summary)
    assert not failures, "\n".join(failures)


def test_compare_reports_each_kind_of_failure():
    ref = {"quantities": {"a": {"value": 10.0, "rel": 0.1}, "b": {"value": 1.0, "abs": 0.01},
                          "c": {"value": "notch"}, "d": {"value": 3, "abs": 0}}}
    assert regression.compare(ref, {"a": 10.9, "b": 1.005, "c": "notch", "d": 3}) == []
    failures = regression.compare(ref, {"a": 11.5, "b": 1.02, "c": "midspan"})
    assert [f.split(":")[0] for f in failures] == ["a", "b", "c", "d"]
