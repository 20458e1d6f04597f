#!/bin/sh
# LPFBF over the whole bundled print at 1 kHz (docs/compensation.md, "LPFBF over a whole
# print"): real-time factor from the JSON, peak RSS from /usr/bin/time -v.
# Usage: bench/lpfbf_whole_print.sh [build/release/apps/amctl/amctl] [extra compensate flags]
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
amctl=${1:-$here/build/release/apps/amctl/amctl}
[ $# -gt 0 ] && shift
out=${TMPDIR:-/tmp}/lpfbf_whole_print.$$
mkdir -p "$out"
/usr/bin/time -v "$amctl" compensate "$here/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode" \
  --machine "$here/configs/klipper-voron-v0.cfg" --method lpfbf \
  --natural-frequency-hz 40 --damping-ratio 0.1 --csv "$out/cmd.csv" --json "$@" \
  2>"$out/time.txt" | grep -E '"(motion_time_s|compute_time_s|real_time_factor|max_tracking_error_mm|uncompensated_max_tracking_error_mm|window_s|overlap_s|windows|max_held_moves|max_held_samples|samples)"'
grep -E "Maximum resident set size" "$out/time.txt"
rm -rf "$out"
