#!/usr/bin/env bash
# Instructions per step of `amctl steps` with input shaping and pressure advance, counted by
# valgrind's callgrind over the shaped step stage only (the shaped piece stream and the shaped
# step generator): unlike wall or CPU time this figure does not move with the load of a shared
# machine (docs/steppers.md section 8, "Instructions per step").
#
#   scripts/count_step_instructions.sh [BUILD_DIR] [GCODE] [PRINTER_CFG]
#
# Defaults: build/release, boxboss on the Voron V0 with 3hump_ei 60 Hz on X, ei 45 Hz on Y and
# pressure advance 0.045 s (smooth time 0.04 s). Needs valgrind. About 1.5 min of CPU.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD_DIR=${1:-$ROOT/build/release}
GCODE=${2:-$ROOT/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode}
AMCTL=$BUILD_DIR/apps/amctl/amctl
[[ -x $AMCTL ]] || { echo "missing $AMCTL: build first" >&2; exit 2; }
command -v valgrind > /dev/null || { echo "valgrind is not installed (apt install valgrind)" >&2; exit 2; }
WORK=$(mktemp -d "${TMPDIR:-/tmp}/amctl_steps_count.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
CFG=${3:-}
if [[ -z $CFG ]]; then
  CFG=$WORK/printer.cfg
  cp "$ROOT/configs/klipper-voron-v0-macros.cfg" "$WORK/"
  sed -e 's/^pressure_advance: .*/pressure_advance: 0.045\npressure_advance_smooth_time: 0.04/' \
    "$ROOT/configs/klipper-voron-v0.cfg" > "$CFG"
  printf '\n[input_shaper]\nshaper_type_x: 3hump_ei\nshaper_freq_x: 60\nshaper_type_y: ei\nshaper_freq_y: 45\n' >> "$CFG"
fi
STEPS=$("$AMCTL" steps "$GCODE" --machine "$CFG" --json | grep -o '"steps": *[0-9]*' | grep -o '[0-9]*' | paste -sd+ | bc)
valgrind --tool=callgrind --callgrind-out-file="$WORK/cg.out" "$AMCTL" steps "$GCODE" --machine "$CFG" \
  > /dev/null 2> "$WORK/vg.log"
callgrind_annotate "$WORK/cg.out" 2> /dev/null | grep -E '^ *[0-9,]+ \(' |
  grep -E 'ShapedPieceStream|ShapedStepGenerator|steppers::\(anonymous|taylor_shift|memset' |
  awk -v n="$STEPS" '{gsub(",", "", $1); s += $1} END {printf "steps: %d\nshaped step stage: %.0f M instructions, %.0f per step\n", n, s / 1e6, s / n}'
