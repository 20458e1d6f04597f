"""Klipper's own motion time of a G-code body in batch mode, shared by kinematics_times.py and
gstate_times.py (README.md). Klipper reads `before`, `M400`, a REPORT_PRINT_TIME mark (a
[gcode_macro] of the cfg printing printer.toolhead.print_time), `inside` and the body, `M400`
and a second mark; the difference of the marks is returned. A `!!` error or "out of range" in
Klipper's log, or a missing mark, ends the run naming the case. Nothing of Klipper is copied:
klippy.py is run from the checkout given.
"""
import os
import re
import subprocess
import tempfile

MARK = re.compile(r"REPORT_PRINT_TIME tag=(\w+) print_time=([0-9.]+)")


def motion_time(klipper, dictionary, cfg_path, body, before="", inside="", label=""):
    with tempfile.TemporaryDirectory() as tmp:
        gcode = os.path.join(tmp, "in.gcode")
        log = os.path.join(tmp, "klippy.log")
        with open(gcode, "w") as f:
            f.write(before + "M400\nREPORT_PRINT_TIME TAG=start\n" + inside + body +
                    "\nM400\nREPORT_PRINT_TIME TAG=end\n")
        subprocess.run(["/usr/bin/python3", os.path.join(klipper, "klippy", "klippy.py"),
                        cfg_path, "-i", gcode, "-o", "/dev/null", "-d", dictionary, "-l", log],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(log, errors="replace") as f:
            text = f.read()
    errors = [l for l in text.splitlines() if l.startswith("!! ") or "out of range" in l]
    if errors:
        raise SystemExit(f"{label}: Klipper reported {errors[:3]}")
    marks = dict(MARK.findall(text))
    if "start" not in marks or "end" not in marks:
        raise SystemExit(f"{label}: no time marks in Klipper's log")
    return float(marks["end"]) - float(marks["start"])
