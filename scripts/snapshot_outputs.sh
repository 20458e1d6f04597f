#!/usr/bin/env bash
# Every number amctl prints, written to one directory so that a refactoring can be checked
# byte for byte against the code before it (issue 13, "Must not change").
#
#   scripts/snapshot_outputs.sh AMCTL OUTDIR          write the snapshot
#   scripts/snapshot_outputs.sh AMCTL OUTDIR BASEDIR  write it, then diff against BASEDIR
#
# Typical use: build the old commit, snapshot it to /tmp/before; build the new one, snapshot
# it to /tmp/after with /tmp/before as BASEDIR. Exit 0 when identical, 1 with the diff when not.
#
# Covered: `estimate --json` on the shared corpus (when ../shared is there), the examples and
# the Klipper reference files, on every preset, the Klipper reference configurations and every
# velocity profile; `estimate --compare-profiles --json`; `simulate --json`; `sweep --json`;
# the thermal and process commands of the examples. Wall-clock fields (compute_time_s) are
# removed: they are the only thing that may differ between two runs of the same binary.
set -euo pipefail
amctl=$(realpath "$1")
out=$2
base=${3:-}
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
rm -rf "$out"
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Drop the lines holding wall-clock times (JSON is printed one key per line with dump(2)).
# The scratch directory's name is replaced by TMP.
strip() { grep -v -E '"compute_time_s"|computed in|plan included\)' | sed "s|$tmp|TMP|g" || true; }

run() {  # run NAME CMD...: stdout and exit status into $out/NAME
  local name=$1; shift
  local rc=0
  "$@" >"$out/$name.tmp" 2>"$out/$name.err" || rc=$?
  strip <"$out/$name.tmp" >"$out/$name"
  echo "exit $rc" >>"$out/$name"
  rm -f "$out/$name.tmp"
}

# The shared corpus sits beside the clone (../shared); from a git worktree deeper down, look
# further up, or set AMCTL_CORPUS_DIR.
corpus=${AMCTL_CORPUS_DIR:-}
if [ -z "$corpus" ]; then
  d=$root
  while [ "$d" != / ]; do
    d=$(dirname "$d")
    if [ -d "$d/shared/corpus/gcode" ]; then corpus=$(realpath --relative-to="$root" "$d/shared/corpus"); break; fi
  done
