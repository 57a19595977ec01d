"""bench_block --modes (bench/option_cost.py's measurement): one block per mode stepped in turn in
one process. Each mode's scene must be the one a run of that mode alone steps, and the ratios
must be those of the times it measured."""
import json
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXE = os.path.join(ROOT, "build", "bench_block")


def rows(*args):
    out = subprocess.run([EXE, *args], check=True, text=True, capture_output=True).stdout
    return [json.loads(line[5:]) for line in out.splitlines() if line.startswith("JSON ")]


@pytest.mark.parametrize("case,size", [("gimp2", ["--sizes", "3e3"]), ("gimp3", ["--size3d", "2e3"])])
def test_each_mode_steps_the_scene_of_a_run_of_that_mode_alone(case, size):
    common = ["--cases", case, *size, "--threads", "1", "--warmup", "1", "--steps", "6"]
    modes = ["FLIP smallStrain", "APIC corotational", "FLIP smallStrain", "APIC smallStrain"]
    together = rows(*common, "--modes", ",".join(modes), "--chunk", "2")
    assert [r["mode"] for r in together] == ["+".join(m.split()) for m in modes]
    for r in together:
        assert r["steps"] == 6  # 3 rounds of 2 steps each
    alone = {}
    for m in set(modes):
        transfer, update = m.split()
        (row,) = rows(*common, "--transfer", transfer, "--stress-update", update)
        alone[m] = row["checksum"]
    assert len(set(alone.values())) == 3  # the modes differ: the comparison can fail
    for m, r in zip(modes, together):
        assert r["checksum"] == alone[m], m
    first = together[0]
    for r in together:
        assert r["time_ratio_to_first_mode"] == pytest.approx(r["cpu_time_s"] / first["cpu_time_s"], rel=1e-3)
        assert r["round_ratio_q1"] <= r["median_round_ratio"] <= r["round_ratio_q3"]
    assert first["time_ratio_to_first_mode"] == 1 and first["median_round_ratio"] == 1


def test_a_mode_that_is_not_one_is_refused_by_name():
    p = subprocess.run([EXE, "--modes", "FLIP smallStrain,PIC corotational"], text=True, capture_output=True)
    assert p.returncode == 2
    assert "PIC corotational" in p.stderr and "FLIP|APIC" in p.stderr


def optionCost(*args):
    return subprocess.run(["/usr/bin/python3.11", os.path.join(ROOT, "bench", "option_cost.py"), "--exe", EXE, *args],
                          text=True, capture_output=True)


def test_option_cost_separate_times_each_mode_alone_and_gives_the_rounds_median():
    p = optionCost("--separate", "--rounds", "3", "--min-time", "0.05", "--cases", "gimp2", "--sizes", "3e3",
                   "--modes", "APIC corotational,FLIP corotational")
    assert p.returncode == 0, p.stderr
    lines = [line for line in p.stdout.splitlines() if "alone, median of 3 rounds" in line]
    assert [line.split()[1:4] for line in lines] == [["APIC", "+", "corotational"], ["FLIP", "+", "corotational"]]
    for line in lines:
        median = float(line.split("rounds")[1].split()[0])
        q1, q3 = (float(v) for v in line.split("quartiles ")[1].split(",")[0].split("-"))
        lo, hi = (float(v.rstrip(")")) for v in line.split("range ")[1].split("-"))
        assert 0 < lo <= q1 <= median <= q3 <= hi


def test_option_cost_refuses_separate_with_control_and_no_rounds():
    p = optionCost("--separate", "--control")
    assert p.returncode == 2 and "--separate and --control" in p.stderr
    p = optionCost("--separate", "--rounds", "0")
    assert p.returncode == 2 and "--rounds 0" in p.stderr
