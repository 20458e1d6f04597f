#!/usr/bin/env python3
"""Measures Klipper's own print time (batch mode) for amctl's kinematics cross-check.

Usage (Debian's python3; Klipper needs python3-greenlet, -cffi, -serial, -jinja2):
    /usr/bin/python3 kinematics_times.py KLIPPER_DIR KLIPPER_DICT CORPUS_GCODE_DIR > klipper_times_kinematics.json

For each case (a printer.cfg of this directory, a preamble and an input) it writes the input
Klipper reads: `M400` + a REPORT_PRINT_TIME mark, the preamble, the input, `M400` + a second
mark, runs `klippy.py CFG -i INPUT -o /dev/null -d KLIPPER_DICT -l LOG` and records the
difference of the two marks (printer.toolhead.print_time), Klipper's motion time. Any
"Move out of range" or other `!!` error in the log fails the run. The preamble is what amctl
reads too (tests/plan/klipper_kinematics_test.cpp builds the same text).
"""
import json
import os
import subprocess
import sys

import batch_time

HERE = os.path.dirname(os.path.abspath(__file__))

# (key, cfg, preamble, input): input is a file of this directory or "corpus:NAME".
# The benchy of the corpus is centred at (60, 60); G92 moves it to the delta's centre, or to
# (120, 0) where part of it lies in the half-speed ring (r > 141.2 mm).
BENCHY = "corpus:benchy_superslicer-2.3_klipper-v0.gcode"
CASES = [
    ("delta/syn_delta", "delta.cfg", "", "syn_delta.gcode"),
    ("delta/benchy_centre", "delta.cfg", "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG92 X60 Y60 Z0\n", BENCHY),
    ("delta/benchy_edge", "delta.cfg", "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG92 X-60 Y60 Z0\n", BENCHY),
    ("winch/syn_winch", "winch.cfg", "", "syn_winch.gcode"),
    ("winch/benchy", "winch.cfg", "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\n", BENCHY),
    ("deltesian/syn_deltesian", "deltesian.cfg", "", "syn_deltesian.gcode"),
    # The benchy spans x 29.6-89.7 (60 mm): centred on x = 0 it stays inside |x| < 30.2, clear
    # of the slow zone (where Klipper 84104bbb fails, docs/machine.md).
    ("deltesian/benchy", "deltesian.cfg", "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG92 X60 Y00 Z0\n", BENCHY,
     0.05),  # amctl 0.018 s shorter, likely batch-mode runout stops (docs/machine.md, "Deltesian")
    # generic_cartesian: the benchy centred on the bed (150, 100).
    ("generic_cartesian/syn_generic_cartesian", "generic_cartesian.cfg", "", "syn_generic_cartesian.gcode"),
    ("generic_cartesian/benchy", "generic_cartesian.cfg",
     "SET_KINEMATIC_POSITION X=150 Y=100 Z=0\nG92 X60 Y60 Z0\n", BENCHY,
     0.05),  # amctl 0.020 s shorter; Klipper's cartesian twin of the cfg gives the same time (README.md)
    # polar: the benchy centred at (100, 0), where max_angular_velocity binds on the moves
    # nearest the centre. (Centred at (0.5, 0.3), Klipper 84104bbb aborts: docs/machine.md.)
    ("polar/syn_polar", "polar.cfg", "", "syn_polar.gcode"),
    ("polar/benchy_off_centre", "polar.cfg", "SET_KINEMATIC_POSITION X=100 Y=0 Z=0\nG92 X60 Y60 Z0\n", BENCHY),
    ("rotary_delta/syn_rotary_delta", "rotary_delta.cfg", "", "syn_rotary_delta.gcode"),
    ("rotary_delta/benchy", "rotary_delta.cfg", "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG92 X60 Y60 Z0\n", BENCHY),
]

def run(klipper, dictionary, corpus, cfg, preamble, source):
    path = os.path.join(corpus, source[7:]) if source.startswith("corpus:") else os.path.join(HERE, source)
    with open(path, encoding="utf-8", errors="replace") as f:
        body = f.read()
    return batch_time.motion_time(klipper, dictionary, os.path.join(HERE, cfg), body,
                                  inside=preamble, label=f"{cfg} {source}")


def main():
    klipper, dictionary, corpus = sys.argv[1:4]
    commit = subprocess.run(["git", "-C", klipper, "rev-parse", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    out = {"klipper_commit": commit}
    only = sys.argv[4:]
    for key, cfg, preamble, source, *tolerance in CASES:
        if only and not any(key.startswith(o) for o in only):
            continue
        out[key] = {"motion_stock_s": run(klipper, dictionary, corpus, cfg, preamble, source),
                    "cfg": cfg, "preamble": preamble, "input": source,
                    "tolerance_s": tolerance[0] if tolerance else 1e-5}
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()


if __name__ == "__main__":
    main()
