#!/usr/bin/env python3
"""Every bundled example fits the printer it is bundled with, and heats up sanely.

A new user's first command is `make demo`: a bundled G-code on a bundled printer. This check
keeps that first impression clean for every example, not only the demo's:

* every G-code under examples/ is listed in EXAMPLES with its printer (a new example without
  one fails here), and every slicer profile under examples/slicer/ in SLICER_PROFILES;
* `amctl estimate --json` of each example on its printer reports no move out of the
  printer's range, no unknown command, no warning, and every macro the file calls expanded;
* each heater waits at one temperature only (no bed 100 -> 60 C, hotend 200 -> 240 C),
  the slicer's first-layer temperature when the file records it;
* each slicer profile's bed lies inside its printer's position limits, and the parameters
  its start G-code passes to a printer macro are the ones the macro reads.

usage: examples_fit.py AMCTL SOURCE_DIR
"""
import json
import pathlib
import re
import subprocess
import sys

# G-code example (relative to the source) -> the printer it is bundled with.
EXAMPLES = {
    "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode": "configs/klipper-voron-v0.cfg",
    "examples/30_belt_corner.gcode": "examples/30_belt_corner_printer.cfg",
}
# Slicer profile -> the printer it slices for.
SLICER_PROFILES = {
    "examples/slicer/klipper_voron.ini": "configs/klipper-voron-v0.cfg",
}
HEATER_WAIT = re.compile(r"^M(?:190|109)\s+(\w+)\s+([-0-9.]+) C \(wait\)$")


def amctl_json(amctl, *args):
    p = subprocess.run([amctl, *args, "--json"], capture_output=True, text=True)
    if p.returncode != 0:
        raise AssertionError(f"amctl {' '.join(args)}: exit {p.returncode}: {p.stderr.strip()}")
    return json.loads(p.stdout)


def slicer_settings(text):
    """The `; key = value` settings PrusaSlicer writes at the end of its G-code or in an .ini."""
    out = {}
    for line in text.splitlines():
        m = re.match(r"^;?\s*([a-z_0-9]+) = (.*)$", line)
        if m:
            out[m.group(1)] = m.group(2)
    return out


def check_gcode(amctl, src, gcode, printer):
    errors = []
    r = amctl_json(amctl, "estimate", str(src / gcode), "--machine", str(src / printer))
    where = f"{gcode} on {printer}"
    if r.get("range_error"):
        e = r["range_error"]
        errors.append(f"{where}: line {e['line']}: {e['axis']} = {e['position_mm']} mm is beyond "
                      f"the printer's limit {e['limit_mm']} mm")
    for u in r["unknown_commands"]:
        errors.append(f"{where}: unknown command {u['name']} (line {u['first_line']})")
    for w in r["warnings"]:
        errors.append(f"{where}: warning: {w}")
    for m in r["macros"]:
        if m["skipped"]:
            errors.append(f"{where}: macro {m['name']} skipped: {m['skip_reason']}")
    waits = {}
    for h in r["heater_waits"]:
        m = HEATER_WAIT.match(h["what"])
        if not m:
            errors.append(f"{where}: heater wait not understood: {h['what']}")
            continue
        waits.setdefault(m.group(1), []).append((float(m.group(2)), h["line"]))
    for heater, ws in waits.items():
        temps = sorted({t for t, _ in ws})
        if len(temps) > 1:
            errors.append(f"{where}: the {heater} waits at {len(temps)} temperatures "
                          f"({', '.join(f'{t:g} C at line {l}' for t, l in ws)}), expected one")
    settings = slicer_settings((src / gcode).read_text())
    for heater, key in (("bed", "first_layer_bed_temperature"), ("hotend", "first_layer_temperature")):
        if key in settings and heater in waits:
            want = float(settings[key].split(",")[0])
            if waits[heater][0][0] != want:
                errors.append(f"{where}: the {heater} first waits at {waits[heater][0][0]:g} C, "
                              f"the slicer's {key} is {want:g} C")
    return errors


def check_profile(amctl, src, ini, printer):
    errors = []
    s = slicer_settings((src / ini).read_text())
    m = amctl_json(amctl, "machine", "show", str(src / printer))
    where = f"{ini} for {printer}"
    pts = [tuple(float(v) for v in p.split("x")) for p in s.get("bed_shape", "").split(",") if p]
    if not pts:
        errors.append(f"{where}: no bed_shape")
    for axis, i in (("x", 0), ("y", 1)):
        st = m["steppers"].get(axis)
        if not st:
            continue
        lo, hi = st["position_min"], st["position_max"]
        for p in pts:
            if not lo <= p[i] <= hi:
                errors.append(f"{where}: bed_shape {axis} = {p[i]:g} mm lies outside the printer's "
                              f"position_min..position_max {lo:g}..{hi:g} mm")
    # Parameters passed to printer macros (NAME KEY=VALUE ...) against params.KEY in the macro.
    cfg_text = "".join(p.read_text() for p in (src / printer).parent.glob("*.cfg"))
    for line in s.get("start_gcode", "").split("\\n") + s.get("end_gcode", "").split("\\n"):
        words = line.split(";")[0].split()
        if not words or not re.match(r"^[A-Z_][A-Z0-9_]*$", words[0]) or re.match(r"^[GMT]\d", words[0]):
            continue
        body = re.search(r"^\[gcode_macro " + re.escape(words[0]) + r"\]\n(.*?)(?=^\[|\Z)",
                         cfg_text, re.S | re.M | re.I)
        if not body:
            errors.append(f"{where}: start/end G-code calls {words[0]}, no such macro")
            continue
        read = set(re.findall(r"params\.([A-Z_0-9]+)", body.group(1)))
        for w in words[1:]:
            key = w.split("=", 1)[0].upper()
            if key not in read:
                errors.append(f"{where}: {words[0]} is passed {key}=, the macro reads only "
                              f"{', '.join(sorted(read)) or 'no parameter'}")
    return errors


def main():
    amctl, src = sys.argv[1], pathlib.Path(sys.argv[2])
    errors = []
    listed = set(EXAMPLES)
    for g in sorted(src.glob("examples/**/*.gcode")):
        rel = g.relative_to(src).as_posix()
        if rel not in listed:
            errors.append(f"{rel}: a bundled G-code without its printer: add it to EXAMPLES")
    for ini in sorted(src.glob("examples/slicer/*.ini")):
        rel = ini.relative_to(src).as_posix()
        if rel not in SLICER_PROFILES:
            errors.append(f"{rel}: a slicer profile without its printer: add it to SLICER_PROFILES")
    for g, p in EXAMPLES.items():
        errors += check_gcode(amctl, src, g, p)
    for ini, p in SLICER_PROFILES.items():
        errors += check_profile(amctl, src, ini, p)
    for e in errors:
        print(e)
    print(f"{len(EXAMPLES)} examples, {len(SLICER_PROFILES)} slicer profiles: "
          f"{'FAILED, ' + str(len(errors)) + ' problems' if errors else 'all fit their printers'}")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
