#!/usr/bin/env python3
"""Seed 000's sweep (tables 3.2 and 3.3) through `amctl compensate --method collocation` with a
base acceleration bound: per case the grid size, IPOPT's status and iterations, the largest
Hermite-Simpson defect (the thesis's "feasibility"), the peak command acceleration against the
bound, the tracking error against the uncompensated one, and the compute time.

Usage: scripts/collocation_sweep.py [AMCTL] [--max-base-accel-mm-s2 A] [--markdown]
(AMCTL defaults to build/release/apps/amctl/amctl; A to 10000). Prints a table."""
import json, math, os, subprocess, sys, tempfile

args = [a for a in sys.argv[1:]]
markdown = "--markdown" in args
if markdown:
    args.remove("--markdown")
limit = 10000.0
if "--max-base-accel-mm-s2" in args:
    i = args.index("--max-base-accel-mm-s2")
    limit = float(args[i + 1])
    del args[i:i + 2]
amctl = args[0] if args else "build/release/apps/amctl/amctl"
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
cfg = os.path.join(root, "examples/30_belt_corner_printer.cfg")

base = dict(w=100.0, z=0.5, a=5000.0, v=100.0, h=0.005)
cases = [("base", {})]
cases += [(f"1 w={w:g}", {"w": w}) for w in (50, 200, 500)]
cases += [(f"2 z={z:g}", {"z": z}) for z in (0, 1, 2)]
cases += [(f"3 a={a:g}", {"a": a}) for a in (1000, 10000)]
cases += [(f"4 v={v:g}", {"v": v}) for v in (50, 200)]
cases += [(f"5 h={h:g}", {"h": h}) for h in (0.01, 0.001, 0.0002)]

rows = []
with tempfile.TemporaryDirectory() as tmp:
    for name, change in cases:
        p = dict(base, **change)
        gcode = os.path.join(tmp, "path.gcode")
        f = p["v"] * 60
        with open(gcode, "w") as g:
            g.write(f"G90\nG1 X0 Y0 F{f:g}\nG1 X10 Y0 F{f:g}\nG1 X10 Y10 F{f:g}\n")
        cmd = [amctl, "compensate", gcode, "--machine", cfg, "--set", f"printer.max_accel={p['a']:g}",
               "--method", "collocation", "--natural-frequency-hz", repr(p["w"] / (2 * math.pi)),
               "--damping-ratio", repr(p["z"]), "--sample-rate-hz", repr(1.0 / p["h"]),
               "--max-base-accel-mm-s2", repr(limit), "--csv", os.path.join(tmp, "c.csv"), "--json"]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if not run.stdout.strip():
            sys.exit(f"{name}: {run.stderr.strip()}")
        r = json.loads(run.stdout)
        rows.append((name, r))

head = ["case", "samples", "status", "iter", "max defect mm", "peak accel mm/s^2",
        "max err um", "uncomp. um", "compute s"]
def cells(name, r):
    fmt = lambda v, spec: "-" if v is None else format(v, spec)
    return [name, str(r["samples"]), r["status"], str(r.get("solver_iterations", "")),
            fmt(r.get("max_defect_mm"), ".1e"), fmt(r.get("peak_command_accel_mm_s2"), ".0f"),
            fmt(None if r["status"] != "ok" else r["max_tracking_error_mm"] * 1e3, ".3f"),
            fmt(r["uncompensated_max_tracking_error_mm"] * 1e3, ".0f"), fmt(r["compute_time_s"], ".3f")]
if markdown:
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name, r in rows:
        print("| " + " | ".join(cells(name, r)) + " |")
else:
    w = [max(len(head[i]), *(len(cells(n, r)[i]) for n, r in rows)) for i in range(len(head))]
    print("  ".join(h.rjust(w[i]) for i, h in enumerate(head)))
    for name, r in rows:
        print("  ".join(c.rjust(w[i]) for i, c in enumerate(cells(name, r))))
