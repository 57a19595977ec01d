"""Collects the summary.json files of a yade-batch sweep into a table (Markdown and CSV), in the
layout of the paper's Tables 1 and 2: one row per value of --rows, one column per value of
--cols (optional), each cell the --value quantities of that run.

    /usr/bin/python3.11 tools/collect.py out/lshaped_panel --rows alpha --cols kappaOverH \
        [--value displacement_at_peak_mm,peak_load_kN] [--csv table.csv]

The parameters of a run are read from its summary's "parameters" (every example writes them).
"""
import argparse
import glob
import json
import os
import sys


def load(root):
    runs = []
    for path in sorted(glob.glob(os.path.join(root, "**", "summary.json"), recursive=True)):
        with open(path) as f:
            s = json.load(f)
        runs.append((s.get("parameters", {}), s))
    return runs


def fmt(v):
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def table(runs, rows, cols, values):
    """(header, body): body rows are [row value, cell, cell, ...]."""
    rv = sorted({p[rows] for p, _ in runs if rows in p})
    cv = sorted({p[cols] for p, _ in runs if cols in p}) if cols else [None]
    header = [rows] + [f"{v} {cols}={c}" if cols else v for c in cv for v in values]
    body = []
    for r in rv:
        line = [fmt(r)]
        for c in cv:
            match = [s for p, s in runs if p.get(rows) == r and (cols is None or p.get(cols) == c)]
            for v in values:
                line.append(fmt(match[0].get(v, "")) if match else "")
        body.append(line)
    return header, body


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("root")
    ap.add_argument("--rows", required=True)
    ap.add_argument("--cols")
    ap.add_argument("--value", default="displacement_at_peak_mm,peak_load_kN")
    ap.add_argument("--csv")
    a = ap.parse_args(argv)
    runs = load(a.root)
    if not runs:
        raise SystemExit(f"collect: no summary.json under {a.root}")
    header, body = table(runs, a.rows, a.cols, a.value.split(","))
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for line in body:
        print("| " + " | ".join(line) + " |")
    if a.csv:
        with open(a.csv, "w") as f:
            for line in [header] + body:
                f.write(",".join(line) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
