#!/usr/bin/env python3
"""Every real print through the closed-loop stepper simulation (docs/closedloop.md, section 4.3):
each G-code of examples/ and of the shared corpus, on every machine preset and bundled
printer.cfg, open loop and each controller (`amctl stepper simulate FILE --machine M
--controller C --json`). Writes one CSV row per (print, machine, controller) and checks the
figures the closed loop is held to:

  1. no controller loses a step where open loop loses none;
  2. feedforward's maximum and rms tracking error are at most open loop's on each axis;
  3. feedforward never runs at the drive's step-rate cap (step_rate_limited_periods == 0).

Usage: scripts/closedloop_sweep.py [--amctl PATH] [--jobs N] [--csv OUT] [--prints P ...]
       [--machines M ...] [--controllers C ...] [--head-lines N]
--head-lines N runs every corpus print longer than N lines on its first N lines only (a copy in
a temporary directory; the CSV's print column says "first N lines"), for a sweep that must fit a
time budget; the bundled examples always run whole.
Defaults: build/release/apps/amctl/amctl, 2 jobs, no CSV, every print, machine and controller.
Exit status 1 when a figure fails (the failures are listed), 0 otherwise. Machines without
stepper sections run on the default drive train (the simulation says so in its notes); a
machine file that is not a printer.cfg (an include) is listed as skipped with the reason."""
import argparse, concurrent.futures, csv, glob, itertools, json, os, subprocess, sys, tempfile, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONTROLLERS = ["open", "encoder-sequenced", "speed-tracking", "pid", "feedforward"]


def default_prints():
    prints = sorted(glob.glob(os.path.join(ROOT, "examples", "**", "*.gcode"), recursive=True))
    prints += sorted(glob.glob("/work/shared/corpus/gcode/*.gcode"))
    return prints


def default_machines(amctl):
    out = subprocess.run([amctl, "machine", "list"], capture_output=True, text=True, check=True)
    presets = [line.split()[0] for line in out.stdout.splitlines() if line.strip()]
    cfgs = sorted(glob.glob(os.path.join(ROOT, "configs", "*.cfg")))
    cfgs += sorted(glob.glob(os.path.join(ROOT, "examples", "**", "*.cfg"), recursive=True))
    return presets + cfgs


def run(amctl, gcode, machine, controller):
    t0 = time.process_time()
    start = time.time()
    p = subprocess.run([amctl, "stepper", "simulate", gcode, "--machine", machine,
                        "--controller", controller, "--json"], capture_output=True, text=True)
    wall = time.time() - start
    if p.returncode != 0:
        return {"error": p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}",
                "exit": p.returncode}
    r = json.loads(p.stdout)
    r["wall_s"] = wall
    return r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--amctl", default=os.path.join(ROOT, "build/release/apps/amctl/amctl"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--csv")
    ap.add_argument("--prints", nargs="*")
    ap.add_argument("--machines", nargs="*")
    ap.add_argument("--controllers", nargs="*", default=CONTROLLERS)
    ap.add_argument("--head-lines", type=int, default=0)
    a = ap.parse_args()
    prints = a.prints or default_prints()
    labels = {g: os.path.basename(g) for g in prints}
    if a.head_lines > 0:
        tmp = tempfile.mkdtemp(prefix="closedloop_sweep_")
        headed = []
        for g in prints:
            with open(g, "rb") as f:
                lines = list(itertools.islice(f, a.head_lines + 1))
            if len(lines) <= a.head_lines or os.path.abspath(g).startswith(os.path.join(ROOT, "examples")):
                headed.append(g)
                continue
            h = os.path.join(tmp, os.path.basename(g))
            with open(h, "wb") as f:
                f.writelines(lines[:a.head_lines])
            labels[h] = f"{os.path.basename(g)} (first {a.head_lines} lines)"
            headed.append(h)
        prints = headed
    machines = a.machines or default_machines(a.amctl)
    jobs = [(g, m, c) for g in prints for m in machines for c in a.controllers]
    results = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as ex:
        futs = {ex.submit(run, a.amctl, g, m, c): (g, m, c) for g, m, c in jobs}
        for f in concurrent.futures.as_completed(futs):
            key = futs[f]
            results[key] = f.result()
            r = results[key]
            tag = r.get("error") or " ".join(
                f"{n}: max {x['max_tracking_error_mm']:.4f} rms {x['rms_tracking_error_mm']:.4f} "
                f"lost {x['lost_full_steps']}" for n, x in r["axes"].items())
            print(f"{labels[key[0]]} | {os.path.basename(key[1])} | {key[2]} | {tag}",
                  flush=True)
    rows, failures, skipped = [], [], set()
    for g in prints:
        for m in machines:
            open_r = results.get((g, m, "open"))
            for c in a.controllers:
                r = results[(g, m, c)]
                name = f"{labels[g]} on {os.path.basename(m)}, {c}"
                if "error" in r:
                    skipped.add((labels[g], os.path.basename(m), r["error"]))
                    continue
                for axis, x in r["axes"].items():
                    rows.append({"print": labels[g], "machine": os.path.basename(m),
                                 "controller": c, "axis": axis,
                                 "duration_s": r["duration_s"],
                                 "max_error_mm": x["max_tracking_error_mm"],
                                 "rms_error_mm": x["rms_tracking_error_mm"],
                                 "max_path_error_mm": x["max_path_error_mm"],
                                 "lost_full_steps": x["lost_full_steps"],
                                 "max_load_angle_deg": x["max_load_angle_deg"],
                                 "peak_step_rate_hz": x["peak_step_rate_hz"],
                                 "step_rate_limited_periods": x["step_rate_limited_periods"],
                                 "degraded_moves": x["degraded_moves"],
                                 "lead_capped_periods": x.get("lead_capped_periods", 0),
                                 "rotor_capped_periods": x.get("rotor_capped_periods", 0),
                                 "motor": x["motor"]["name"],
                                 "wall_s": round(r["wall_s"], 2)})
                    if open_r is None or "error" in open_r:
                        continue
                    o = open_r["axes"][axis]
                    if c != "open" and o["lost_full_steps"] == 0 and x["lost_full_steps"] > 0:
                        failures.append(f"{name}: axis {axis} loses {x['lost_full_steps']} full "
                                        f"steps where open loop loses none")
                    if c == "feedforward":
                        for key in ("max_tracking_error_mm", "rms_tracking_error_mm"):
                            if x[key] > o[key] * (1 + 1e-9):
                                failures.append(f"{name}: axis {axis} {key} {x[key]:.4f} above open "
                                                f"loop's {o[key]:.4f}")
                        if x["step_rate_limited_periods"] > 0:
                            failures.append(f"{name}: axis {axis} at the step-rate cap for "
                                            f"{x['step_rate_limited_periods']} periods")
    if a.csv and rows:
        with open(a.csv + ".part", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)
        os.replace(a.csv + ".part", a.csv)
    for s in sorted(skipped):
        print(f"skipped: {s[0]} on {s[1]}: {s[2]}")
    for f in failures:
        print(f"FAIL: {f}")
    ran = len({(r['print'], r['machine'], r['controller']) for r in rows})
    print(f"{ran} runs, {len(skipped)} skipped (print, machine) pairs, {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
