#!/bin/sh
# Thermal module tour (docs/thermal.md). Run from the repository root after building:
#   cmake --preset release && cmake --build build/release
# The CSV files go to $OUT (default build/examples), never into the working directory.
set -e
AMCTL=${AMCTL:-build/release/apps/amctl/amctl}
OUT=${OUT:-build/examples}
mkdir -p "$OUT"

# 1. The SLS temperature-control paper (2018): margins of its PI on G_1 and on the exact G, two ways each.
"$AMCTL" thermal sls-margins --kp 0.3 --ti 0.5 --modes 1 --json
"$AMCTL" thermal sls-margins --modes 1 --length-mm 0.5 --bode-csv "$OUT/sls_bode.csv"

# 2. Closed-loop build of 200 PA12 layers with the sintering laser and a set-point change.
"$AMCTL" thermal sls --config configs/sls_pa12.toml --csv "$OUT/sls_trace.csv"
"$AMCTL" thermal sls --config configs/sls_pa12.toml --anti-windup back_calculation

# 3. FDM: relay-autotuned PID vs identified MPC on the same hotend, and the bed.
"$AMCTL" thermal hotend --csv "$OUT/hotend_trace.csv"
"$AMCTL" thermal hotend --noise 0.1
"$AMCTL" thermal bed
