#!/usr/bin/env python3
"""Klipper's own print time and step commands with a bed mesh loaded, for amctl's check
(README.md, "Bed mesh"; docs/bedmesh.md).

Usage (Debian's python3; Klipper needs python3-greenlet, -cffi, -serial, -jinja2):
    /usr/bin/python3 bedmesh_crosscheck.py KLIPPER_DIR CORPUS_GCODE_DIR AMCTL [times|steps]... \
        [--no-runout KLIPPER_COPY_DIR]

Each case is a printer.cfg of this directory, a preamble (SET_KINEMATIC_POSITION and the mesh
load: PRINT_START, a macro of the cfg, or BED_MESH_PROFILE LOAD=default) and an input (a file
here or "corpus:NAME", optionally only its first `head` lines, every G28 replaced by
SET_KINEMATIC_POSITION X=0 Y=0 Z=0 as batch mode has no endstops). The text both programs
read is input_text() below (tests/bedmesh/klipper_bedmesh_test.cpp builds the same).

- times: batch_time.motion_time (a REPORT_PRINT_TIME mark before and after) -> stdout as
  klipper_times_bedmesh.json: `motion_stock_s` from KLIPPER_DIR; with --no-runout, a copy of
  the checkout whose toolhead.py makes no buffer-runout flush (_handle_step_flush returns at
  once, the priming timer flushes nothing: README.md), `motion_s` with the mesh and
  `motion_no_mesh_s` without its load (the preamble's PRINT_START / BED_MESH_PROFILE line
  left out), so that the mesh's own effect on Klipper's time is known
- steps: scripts/klipper_steps_crosscheck.py's compare() (Klipper's queue_step stream decoded,
  amctl steps --step-filter klipper beside it) -> klipper_steps_bedmesh.json in this directory;
  with --no-runout the copy is the Klipper run (a runout stop shifts every later step)
Nothing of Klipper is copied: klippy.py is run from the checkout given.
"""
import json
import os
import re
import subprocess
import sys
import tempfile

import batch_time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "scripts"))

HOME = "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\n"
MACRO = HOME + "PRINT_START\n"                      # corexy: the macro loads 'default'
LOAD = HOME + "BED_MESH_PROFILE LOAD=default\n"    # cartesian: the G-code loads it
SUPER = "corpus:benchy_superslicer-2.3_klipper-v0.gcode"
CURA = "corpus:benchy_cura-5.3.gcode"
IDEA = "corpus:benchy_ideamaker-4.2.gcode"
HEAD = 4000

# (key, cfg, preamble, input, head lines or None)
TIME_CASES = [
    ("corexy/syn_bedmesh", "bedmesh_corexy.cfg", MACRO, "syn_bedmesh.gcode", None),
    ("corexy/benchy_superslicer", "bedmesh_corexy.cfg", MACRO, SUPER, None),
    ("corexy/benchy_cura", "bedmesh_corexy.cfg", MACRO, CURA, None),
    ("cartesian/syn_bedmesh", "bedmesh_cartesian.cfg", LOAD, "syn_bedmesh.gcode", None),
    ("cartesian/benchy_superslicer", "bedmesh_cartesian.cfg", LOAD, SUPER, None),
    ("cartesian/benchy_ideamaker", "bedmesh_cartesian.cfg", LOAD, IDEA, None),
]
STEP_CASES = [
    ("corexy/syn_bedmesh", "bedmesh_corexy.cfg", MACRO, "syn_bedmesh.gcode", None),
    ("corexy/benchy_superslicer_head", "bedmesh_corexy.cfg", MACRO, SUPER, HEAD),
    ("corexy/benchy_cura_head", "bedmesh_corexy.cfg", MACRO, CURA, HEAD),
    ("cartesian/syn_bedmesh", "bedmesh_cartesian.cfg", LOAD, "syn_bedmesh.gcode", None),
    ("cartesian/benchy_superslicer_head", "bedmesh_cartesian.cfg", LOAD, SUPER, HEAD),
    ("cartesian/benchy_ideamaker_head", "bedmesh_cartesian.cfg", LOAD, IDEA, HEAD),
]


def input_text(corpus, preamble, source, head):
    path = os.path.join(corpus, source[7:]) if source.startswith("corpus:") else os.path.join(HERE, source)
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = f.read().split("\n")
    if head is not None:
        lines = lines[:head]
    body = "\n".join(HOME.rstrip("\n") if re.match(r"^\s*G28\b", l, re.I) else l for l in lines)
    return preamble + body + "\nM400\n"


def main():
    args = sys.argv[1:]
    norunout = None
    if "--no-runout" in args:
        i = args.index("--no-runout")
        norunout = args[i + 1]
        del args[i:i + 2]
    klipper, corpus, amctl = args[:3]
    what = args[3:] or ["times", "steps"]
    dictionary = os.path.join(klipper, "out", "klipper.dict")
    commit = subprocess.run(["git", "-C", klipper, "rev-parse", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    if "times" in what:
        out = {"klipper_commit": commit}
        for key, cfg, pre, source, head in TIME_CASES:
            text = input_text(corpus, pre, source, head)
            k = batch_time.motion_time(klipper, dictionary, os.path.join(HERE, cfg), text, label=key)
            out[key] = {"motion_stock_s": k, "cfg": cfg, "preamble": pre, "input": source,
                        "head_lines": head}
            if norunout:
                nd = os.path.join(norunout, "out", "klipper.dict")
                out[key]["motion_s"] = batch_time.motion_time(norunout, nd, os.path.join(HERE, cfg), text,
                                                              label=key)
                plain = input_text(corpus, HOME, source, head)
                out[key]["motion_no_mesh_s"] = batch_time.motion_time(norunout, nd, os.path.join(HERE, cfg),
                                                                      plain, label=key)
            print(key, out[key], file=sys.stderr)
        json.dump(out, sys.stdout, indent=1, sort_keys=True)
        print()
    if "steps" in what:
        import klipper_steps_crosscheck as kx
        results = []
        with tempfile.TemporaryDirectory(prefix="bedmesh_steps_") as tmp:
            for key, cfg, pre, source, head in STEP_CASES:
                gcode = os.path.join(tmp, key.replace("/", "_") + ".gcode")
                with open(gcode, "w") as f:
                    f.write(input_text(corpus, pre, source, head))
                r = kx.compare(norunout or klipper, amctl, os.path.join(HERE, cfg), gcode, "/usr/bin/python3")
                r["klipper_batch_mode"] = "no buffer-runout flush" if norunout else "stock"
                r.update({"case": key, "preamble": pre, "input": source, "head_lines": head})
                results.append(r)
                counts = " ".join("%s=%d/%d%s" % (s["stepper"], s["klipper_steps"], s["amctl_steps_filtered"],
                                                  "" if s["count_equal"] else "!") for s in r["steppers"])
                print("%-5s %-34s max|dt| %8.3f us  %s" % ("ok" if r["ok"] else "DIFF", key,
                                                           r["max_abs_dt_us"], counts), file=sys.stderr)
        with open(os.path.join(HERE, "klipper_steps_bedmesh.json"), "w") as f:
            json.dump({"generated_by": "tests/reference/klipper/bedmesh_crosscheck.py",
                       "klipper_commit": commit, "results": results}, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
