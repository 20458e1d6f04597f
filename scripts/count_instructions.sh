#!/usr/bin/env bash
# Instructions per move of `amctl estimate` (parse + plan + report), counted by valgrind's
# callgrind: unlike wall or CPU time this figure does not move with the load of a shared
# machine, so it shows whether a change made the hot path cheaper. It does not replace the
# timed benchmarks (a division costs more than an add), it complements them.
#
#   scripts/count_instructions.sh [BUILD_DIR] [BYTES]
#
# Defaults: build/release, 6 MB (about 200 000 moves). Needs valgrind (Debian: valgrind).
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD_DIR=${1:-$ROOT/build/release}
BYTES=${2:-6000000}
AMCTL=$BUILD_DIR/apps/amctl/amctl
[[ -x $AMCTL ]] || { echo "missing $AMCTL: build first" >&2; exit 2; }
command -v valgrind > /dev/null || { echo "valgrind is not installed (apt install valgrind)" >&2; exit 2; }
WORK=$(mktemp -d "${TMPDIR:-/tmp}/amctl_count.XXXXXX")
trap 'rm -rf "$WORK"' EXIT

"${CXX:-c++}" -O2 -std=c++20 -o "$WORK/gen" "$ROOT/scripts/gen_slicer_gcode.cpp"
F=$WORK/bench.gcode
"$WORK/gen" "$BYTES" > "$F"
MOVES=$("$AMCTL" estimate "$F" --json | grep -E '^  "moves": *[0-9]+' | grep -o '[0-9]*')
LINES=$(wc -l < "$F")
valgrind --tool=callgrind --callgrind-out-file="$WORK/cg.out" "$AMCTL" estimate "$F" --brief \
  > /dev/null 2> "$WORK/vg.log"
TOTAL=$(grep -o 'Collected : [0-9]*' "$WORK/vg.log" | grep -o '[0-9]*$')
echo "file: $(stat -c %s "$F") bytes, $LINES lines, $MOVES moves"
awk -v t="$TOTAL" -v m="$MOVES" 'BEGIN { printf "instructions: %d in all, %.0f per move\n", t, t / m }'
echo "top functions (self):"
callgrind_annotate "$WORK/cg.out" 2> /dev/null | grep -E '^ *[0-9,]+ \(' | sed -n '2,9p' |
  sed -E 's/\[[^]]*\]$//; s/\(std::basic_string_view<char, std::char_traits<char> >/(string_view/g' |
  cut -c1-110
