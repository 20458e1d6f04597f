#!/usr/bin/env python3
"""Measures Klipper's own print time (batch mode) for SAVE_/RESTORE_GCODE_STATE,
[exclude_object], an IDEX ([dual_carriage] on cartesian and hybrid_corexy, [dual_carriage NAME]
on generic_cartesian) and a print with start/end macros (README.md,
"G-code state, exclude_object and IDEX").

Usage (Debian's python3; Klipper needs python3-greenlet, -cffi, -serial, -jinja2):
    /usr/bin/python3 gstate_times.py KLIPPER_DIR KLIPPER_DICT > klipper_times_gstate.json

Each case is a printer.cfg of this directory, a set-up that is not timed (G28: Klipper's
homing moves take time amctl does not count) and an input. Klipper reads the set-up, `M400`, a
REPORT_PRINT_TIME mark (a [gcode_macro] of the cfg printing printer.toolhead.print_time), the
input, `M400` and a second mark; the difference is Klipper's motion time (`motion_stock_s`,
unmodified batch mode). A `!!` error or "out of range" in Klipper's log fails the run. amctl
reads the set-up and the input (tests/plan/klipper_gstate_test.cpp).
"""
import json
import os
import subprocess
import sys

import batch_time

HERE = os.path.dirname(os.path.abspath(__file__))

# (key, cfg, set-up, input[, tolerance_s]): paths relative to this directory.
CASES = [
    ("cartesian/syn_gcode_state", "gstate_cartesian.cfg", "G28\n", "syn_gcode_state.gcode"),
    ("cartesian/syn_exclude_object", "gstate_cartesian.cfg", "G28\n", "syn_exclude_object.gcode"),
    ("idex_cartesian/syn_idex", "idex_cartesian.cfg", "G28\n", "syn_idex.gcode"),
    ("idex_hybrid_corexy/syn_idex", "idex_hybrid_corexy.cfg", "G28\n", "syn_idex.gcode"),
    # generic_cartesian dual carriages on X and Y, chosen by name (SET_DUAL_CARRIAGE
    # CARRIAGE=carriage_u), both axes restored in one move.
    ("idex_generic_cartesian/syn_gc_idex", "idex_generic_cartesian.cfg", "G28\n",
     "syn_gc_idex.gcode"),
    # A print whose start and end G-code are macros (tests/reference/macro: PRINT_START with a
    # heat soak and a purge line, a renamed M109, PRINT_END). Batch mode skips heater waits
    # without stopping the toolhead (heaters.py returns at once with debug output); a printer
    # stops for M109, and so does amctl: 2.3 ms here (docs/macros.md).
    ("macro/print", "../macro/klipper_batch.cfg", "SET_KINEMATIC_POSITION X=120 Y=120 Z=120\n",
     "../macro/print.gcode", 0.005),
]

def run(klipper, dictionary, cfg, setup, source):
    with open(os.path.join(HERE, source), encoding="utf-8") as f:
        body = f.read()
    return batch_time.motion_time(klipper, dictionary, os.path.join(HERE, cfg), body,
                                  before=setup, label=f"{cfg} {source}")


def main():
    klipper, dictionary = sys.argv[1:3]
    commit = subprocess.run(["git", "-C", klipper, "rev-parse", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    out = {"klipper_commit": commit}
    for key, cfg, setup, source, *tolerance in CASES:
        out[key] = {"motion_stock_s": run(klipper, dictionary, cfg, setup, source),
                    "cfg": cfg, "setup": setup, "input": source,
                    "tolerance_s": tolerance[0] if tolerance else 1e-6}
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()


if __name__ == "__main__":
    main()
