"""What the crack diagnostics cost in the branching plate (examples/crack_branching.py's scene):
the EigenErosion record (front distance and tips, every 0.1 us of simulated time as in the
example) against the same run without records. Run inside YADE, one thread:

    PYTHONPATH=build/python yade -n -j 1 -x bench/bench_crack_records.py [--h-mm 0.5]
        [--dt-us 0.018] [--end-us 80] [--rounds 2]

A round steps the scene twice from its start, once recording and once not, the order
alternating from round to round; the time is the process's CPU time of O.run, and in the run
with records also the CPU time spent inside EigenErosion.record. Reported per round: both run
times, the time inside the records and its share of the rest of that run (the robust figure:
the difference of the two runs carries the machine's noise), the number of records, the eroded
points at the end and one record's time at the end; then the median share. The two runs must
end with the same eroded set (the records only read).
To compare two builds' Python packages, run it with each PYTHONPATH in turn (a `cp -rL` copy of
the old build/python, since build/python links its .py files to the source tree).
"""
import argparse
import json
import os
import statistics
import sys
import time

from yade import O

import eigenmpm as em

# (run from the repository root; or the examples beside the package's source, which build/python links to)
sys.path[:0] = [os.path.join(os.getcwd(), "examples"),
                os.path.join(os.path.dirname(os.path.realpath(em.__file__)), "..", "..", "examples")]
import crack_branching  # noqa: E402


def run(o, record):
    """CPU seconds of the run, the erosion engine and the engine."""
    O.reset()
    mpm, crack = crack_branching.build(o)
    if not record:
        crack.iterPeriod = 10 ** 9
    O.dt = o["dt_us"] * 1e-6
    O.engines = [mpm, crack]
    steps = int(round(o["endTime_us"] / o["dt_us"]))
    crack.recordTime = 0.0
    plain = crack.record

    def timed(m=None):  # (an instance attribute: the engine's action calls self.record)
        t = time.process_time()
        plain(m)
        crack.recordTime += time.process_time() - t

    crack.record = timed
    t = time.process_time()
    O.run(steps, True)
    return time.process_time() - t, crack, mpm


def main(argv):
    ap = argparse.ArgumentParser(prog="bench_crack_records.py")
    ap.add_argument("--h-mm", type=float, default=0.5)
    ap.add_argument("--dt-us", type=float, default=0.018)
    ap.add_argument("--end-us", type=float, default=80.0)
    ap.add_argument("--rounds", type=int, default=2)
    a = ap.parse_args(argv)
    o = dict(crack_branching.DEFAULTS, h_mm=a.h_mm, dt_us=a.dt_us, endTime_us=a.end_us)
    shares = []
    for r in range(a.rounds):
        times, eroded = {}, {}
        for record in ((True, False) if r % 2 == 0 else (False, True)):
            times[record], crack, mpm = run(o, record)
            eroded[record] = [e[0] for e in crack.core.events()]
            if record:
                records, inside = len(crack.history), crack.recordTime
                t = time.process_time()
                crack.record(mpm)
                one = time.process_time() - t
        assert eroded[True] == eroded[False], "the records changed the run"
        eroded = eroded[True]
        share = inside / (times[True] - inside)
        shares.append(share)
        print(json.dumps({"round": r + 1, "with_s": round(times[True], 2), "without_s": round(times[False], 2),
                          "records_s": round(inside, 3), "records_share": round(share, 4), "records": records,
                          "eroded": len(eroded), "record_ms_at_end": round(1e3 * one, 2)}))
    print(f"median share of the records: {statistics.median(shares):.4f} over {a.rounds} rounds "
          f"(h = {a.h_mm} mm, dt = {a.dt_us} us, {a.end_us} us)")


if __name__ == "__main__":
    main(sys.argv[1:])
