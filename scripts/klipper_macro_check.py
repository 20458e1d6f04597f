#!/usr/bin/python3
"""Runs every [gcode_macro] of Klipper's own config/ directory through amctl: one print that
calls each macro once (no parameters, so each takes its defaults) on a small printer with
those macros, and prints what amctl did with each (expanded, or skipped and why). Klipper's
files are read from a checkout or a bare mirror, never copied here.

    scripts/klipper_macro_check.py [KLIPPER_GIT_DIR] [--amctl build/release/apps/amctl/amctl]

Default git dir: /work/.mirror/Klipper3d+klipper/repo. Measured figures: docs/macros.md."""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

BASE = """[printer]
kinematics: cartesian
max_velocity: 300
max_accel: 3000
[stepper_x]
rotation_distance: 40
microsteps: 16
position_max: 235
[stepper_y]
rotation_distance: 40
microsteps: 16
position_max: 235
[stepper_z]
rotation_distance: 8
microsteps: 16
position_max: 250
[extruder]
nozzle_diameter: 0.4
filament_diameter: 1.75
[heater_bed]
[gcode_arcs]
"""


def git(gitdir, *args):
    return subprocess.run(["git", "--git-dir", gitdir, *args], check=True,
                          capture_output=True, text=True).stdout


def macro_sections(text):
    """The [gcode_macro] sections of one config file, as written."""
    out, cur = [], None
    for line in text.splitlines():
        if line.startswith("["):
            cur = [line] if line.startswith("[gcode_macro ") else None
            if cur is not None:
                out.append(cur)
        elif cur is not None:
            cur.append(line)
    return ["\n".join(s) for s in out]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("gitdir", nargs="?", default="/work/.mirror/Klipper3d+klipper/repo")
    ap.add_argument("--amctl", default="build/release/apps/amctl/amctl")
    a = ap.parse_args()
    files = [f for f in git(a.gitdir, "ls-tree", "-r", "--name-only", "HEAD", "config/").split()
             if f.endswith(".cfg")]
    seen, sections = set(), []
    for f in files:
        for s in macro_sections(git(a.gitdir, "show", "HEAD:" + f)):
            name = s.split("\n", 1)[0].strip("[] ").split()[1].upper()
            if name not in seen:  # the first definition of each name
                seen.add(name)
                sections.append((f, name, s))
    with tempfile.TemporaryDirectory() as tmp:
        cfg = os.path.join(tmp, "printer.cfg")
        with open(cfg, "w") as out:
            out.write(BASE + "\n" + "\n\n".join(s for _, _, s in sections) + "\n")
        gcode = os.path.join(tmp, "calls.gcode")
        with open(gcode, "w") as out:
            out.write("G28\n" + "".join(n + "\n" for _, n, _ in sections))
        r = subprocess.run([a.amctl, "estimate", gcode, "--machine", cfg, "--json"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            print(r.stderr, file=sys.stderr)
            return r.returncode
        report = json.loads(r.stdout)
    macros = {m["name"]: m for m in report["macros"]}
    expanded = 0
    for f, n, _ in sections:
        m = macros.get(n)
        if m is None:
            print(f"{n:28s} {f}: not reached (called from no line)")
            continue
        if m["skipped"] == 0:
            expanded += 1
            print(f"{n:28s} {f}: expanded")
        else:
            print(f"{n:28s} {f}: skipped: {m['skip_reason']}")
    print(f"{expanded} of {len(sections)} macros expanded; unknown commands in their output: "
          + ", ".join(u["name"] for u in report["unknown_commands"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
