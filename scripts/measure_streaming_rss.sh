#!/usr/bin/env bash
# Proves that `amctl estimate` streams: peak RSS on a ~10 MB and a ~1 GB generated G-code file
# must agree within a few MB. Also prints throughput (MB/s and moves/s) for both.
#
#   scripts/measure_streaming_rss.sh [BUILD_DIR] [SMALL_BYTES] [LARGE_BYTES]
#
# Defaults: build/release, 10 MB, 1 GB. The files go to ${TMPDIR:-/tmp} and are deleted at
# exit (the 1 GB one too). Needs /usr/bin/time (GNU time) and a C++ compiler for the
# generator (scripts/gen_slicer_gcode.cpp).
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD_DIR=${1:-$ROOT/build/release}
SMALL=${2:-10000000}
LARGE=${3:-1000000000}
AMCTL=$BUILD_DIR/apps/amctl/amctl
TMP=${TMPDIR:-/tmp}
WORK=$(mktemp -d "$TMP/amctl_rss.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

[[ -x $AMCTL ]] || { echo "missing $AMCTL: build first (cmake --build $BUILD_DIR --target amctl)" >&2; exit 2; }
[[ -x /usr/bin/time ]] || { echo "needs GNU time (/usr/bin/time, Debian package 'time')" >&2; exit 2; }

CXX=${CXX:-c++}
"$CXX" -O2 -std=c++20 -o "$WORK/gen" "$ROOT/scripts/gen_slicer_gcode.cpp"

measure() {  # $1 = bytes, $2 = label
  local f="$WORK/$2.gcode"
  "$WORK/gen" "$1" > "$f"
  local size
  size=$(stat -c %s "$f")
  /usr/bin/time -v "$AMCTL" estimate "$f" --json > "$WORK/$2.json" 2> "$WORK/$2.time"
  local rss_kb wall moves
  rss_kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$WORK/$2.time")
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$WORK/$2.time")
  moves=$(grep -E '^  "moves": *[0-9]+' "$WORK/$2.json" | grep -o '[0-9]*')
  # wall clock is [h:]mm:ss.ss
  local secs
  secs=$(echo "$wall" | awk -F: '{ s = 0; for (i = 1; i <= NF; ++i) s = s * 60 + $i; print s }')
  awk -v l="$2" -v b="$size" -v r="$rss_kb" -v s="$secs" -v m="$moves" 'BEGIN {
    printf "%-6s %10.1f MB  %10d moves  peak RSS %8.1f MB  %7.2f s  %7.1f MB/s  %6.2f M moves/s\n",
           l, b / 1e6, m, r / 1024.0, s, b / 1e6 / s, m / 1e6 / s }'
  echo "$rss_kb" > "$WORK/$2.rss"
  # The same run without the JSON document (whose per-layer rows grow with the layer count):
  /usr/bin/time -v "$AMCTL" estimate "$f" --brief > /dev/null 2> "$WORK/$2.btime"
  awk -F': ' -v l="$2" '/Maximum resident set size/ {
    printf "%-6s --brief peak RSS %8.1f MB\n", l, $2 / 1024.0 }' "$WORK/$2.btime"
  awk -F': ' '/Maximum resident set size/ {print $2}' "$WORK/$2.btime" > "$WORK/$2.brss"
  echo "layers: $(grep -c '^;LAYER_CHANGE' "$f")"
  rm -f "$f"
}

echo "amctl estimate --json, $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) CPUs, $AMCTL"
measure "$SMALL" small
measure "$LARGE" large
awk -v a="$(cat "$WORK/small.rss")" -v b="$(cat "$WORK/large.rss")" \
    -v c="$(cat "$WORK/small.brss")" -v d="$(cat "$WORK/large.brss")" 'BEGIN {
  j = (b - a) / 1024.0; k = (d - c) / 1024.0
  printf "peak RSS difference (large - small): --json %.1f MB, --brief %.1f MB\n", j, k
  exit (j > 8.0 || j < -8.0 || k > 4.0 || k < -4.0) ? 1 : 0 }'
