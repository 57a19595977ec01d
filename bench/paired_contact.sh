#!/bin/bash
# Paired run of bench/bench_contact.py with two builds of the Python package, in alternating
# rounds in one invocation (a slow spell of the shared machine then hits both):
#
#     bench/paired_contact.sh OLD_PYTHONPATH NEW_PYTHONPATH [ROUNDS] [bench_contact.py options]
#
# Each PYTHONPATH is a build's python/ folder. Copy an old build's with `cp -rL` (build/python
# links the package's .py files to the source tree, which would otherwise be the new ones).
# Prints each round's lines of bench_contact.py (ratio with / without contact, and the part
# spent reading YADE's bodies and writing their forces), then the median ratio of each build
# with its range.
set -euo pipefail
old=$1 new=$2
rounds=${3:-4}
shift $(( $# >= 3 ? 3 : $# ))
here=$(cd "$(dirname "$0")" && pwd)
args=("$@")
[ ${#args[@]} -gt 0 ] || args=(--points 1e5 --bodies 1000 --steps 10 --rounds 3)
log=$(mktemp)
trap 'rm -f "$log"' EXIT
for r in $(seq 1 "$rounds"); do
  for p in "$old" "$new"; do
    echo "== $p round $r"
    PYTHONPATH=$p yade -n -j1 -x "$here/bench_contact.py" "${args[@]}" 2>&1 | tail -3 | tee -a "$log" |
      sed -n '1,3p'
    echo "ratio-of $p $(grep -o 'ratio [0-9.]*' "$log" | tail -1 | cut -d' ' -f2)" >> "$log.ratios"
  done
done
for p in "$old" "$new"; do
  grep "^ratio-of $p " "$log.ratios" | cut -d' ' -f3 | sort -n |
    awk -v p="$p" '{v[NR] = $1} END {m = NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2;
                   printf "median ratio %s: %.3f (range %.3f-%.3f, %d runs)\n", p, m, v[1], v[NR], NR}'
done
rm -f "$log.ratios"