fi
gcodes=(examples/gcode/*.gcode examples/*.gcode tests/reference/klipper/*.gcode)
if [ -n "$corpus" ]; then gcodes+=("$corpus"/gcode/*.gcode); fi
machines=(default ender3 prusa-mk3s voron24 configs/klipper-voron-v0.cfg
          examples/30_belt_corner_printer.cfg
          tests/reference/klipper/ender3_cartesian.cfg tests/reference/klipper/v0_corexy.cfg)
profiles=(trapezoid bezier5 scurve7)

n=0
for g in "${gcodes[@]}"; do
  gb=$(basename "$g" .gcode)
  for m in "${machines[@]}"; do
    mb=$(basename "$m"); mb=${mb%.*}
    for p in "${profiles[@]}"; do
      run "estimate__${gb}__${mb}__${p}.json" "$amctl" estimate "$g" --machine "$m" \
          --set "printer.profile=$p" --json
      n=$((n + 1))
    done
  done
  run "estimate_human__${gb}.txt" "$amctl" estimate "$g" --machine configs/klipper-voron-v0.cfg --layers
  run "compare_profiles__${gb}.json" "$amctl" estimate "$g" --machine voron24 --compare-profiles --json
done

# Simulation: the seed-000 example and a real print window, both profiles.
run simulate_seed000.json "$amctl" simulate examples/30_belt_corner.gcode \
    --machine examples/30_belt_corner_printer.cfg --natural-frequency-hz 15.9 --damping-ratio 0.5 --json
run simulate_seed000_scurve.json "$amctl" simulate examples/30_belt_corner.gcode \
    --machine examples/30_belt_corner_printer.cfg --natural-frequency-hz 15.9 --damping-ratio 0.5 \
    --profile scurve7 --json
run simulate_boxboss.json "$amctl" simulate examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode \
    --machine configs/klipper-voron-v0.cfg --natural-frequency-hz 40 --damping-ratio 0.05 \
    --layer-begin 2 --layer-end 3 --json
run simulate_boxboss_modes.json "$amctl" simulate examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode \
    --machine voron24 --mode 35,0.05 --mode 80,0.02,0.3 --motor-space --t-end 120 --json
run sweep.json "$amctl" sweep --json

# Thermal and process (the examples' commands; CSV traces written to a scratch directory).
run thermal_margins.json "$amctl" thermal sls-margins --kp 0.3 --ti 0.5 --modes 1 --json
run thermal_margins_3.json "$amctl" thermal sls-margins --modes 3 --length-mm 0.5 --json
run thermal_sls.txt "$amctl" thermal sls --config configs/sls_pa12.toml --csv "$tmp/sls.csv"
run thermal_sls_csv.txt cat "$tmp/sls.csv"
run thermal_sls_bc.txt "$amctl" thermal sls --config configs/sls_pa12.toml --anti-windup back_calculation --csv ''
for h in hotend bed; do
  run "thermal_$h.json" "$amctl" thermal "$h" --json
  run "thermal_$h.txt" "$amctl" thermal "$h" --noise 0.1
done
run shrink_fit1.json "$amctl" shrink fit examples/04_shrink_geometry1.csv --json
run shrink_fit1.txt "$amctl" shrink fit examples/04_shrink_geometry1.csv
run shrink_fit4.json "$amctl" shrink fit examples/04_shrink_geometry4.csv --json
run shrink_fit_ranges.json "$amctl" shrink fit examples/04_shrink_geometry1.csv --ranges 2 --json
run shrink_slicing.txt "$amctl" shrink slicing examples/04_shrink_geometry4.csv
if [ -f "$corpus/models/ringing_tower.stl" ]; then
  run shrink_fit_save.json "$amctl" shrink fit examples/04_shrink_geometry1.csv --json
  cp "$out/shrink_fit_save.json" "$tmp/fit.json"; sed -i '$d' "$tmp/fit.json"
  run shrink_apply_stl.json "$amctl" shrink apply --model "$corpus/models/ringing_tower.stl" \
      --factors "$tmp/fit.json" --layer-mm 0.2 -o "$tmp/scaled.stl" --json
  run shrink_apply_stl_md5.txt md5sum - <"$tmp/scaled.stl"
fi
for g in examples/gcode/*.gcode "$corpus/gcode/benchy_cura-5.3.gcode"; do
  [ -f "$g" ] || continue
  gb=$(basename "$g" .gcode)
  run "empirical__$gb.json" "$amctl" estimate "$g" --mode empirical --json
  run "empirical_params__$gb.json" "$amctl" estimate "$g" --mode empirical \
      --params examples/04_empirical_start.json --json
  run "shrink_apply__$gb.txt" "$amctl" shrink apply --gcode "$g" --factors x=1.01,y=1.02,z=1.005:2:1.003 \
      -o "$tmp/scaled.gcode" --json
  run "shrink_apply_out__$gb.gcode" cat "$tmp/scaled.gcode"
done

# Resonance: Klipper's calibration, the sweep's frequency response and modal fit, the
# model-based recommendation (FFT, Welch, least squares and the scalar search all run here).
for r in tests/reference/resonance/calibration_data_y_sweep_1.csv tests/reference/resonance/calibration_data_y_sweeps_1_2_3.csv; do
  rb=$(basename "$r" .csv)
  run "resonance_calibrate__$rb.json" "$amctl" resonance calibrate "$r" --json
done
if [ -n "$corpus" ]; then
  for r in "$corpus"/accel/*.csv; do
    rb=$(basename "$r" .csv)
    run "resonance_sweep__$rb.json" "$amctl" resonance calibrate "$r" --axis y --sweep 5,80,4,4000 --json
  done
  run resonance_sweep_recommend.json "$amctl" resonance calibrate "$corpus/accel/ender3v2neo_y_sweep_1.csv" \
      --axis y --sweep 5,80,4,4000 --recommend --json
fi
run resonance_recommend.json "$amctl" resonance recommend --natural-frequency-hz 45 --damping-ratio 0.08 --json

# calibrate-time (least squares over the planner's limits): made-up durations of four files.
{
  echo "gcode,duration_s"
  echo "$root/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode,905"
  echo "$root/tests/reference/klipper/syn_arcs.gcode,5.3"
  echo "$root/tests/reference/klipper/syn_square.gcode,1.05"
  echo "$root/tests/reference/klipper/syn_velocity_limit.gcode,3.9"
} >"$tmp/timings.csv"
run calibrate_time.json "$amctl" calibrate-time "$tmp/timings.csv" --json

# The machine descriptions.
for m in "${machines[@]}"; do
  mb=$(basename "$m"); mb=${mb%.*}
  run "machine_show__$mb.json" "$amctl" machine show "$m" --json
  run "machine_show__$mb.toml" "$amctl" machine show "$m"
done
run machine_keys.json "$amctl" machine keys --json

# Bad input: the message and exit code are part of the interface.
printf 'G1 X10\nG1 X1e\n' >"$tmp/bad.gcode"
run error_bad_number.txt "$amctl" estimate "$tmp/bad.gcode"
sed "s|$tmp|TMP|g" "$out/error_bad_number.txt.err" >"$out/error_bad_number_stderr.txt"

echo "snapshot: $n estimate runs and the other commands in $out"
if [ -n "$base" ]; then
  if diff -r -x '*.err' "$base" "$out" >"$out.diff"; then
    echo "identical to $base"
  else
    echo "DIFFERENT from $base (first lines of $out.diff):"
    head -40 "$out.diff"
    exit 1
  fi
fi
