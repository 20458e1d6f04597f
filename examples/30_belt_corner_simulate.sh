#!/bin/sh
# The feedforward thesis' base case end to end: plan the 10 mm X + 10 mm Y path with a full stop
# at the corner (square_corner_velocity 0) and simulate the belt model w = 100 rad/s (15.915 Hz),
# z = 0.5. Prints one JSON object; writes the commanded and simulated path at 200 Hz to
# $OUT/belt_corner.csv (default build/examples: never into the working directory).
set -e
AMCTL=${AMCTL:-build/release/apps/amctl/amctl}
OUT=${OUT:-build/examples}
mkdir -p "$OUT"
"$AMCTL" simulate examples/30_belt_corner.gcode --machine examples/30_belt_corner_printer.cfg \
  --natural-frequency-hz 15.915494309189533 --damping-ratio 0.5 --sample-rate-hz 1000 \
  --csv "$OUT/belt_corner.csv" --csv-rate-hz 200 --json
# Tables 3.2 and 3.3 of the thesis with the real look-ahead and with zero junction speed:
"$AMCTL" sweep
