#!/usr/bin/env bash
# The main job on the bundled example: a part sliced by PrusaSlicer for a Klipper printer,
# planned move by move as Klipper's look-ahead would, then the same file on other printers.
set -euo pipefail
build=${1:-build/release}
amctl="$build/apps/amctl/amctl"
gcode=examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode

echo "== amctl estimate $gcode --machine configs/klipper-voron-v0.cfg"
"$amctl" estimate "$gcode" --machine configs/klipper-voron-v0.cfg
echo
echo "== the same G-code on other printers (presets in configs/)"
for m in configs/klipper-voron-v0.cfg voron24 prusa-mk3s ender3; do
  "$amctl" estimate "$gcode" --machine "$m" --brief
done
echo
echo "== what-if: the Voron with square_corner_velocity 0 (the thesis' full stop at every corner)"
"$amctl" estimate "$gcode" --machine configs/klipper-voron-v0.cfg --set printer.square_corner_velocity=0 --brief
echo
echo "== what-if: max_accel 1000 mm/s^2; the file's own M204 lines win unless capped (--file-limits)"
"$amctl" estimate "$gcode" --machine configs/klipper-voron-v0.cfg --set printer.max_accel=1000 --brief
"$amctl" estimate "$gcode" --machine configs/klipper-voron-v0.cfg --set printer.max_accel=1000 \
  --file-limits cap --brief
if [[ -f "$build/python/amctl/__init__.py" ]]; then
  echo
  echo "== the same from Python (docs/python.md)"
  PYTHONPATH="$build/python" /usr/bin/python3 -c "
import amctl
r = amctl.estimate('$gcode', machine='configs/klipper-voron-v0.cfg')
moves = amctl.plan('$gcode', machine='configs/klipper-voron-v0.cfg')
print(f\"total {r['total_time_s']:.1f} s; {len(moves)} moves, {int((moves['cruise_v_mm_s'] > 200).sum())} cruise above 200 mm/s\")"
fi
echo
echo "== the print as a page: speed over time, layers, toolpath coloured by contour error (belt at 40 Hz)"
"$amctl" report "$gcode" --machine configs/klipper-voron-v0.cfg --natural-frequency-hz 40 \
  --damping-ratio 0.1 -o "$build/demo_report.html"
echo "   open $build/demo_report.html in a browser (self-contained, no network)"
