#!/bin/sh
# Table 4 of the UTFPR process-planning study on a modern toolchain: coins of 25, 50 and 100 mm diameter (3 mm thick),
# sliced by Debian's prusa-slicer with 100 % rectilinear infill at raster angles 0/45/90/135,
# then timed by the empirical model (the study's uncalibrated speeds and calibrated) and by the look-ahead planner.
# Usage: examples/04_coins.sh [AMCTL] [WORKDIR]      (see docs/process.md for the results)
set -eu
AMCTL=${1:-build/release/apps/amctl/amctl}
WORK=${2:-build/coins}
HERE=$(dirname "$0")
MACHINE=prusa-mk3s
mkdir -p "$WORK"
for d in 25 50 100; do
  /usr/bin/python3 "$HERE/04_make_coin_stl.py" "$d" 3 "$WORK/coin$d.stl" --segments 256
  for a in 0 45 90 135; do
    prusa-slicer --export-gcode --layer-height 0.2 --first-layer-height 0.2 \
      --fill-density 100% --fill-pattern rectilinear --top-fill-pattern rectilinear \
      --bottom-fill-pattern rectilinear --fill-angle "$a" --perimeters 1 --skirts 0 \
      --extrusion-width 0.45 -o "$WORK/coin${d}_a$a.gcode" "$WORK/coin$d.stl" >/dev/null 2>&1
  done
done
# Reference durations: the planner on the printer the files were sliced for. No physical
# print was timed here, so the planner stands in for the stopwatch.
echo "gcode,duration_s" > "$WORK/planner_times.csv"
echo "gcode,duration_s" > "$WORK/small_coins.csv"
for d in 25 50 100; do
  for a in 0 45 90 135; do
    t=$("$AMCTL" estimate "$WORK/coin${d}_a$a.gcode" --machine $MACHINE --json |
        /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["total_time_s"])')
    echo "coin${d}_a$a.gcode,$t" >> "$WORK/planner_times.csv"
    if [ "$d" != 100 ]; then echo "coin${d}_a$a.gcode,$t" >> "$WORK/small_coins.csv"; fi
  done
done
# Empirical model calibrated on the 25 and 50 mm coins only (as one would from a few test
# prints), then used on all coins.
# Two coin sizes cannot separate many terms, so only the raster (= contour) and link paces
# are fitted; travel is held at the files' travel feed (7800 mm/min = 130 mm/s).
"$AMCTL" calibrate-time "$WORK/small_coins.csv" --mode empirical \
  --params "$HERE/04_empirical_start.json" --fix wipe_s --fix fixed_s --fix layer_change_s \
  --fix retract_s --fix travel_pace=0.00769 \
  --save "$WORK/empirical_fit.json" --json > "$WORK/empirical_fit_report.json"
echo "diameter_mm,angle_deg,planner_s,slicer_s,empirical_uncalibrated_s,empirical_fit_s" > "$WORK/table4.csv"
for d in 25 50 100; do
  for a in 0 45 90 135; do
    g="$WORK/coin${d}_a$a.gcode"
    p=$(grep "^coin${d}_a$a.gcode," "$WORK/planner_times.csv" | cut -d, -f2)
    "$AMCTL" estimate "$g" --mode empirical --json > "$WORK/uncalibrated.json"
    "$AMCTL" estimate "$g" --mode empirical --params "$WORK/empirical_fit.json" --json > "$WORK/fit.json"
    /usr/bin/python3 - "$d" "$a" "$p" "$WORK/uncalibrated.json" "$WORK/fit.json" >> "$WORK/table4.csv" <<'PY'
import json, sys
d, a, p, uncal, fit = sys.argv[1:]
s = json.load(open(uncal)); f = json.load(open(fit))
print("%s,%s,%.1f,%s,%.1f,%.1f" % (d, a, float(p), s["slicer_estimate_s"], s["total_time_s"], f["total_time_s"]))
PY
  done
done
# Planner calibration: durations of a "printer" whose limits differ from the preset
# (accel 900 mm/s^2, jerk 6 mm/s, max speed 150 mm/s), with +-1 % timing scatter; fit
# accel and jerk back from the twelve coins.
echo "gcode,duration_s" > "$WORK/timed_prints.csv"
i=0
for d in 25 50 100; do
  for a in 0 45 90 135; do
    t=$("$AMCTL" estimate "$WORK/coin${d}_a$a.gcode" --machine $MACHINE \
          --set marlin.print_accel=900 --set marlin.travel_accel=900 --set marlin.retract_accel=900 \
          --set 'marlin.jerk=[6,6,0.4,1.5]' --json |
        /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["total_time_s"])')
    t=$(/usr/bin/python3 -c "print($t * (1 + 0.01 * [0.3,-0.8,0.5,1.0,-0.2,-1.0,0.7,0.1,-0.5,0.9,-0.3,0.0][$i]))")
    echo "coin${d}_a$a.gcode,$t" >> "$WORK/timed_prints.csv"
    i=$((i + 1))
  done
done
"$AMCTL" calibrate-time "$WORK/timed_prints.csv" --machine $MACHINE --fit accel,jerk
"$AMCTL" calibrate-time "$WORK/timed_prints.csv" --machine $MACHINE --fit accel,jerk --json \
  > "$WORK/planner_calibration.json"
cat "$WORK/table4.csv"
