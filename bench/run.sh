#!/usr/bin/env bash
# Builds (if needed) and runs the step-throughput benchmark (bench/bench_block.cpp), printing the
# machine first, then the fracture-overhead benchmark (bench/bench_fracture.cpp; its arguments
# in FRACTURE_ARGS, e.g. FRACTURE_ARGS=--quick) and, where yade is installed, the YADE-path overhead
# benchmark (bench/bench_yade_overhead.py; arguments in YADE_ARGS, e.g. YADE_ARGS='--rounds 4')
# and the crack diagnostics' share (bench/bench_crack_records.py; arguments in RECORDS_ARGS,
# default the quick branching plate: RECORDS_ARGS='--h-mm 1 --dt-us 0.04 --end-us 40').
# `make bench` calls this. Arguments are passed
# to bench_block, e.g.
#   bash bench/run.sh --quick
#   bash bench/run.sh --sizes 1e5,1e6 --threads 1,2 --min-time 3 --cases gimp2,linear2,gimp3
# Environment: BUILD (build directory, default build), PYTHON (default /usr/bin/python3.11).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
PYTHON=${PYTHON:-/usr/bin/python3.11}

if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE="$PYTHON" > /dev/null
fi
# Re-running cmake picks up bench/*.cpp added since the last configure (CONFIGURE_DEPENDS).
cmake --build "$BUILD" --target bench_block bench_fracture -j "$(nproc)" > /dev/null

echo "== machine"
echo "host:       $(uname -n) ($(uname -sr))"
echo "cpus:       $(nproc) (nproc)"
echo "cpu model:  $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
echo "cpu id:     family $(grep -m1 '^cpu family' /proc/cpuinfo | cut -d: -f2 | tr -d ' ') model $(grep -m1 '^model[[:space:]]*:' /proc/cpuinfo | cut -d: -f2 | tr -d ' '), $(grep -m1 '^cpu MHz' /proc/cpuinfo | cut -d: -f2 | tr -d ' ') MHz, avx2: $(grep -qw avx2 /proc/cpuinfo && echo yes || echo no), avx512f: $(grep -qw avx512f /proc/cpuinfo && echo yes || echo no)"
command -v lscpu > /dev/null && echo "caches:     $(lscpu | awk -F: '/^L[123][di]? cache/{gsub(/^ +/, "", $2); printf "%s %s; ", $1, $2}')"
echo "compiler:   $(${CXX:-c++} --version 2>/dev/null | head -n1)"
echo "build type: $(grep -m1 '^CMAKE_BUILD_TYPE:' "$BUILD/CMakeCache.txt" | cut -d= -f2)"
echo "load avg:   $(cut -d' ' -f1-3 /proc/loadavg) (timings are noisy when other jobs run)"
commit=$(git rev-parse --short HEAD 2>/dev/null || echo n/a)
git diff --quiet HEAD -- pkg bench CMakeLists.txt 2>/dev/null || commit="$commit + uncommitted changes in pkg/bench"
echo "date:       $(date -u +%Y-%m-%dT%H:%M:%SZ)   commit: $commit"
echo
echo "== bench_block $*"
"$BUILD/bench_block" "$@"
echo
echo "== bench_fracture ${FRACTURE_ARGS:-}"
# shellcheck disable=SC2086
"$BUILD/bench_fracture" ${FRACTURE_ARGS:-}
echo
if command -v yade > /dev/null; then
  echo "== bench_yade_overhead ${YADE_ARGS:-}"
  # shellcheck disable=SC2086
  PYTHONPATH="$BUILD/python${PYTHONPATH:+:$PYTHONPATH}" yade -n -j 1 -x bench/bench_yade_overhead.py ${YADE_ARGS:-} \
    < /dev/null 2>&1 | grep -E '^ *[0-9]+ points|^JSON|rror'
  records=${RECORDS_ARGS:---h-mm 1 --dt-us 0.04 --end-us 40}
  echo "== bench_crack_records $records"
  # shellcheck disable=SC2086
  PYTHONPATH="$BUILD/python${PYTHONPATH:+:$PYTHONPATH}" yade -n -j 1 -x bench/bench_crack_records.py $records \
    < /dev/null 2>&1 | grep -E '^\{|^median|rror'
else
  echo "== bench_yade_overhead and bench_crack_records skipped (no yade)"
fi
