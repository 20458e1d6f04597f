#!/usr/bin/env bash
# Throughput of `amctl estimate` (parse + plan + estimate, one core) against `gzip -1` on the
# same generated slicer-like file.
#
#   scripts/bench_estimate.sh [BUILD_DIR] [BYTES] [RUNS]
#
# Defaults: build/release, 30 MB (about 1 M moves), best of 3 runs. Prints wall and CPU
# (user+sys) seconds of the best run of each, moves/s and the ratio gzip time / amctl time
# (> 1 means amctl is faster). On a shared machine compare CPU times: wall time includes
# waiting for the CPU.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD_DIR=${1:-$ROOT/build/release}
BYTES=${2:-30000000}
RUNS=${3:-3}
AMCTL=$BUILD_DIR/apps/amctl/amctl
[[ -x $AMCTL ]] || { echo "missing $AMCTL: build first" >&2; exit 2; }
WORK=$(mktemp -d "${TMPDIR:-/tmp}/amctl_bench.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

"${CXX:-c++}" -O2 -std=c++20 -o "$WORK/gen" "$ROOT/scripts/gen_slicer_gcode.cpp"
F=$WORK/bench.gcode
"$WORK/gen" "$BYTES" > "$F"
cat "$F" > /dev/null  # page cache
MOVES=$("$AMCTL" estimate "$F" --json | grep -E '^  "moves": *[0-9]+' | grep -o '[0-9]*')

best() {  # prints "wall cpu" of the run with the least CPU time
  local cmd=$1 b_wall=1e9 b_cpu=1e9
  for _ in $(seq "$RUNS"); do
    local out
    out=$( { /usr/bin/time -f '%e %U %S' bash -c "$cmd" > /dev/null; } 2>&1 | tail -1)
    read -r w u s <<< "$out"
    local c
    c=$(awk -v u="$u" -v s="$s" 'BEGIN { print u + s }')
    if awk -v c="$c" -v b="$b_cpu" 'BEGIN { exit !(c < b) }'; then b_cpu=$c; b_wall=$w; fi
  done
  echo "$b_wall $b_cpu"
}

read -r gz_wall gz_cpu <<< "$(best "gzip -1 -c '$F'")"
read -r am_wall am_cpu <<< "$(best "'$AMCTL' estimate '$F' --brief")"
echo "file: $(stat -c %s "$F") bytes, $MOVES moves ($(date -u +%Y-%m-%dT%H:%MZ), best of $RUNS)"
awk -v gw="$gz_wall" -v gc="$gz_cpu" -v aw="$am_wall" -v ac="$am_cpu" -v m="$MOVES" -v b="$(stat -c %s "$F")" 'BEGIN {
  printf "gzip -1 -c          wall %6.3f s  cpu %6.3f s  %7.1f MB/s (cpu)\n", gw, gc, b / 1e6 / gc
  printf "amctl estimate      wall %6.3f s  cpu %6.3f s  %7.1f MB/s (cpu)  %5.2f M moves/s (cpu)\n",
         aw, ac, b / 1e6 / ac, m / 1e6 / ac
  printf "gzip / amctl time:  %.2f (cpu), %.2f (wall)\n", gc / ac, gw / aw }'
