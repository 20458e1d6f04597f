#!/usr/bin/python3
"""Checks every interface the project promised to keep stable, as a new user would run it.

Each row of CONTRACTS is one promise: a command line, a flag, a JSON key (with its nesting and
type), a bundled path, a Python function and keyword, an output format, an exit code for a
named bad input, or a figure the project states as an acceptance threshold that a quick run can
check. Each row runs the real `amctl` binary (and the Python package from `<build>/python`,
with Debian's /usr/bin/python3) and prints PASS or FAIL with what differed.

usage: scripts/contract_check.py [--amctl PATH] [--fast] [-k SUBSTRING] [--list]

  --amctl PATH  the binary (default: build/release/apps/amctl/amctl under the repository)
  --fast        only the rows marked fast (the CTest subset, well under a minute in all)
  -k SUBSTRING  only the rows whose name contains SUBSTRING
  --list        print the table (with the number of the issue that fixed each row) and exit

Exit code 0 when every row run passes, 1 otherwise. Rows that need the shared corpus or an MPI
launcher skip with a note when it is absent; rows over ~20 s run a reduced variant, named in
the row. No network, nothing written outside a temporary directory.
"""
import argparse
import csv
import io
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "reference"))

GCODE = "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode"
V0_CFG = "configs/klipper-voron-v0.cfg"
CORNER = "examples/30_belt_corner.gcode"
CORNER_CFG = "examples/30_belt_corner_printer.cfg"
CORPUS = os.path.normpath(os.path.join(ROOT, "..", "shared", "corpus"))
if not os.path.isdir(CORPUS):
    CORPUS = "/work/shared/corpus"

SMALL_CFG = ("[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
             "square_corner_velocity: 5\n"
             + "".join(f"[{s}]\nstep_pin: P{i}\ndir_pin: D{i}\nrotation_distance: {r}\n"
                       f"microsteps: 16\nposition_min: 0\nposition_max: 200\n"
                       for i, (s, r) in enumerate((("stepper_x", 40), ("stepper_y", 40),
                                                   ("stepper_z", 8))))
             + "[extruder]\nrotation_distance: 33.5\nmicrosteps: 16\nnozzle_diameter: 0.4\n"
             "filament_diameter: 1.75\n")
SMALL_GCODE = ("G28\nG90\nM82\nG92 E0\nG1 X10 Y10 F6000\nG1 X20 Y10 E1 F1800\n"
               "G1 X20 Y20 E2\nG1 X10 Y20 E3\nG1 X10 Y10 E4\nG1 Z5 F600\n")


class Fail(Exception):
    pass


class Skip(Exception):
    pass


class Ctx:
    def __init__(self, amctl, tmp):
        self.amctl = amctl
        self.tmp = tmp
        build = os.path.dirname(os.path.dirname(os.path.dirname(amctl)))
        self.pythonpath = os.path.join(build, "python")
        self._files = {}

    def path(self, name, text=None, data=None):
        """A file in the temporary directory, written once."""
        p = os.path.join(self.tmp, name)
        if name not in self._files:
            if text is not None:
                with open(p, "w") as f:
                    f.write(text)
            elif data is not None:
                with open(p, "wb") as f:
                    f.write(data)
            self._files[name] = p
        return p

    def run(self, *args, stdin=None, timeout=60, cwd=None):
        try:
            return subprocess.run([self.amctl, *args], input=stdin, capture_output=True,
                                  timeout=timeout, cwd=cwd or ROOT)
        except subprocess.TimeoutExpired:
            raise Fail(f"timed out after {timeout} s: amctl {' '.join(args)}")

    def ok(self, *args, **kw):
        p = self.run(*args, **kw)
        if p.returncode != 0:
            raise Fail(f"exit {p.returncode}: amctl {' '.join(args)}: "
                       f"{p.stderr.decode(errors='replace').strip()[:300]}")
        return p.stdout.decode(errors="replace")

    def json(self, *args, **kw):
        out = self.ok(*args, **kw)
        try:
            return json.loads(out)
        except ValueError as e:
            raise Fail(f"not one JSON object on stdout ({e}): {out[:200]}")

    def bad(self, *args, where=None, **kw):
        """A named bad input: exit code 2 and the place on stderr's first line."""
        p = self.run(*args, **kw)
        err = p.stderr.decode(errors="replace")
        if p.returncode != 2:
            raise Fail(f"exit {p.returncode}, expected 2: amctl {' '.join(args)}: {err[:200]}")
        first = err.splitlines()[0] if err.strip() else ""
        if where and where not in first:
            raise Fail(f"stderr does not name {where!r}: {err[:300]}")
        return err

    def py(self, code, timeout=120):
        if not os.path.isdir(os.path.join(self.pythonpath, "amctl")):
            raise Skip(f"no Python package in {self.pythonpath} (built with AMCTL_PYTHON=ON)")
        env = dict(os.environ, PYTHONPATH=self.pythonpath)
        try:
            p = subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, env=env,
                               timeout=timeout, cwd=ROOT)
        except subprocess.TimeoutExpired:
            raise Fail(f"python timed out after {timeout} s")
        if p.returncode != 0:
            raise Fail("python: " + p.stderr.decode(errors="replace").strip()[-600:])
        out = p.stdout.decode().strip().splitlines()
        return json.loads(out[-1]) if out else None


# ---- small checkers -----------------------------------------------------------------------

def get(obj, dotted):
    """obj at a path such as 'klipper.recommended.name' or 'snapshots[].time_s' (a list of
    values for []), Fail naming the missing step."""
    parts = dotted.split(".")
    cur = [obj]
    for part in parts:
        many = part.endswith("[]")
        key = part[:-2] if many else part
        nxt = []
        for c in cur:
            if key:
                if not isinstance(c, dict) or key not in c:
                    have = sorted(c)[:40] if isinstance(c, dict) else type(c).__name__
                    raise Fail(f"no key {dotted!r} (at {key!r}; found {have})")
                c = c[key]
            if many:
                if not isinstance(c, list) or not c:
                    raise Fail(f"{dotted!r}: {key!r} is not a non-empty list")
                nxt.extend(c)
            else:
                nxt.append(c)
        cur = nxt
    return cur if any(p.endswith("[]") for p in parts) else cur[0]


def num(obj, dotted, lo=-math.inf, hi=math.inf):
    v = get(obj, dotted)
    vals = v if isinstance(v, list) and "[]" in dotted else [v]
    for x in vals:
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
            raise Fail(f"{dotted!r} = {x!r}: not a finite number")
        if not lo <= x <= hi:
            raise Fail(f"{dotted!r} = {x!r}: outside the plausible range [{lo}, {hi}]")
    return v


def close(name, got, want, rel=None, abs_=None):
    tol = max(abs_ or 0, (rel or 0) * abs(want))
    if not abs(got - want) <= tol:
        raise Fail(f"{name} = {got!r}, expected {want!r} +- {tol:g}")


def exists(*paths):
    for p in paths:
        if not os.path.exists(os.path.join(ROOT, p)):
            raise Fail(f"{p} does not exist")


def flags(ctx, cmd, *names):
    """Every name is an option of `amctl CMD --help` (accepted by the parser)."""
    text = ctx.ok(*cmd.split(), "--help")
    missing = [n for n in names if n not in text]
    if missing:
        raise Fail(f"amctl {cmd} --help lacks {missing}")


def csv_header(path):
    with open(path, newline="") as f:
        return next(csv.reader(f))


# ---- inputs made here ---------------------------------------------------------------------

def raw_sweep_csv(ctx, f0=5.0, f1=80.0, rate=4.0, accel=4000.0, fn=40.0, zeta=0.1, fs=1600.0):
    """A Klipper raw accelerometer record (#time,accel_x,accel_y,accel_z) of a chirp through one
    base-driven mode: e'' + 2 zeta w e' + w^2 e = -u, measured u + e''. RK4 at 4 substeps."""
    name = f"raw_{fn:g}.csv"
    if name in ctx._files:
        return ctx._files[name]
    w = 2 * math.pi * fn
    lead = 0.5
    dur = (f1 - f0) / rate
    n = int((lead + dur + 1.0) * fs)
    h = 1.0 / fs / 4

    def u(t):
        tau = t - lead
        if tau < 0 or tau > dur:
            return 0.0
        return accel * math.sin(2 * math.pi * (f0 * tau + rate * tau * tau / 2))

    def f(t, e, v):
        return v, -u(t) - 2 * zeta * w * v - w * w * e

    e = v = 0.0
    rows = ["#time,accel_x,accel_y,accel_z"]
    t = 0.0
    for i in range(n):
        a = u(t) + f(t, e, v)[1]
        rows.append(f"{t:.6f},{(i % 3) - 1:.3f},{a:.3f},9800.0")
        for _ in range(4):
            k1 = f(t, e, v)
            k2 = f(t + h / 2, e + h / 2 * k1[0], v + h / 2 * k1[1])
            k3 = f(t + h / 2, e + h / 2 * k2[0], v + h / 2 * k2[1])
            k4 = f(t + h, e + h * k3[0], v + h * k3[1])
            e += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            v += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
            t += h
    return ctx.path(name, text="\n".join(rows) + "\n")


def small(ctx):
    return ctx.path("small.gcode", SMALL_GCODE), ctx.path("small.cfg", SMALL_CFG)


# ---- the contracts --------------------------------------------------------------------------
# Each function takes the context and raises Fail (or Skip) or returns a short note.

def c_estimate_json_total(ctx):
    d = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--json")
    t = num(d, "total_time_s", 60, 1e5)
    for k in ("layers", "features", "heater_waits", "unknown_commands"):
        get(d, k)
    num(d, "planner.forced_flushes", 0, 0)
    return f"total_time_s {t:.1f}"


def c_estimate_keys_readme(ctx):
    d = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--json")
    for k in ("motion_time_s", "dwell_time_s", "extrude_only_time_s", "travel_time_s",
              "extrude_time_s", "filament_mm", "filament_volume_mm3", "moves",
              "slicer_estimate_s", "travel_mm", "macros", "pauses", "file_limits"):
        get(d, k)
    if "PRINT_START" not in json.dumps(d["macros"]):
        raise Fail("macros does not name the expanded PRINT_START")
    if not isinstance(d["layers"], list) or not isinstance(d["features"], (list, dict)):
        raise Fail("layers must be a list, features a list or object")


def c_estimate_set_kinematic_position(ctx):
    g = ctx.path("skp.gcode", "G28\nSET_KINEMATIC_POSITION X=10 Y=10 Z=5\nG1 X20 F6000\n")
    d = ctx.json("estimate", g, "--machine", V0_CFG, "--json")
    names = json.dumps(d["unknown_commands"])
    if "SET_KINEMATIC_POSITION" in names:
        raise Fail("SET_KINEMATIC_POSITION reported as unknown")
    num(d, "total_time_s", 0, 10)


def c_estimate_bad_line_col(ctx):
    g = ctx.path("bad.gcode", "G28\nG1 X10 F6000\nG1 X20 F-5\n")
    ctx.bad("estimate", g, "--machine", V0_CFG, "--json", where=f"{g}:3:")


def c_estimate_default_machine_and_presets(ctx):
    d = ctx.json("estimate", GCODE, "--json")
    num(d, "total_time_s", 60, 1e5)
    out = ctx.ok("machine", "list")
    for p in ("voron02", "voron24", "creality-k1", "ender3-v3", "prusa-mk4", "prusa-mini",
              "prusa-mk3s", "bambu-p1", "ender3", "default"):
        if p not in out:
            raise Fail(f"preset {p} missing from machine list")
    for p in ("voron24", "prusa-mk3s", "ender3"):
        num(ctx.json("estimate", GCODE, "--machine", p, "--json"), "total_time_s", 60, 1e5)
    num(ctx.json("estimate", GCODE, "--machine", "configs/prusa-mk3s.toml", "--json"),
        "total_time_s", 60, 1e5)


def c_estimate_set_override(ctx):
    a = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--json", "--file-limits", "ignore")
    b = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--json", "--file-limits", "ignore",
                 "--set", "printer.max_accel=1000")
    if not b["total_time_s"] > a["total_time_s"]:
        raise Fail("--set printer.max_accel=1000 did not lengthen the print")


def c_estimate_write_m73(ctx):
    out = os.path.join(ctx.tmp, "m73.gcode")
    ctx.ok("estimate", GCODE, "--machine", "prusa-mk3s", "--write-m73", out)
    with open(out) as f:
        text = f.read()
    if "M73 P" not in text or " R" not in text:
        raise Fail("no M73 P.. R.. lines written")


def c_estimate_brief_one_line(ctx):
    out = ctx.ok("estimate", GCODE, "--machine", V0_CFG, "--brief")
    if len(out.strip().splitlines()) != 1:
        raise Fail(f"--brief printed {len(out.strip().splitlines())} lines")


def c_skeleton_paths(ctx):
    exists("Makefile", "CMakePresets.json", "scripts/install-deps.sh", ".ci/run",
           "scripts/snapshot_outputs.sh", "scripts/measure_streaming_rss.sh",
           "scripts/bench_estimate.sh", "scripts/count_instructions.sh",
           "scripts/module_graph.sh", "docs/machine.md", "docs/planner.md", "docs/gcode.md")
    with open(os.path.join(ROOT, "CMakePresets.json")) as f:
        presets = {p["name"] for p in json.load(f).get("configurePresets", [])}
    for p in ("release", "debug", "asan", "fuzz"):
        if p not in presets:
            raise Fail(f"CMake preset {p} missing")
    with open(os.path.join(ROOT, "Makefile")) as f:
        mk = f.read()
    for t in ("demo:", "test:", "fuzz:", "bench:"):
        if t not in mk:
            raise Fail(f"make target {t[:-1]} missing")
    with open(os.path.join(ROOT, "CMakeLists.txt")) as f:
        if "AMCTL_FUZZ" not in f.read():
            raise Fail("AMCTL_FUZZ option missing")


def c_estimate_compare_profiles(ctx):
    out = ctx.ok("estimate", GCODE, "--machine", V0_CFG, "--compare-profiles")
    for p in ("trapezoid", "bezier5", "scurve7"):
        if p not in out:
            raise Fail(f"--compare-profiles lacks {p}")


def c_simulate_json(ctx):
    d = ctx.json("simulate", CORNER, "--machine", CORNER_CFG, "--natural-frequency-hz",
                 "15.915", "--damping-ratio", "0.5", "--json")
    num(d, "motion_time_s", 0, 10)
    e = num(d, "max_contour_error_mm", 0, 10)
    num(d, "rms_contour_error_mm", 0, e)
    # The thesis' base case (Table 3.2), full stop at the corner: 0.4636 mm.
    close("max_contour_error_mm (base case)", e, 0.4636, abs_=5e-4)
    return f"max {e:.4f} mm"


def c_simulate_same_plan_as_estimate(ctx):
    s = ctx.json("simulate", GCODE, "--machine", V0_CFG, "--natural-frequency-hz", "40",
                 "--damping-ratio", "0.1", "--json", "--sample-rate-hz", "200")
    e = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--json")
    if abs(s["motion_time_s"] - e["motion_time_s"]) > 1e-6:
        raise Fail(f"simulate motion_time_s {s['motion_time_s']!r}, estimate motion_time_s "
                   f"{e['motion_time_s']!r} (total {e['total_time_s']!r})")


def c_simulate_scv0_full_stop(ctx):
    a = ctx.json("simulate", CORNER, "--machine", CORNER_CFG, "--natural-frequency-hz", "15.915",
                 "--damping-ratio", "0.5", "--json", "--set", "printer.square_corner_velocity=5")
    b = ctx.json("simulate", CORNER, "--machine", CORNER_CFG, "--natural-frequency-hz", "15.915",
                 "--damping-ratio", "0.5", "--json", "--set", "printer.square_corner_velocity=0")
    if not b["motion_time_s"] > a["motion_time_s"]:
        raise Fail("square_corner_velocity=0 did not stop at the corner (no longer time)")


def c_simulate_bad_damping(ctx):
    ctx.bad("simulate", CORNER, "--machine", CORNER_CFG, "--natural-frequency-hz", "40",
            "--damping-ratio", "-0.1", "--json", where="--damping-ratio")


def c_simulate_shaper_flags(ctx):
    flags(ctx, "simulate", "--shaper", "--shaper-freq-hz", "--shaper-x", "--shaper-freq-x-hz",
          "--shaper-y", "--shaper-freq-y-hz", "--natural-frequency-y-hz", "--damping-ratio-y",
          "--mode", "--csv", "--t-begin", "--t-end", "--layer-begin", "--layer-end",
          "--motor-space")
    d = ctx.json("simulate", CORNER, "--machine", CORNER_CFG, "--natural-frequency-hz", "15.915",
                 "--damping-ratio", "0.5", "--shaper", "mzv", "--shaper-freq-hz", "15.915",
                 "--json")
    num(d, "max_contour_error_mm", 0, 10)


def c_simulate_motor_space_nonlinear(ctx):
    cfg = ctx.path("delta.cfg", "[printer]\nkinematics: delta\nmax_velocity: 300\n"
                   "max_accel: 3000\ndelta_radius: 100\n"
                   + "".join(f"[stepper_{s}]\nstep_pin: P\ndir_pin: D\nrotation_distance: 40\n"
                             f"microsteps: 16\narm_length: 200\nposition_endstop: 250\n"
                             for s in "abc"))
    g = ctx.path("delta.gcode", "G28\nG1 X10 Y10 Z10 F6000\nG1 X20\n")
    ctx.bad("simulate", g, "--machine", cfg, "--natural-frequency-hz", "40", "--damping-ratio",
            "0.1", "--motor-space", "--json", where="--motor-space")


def c_sweep_table(ctx):
    out = ctx.ok("sweep")
    if "0.46" not in out:
        raise Fail("sweep table lacks the base case's 0.46 mm")
    d = ctx.json("sweep", "--json")
    if not d:
        raise Fail("sweep --json empty")


def c_sls_margins(ctx):
    d = ctx.json("thermal", "sls-margins", "--kp", "0.3", "--ti", "0.5", "--modes", "1", "--json")
    close("margin_on_GN", num(d, "margin_on_GN"), 2.639e-3, rel=2e-3)
    close("margin_on_G", num(d, "margin_on_G"), 2.686e-3, rel=2e-3)
    close("hinf_G_minus_GN", num(d, "hinf_G_minus_GN"), 4.6675e-5, rel=2e-3)


def c_sls_margins_bad_ti(ctx):
    ctx.bad("thermal", "sls-margins", "--kp", "0.3", "--ti", "0", "--modes", "1", "--json",
            where="--ti")


def c_thermal_sls_config(ctx):
    exists("configs/sls_pa12.toml")
    ctx.ok("thermal", "sls", "--config", "configs/sls_pa12.toml", "--layers", "5",
           "--csv", os.path.join(ctx.tmp, "sls.csv"))
    ctx.ok("thermal", "hotend", "--help")
    ctx.ok("thermal", "bed", "--help")


def c_shrink_fit(ctx):
    d = ctx.json("shrink", "fit", "examples/04_shrink_geometry1.csv", "--json")
    s, i, c = num(d, "slope"), num(d, "intercept"), num(d, "factor")
    close("factor = 1/(1+slope)", c, 1 / (1 + s), rel=1e-12)
    close("factor (Table 1)", c, 1.00311, abs_=5e-5)
    return f"C = {c:.5f}"


def c_shrink_fit_minimal_csv(ctx):
    rows = "nominal_mm,measured_mm,note\n" + "".join(
        f"{n},{n * 0.99 + 0.1 + (0.01 if k % 2 else -0.01)},x\n"
        for k, n in enumerate((10, 20, 30, 40, 50, 60)))
    d = ctx.json("shrink", "fit", ctx.path("shrink.csv", rows), "--json")
    close("slope", num(d, "slope"), -0.01, abs_=1e-3)
    close("factor", num(d, "factor"), 1 / (1 + d["slope"]), rel=1e-12)


def c_shrink_apply_and_empirical(ctx):
    flags(ctx, "shrink apply", "--model", "--gcode", "--factors", "-o")
    d = ctx.json("estimate", GCODE, "--mode", "empirical", "--json")
    num(d, "total_time_s", 1, 1e6)
    flags(ctx, "calibrate-time", "--keep-file-limits", "--file-limits", "--machine")


def c_shaper_show(ctx):
    d = ctx.json("shaper", "show", "--type", "mzv", "--freq-hz", "40", "--damping-ratio", "0.1",
                 "--residual-at-hz", "30,40,60", "--test-damping-ratio", "0.1", "--json")
    # Klipper's MZV, unnormalised: K = exp(-0.75 zeta pi / sqrt(1 - zeta^2)).
    z, f = 0.1, 40.0
    df = math.sqrt(1 - z * z)
    k = math.exp(-0.75 * z * math.pi / df)
    t_d = 1 / (f * df)
    a1 = 1 - 1 / math.sqrt(2)
    want_a = [a1, (math.sqrt(2) - 1) * k, a1 * k * k]
    want_t = [0, 0.375 * t_d, 0.75 * t_d]
    a, t = get(d, "amplitudes"), get(d, "times_s")
    if len(a) != 3 or len(t) != 3:
        raise Fail(f"mzv has {len(a)} amplitudes, {len(t)} times")
    for x, y in zip(a, want_a):
        close("amplitude", x, y, abs_=1e-9)
    for x, y in zip(t, want_t):
        close("time_s", x, y, abs_=1e-9)
    num(d, "smoothing_mm", 0, 1)
    num(d, "max_accel_mm_s2", 100, 1e6)
    r = get(d, "residual_vibration")
    if not isinstance(r, list) or len(r) != 3:
        raise Fail(f"residual_vibration = {r!r}: expected one value per asked frequency")


def c_shaper_marlin(ctx):
    d = ctx.json("shaper", "show", "--type", "mzv", "--freq-hz", "40", "--damping-ratio", "0.1",
                 "--firmware", "marlin", "--json")
    get(d, "amplitudes")


def c_shaper_bad_freq(ctx):
    ctx.bad("shaper", "show", "--type", "mzv", "--freq-hz", "0", "--damping-ratio", "0.1",
            "--json", where="--freq-hz")


def c_resonance_calibrate_psd(ctx):
    f = "tests/reference/resonance/calibration_data_y_sweep_1.csv"
    d = ctx.json("resonance", "calibrate", f, "--axis", "y", "--json")
    name = get(d, "klipper.recommended.name")
    fr = num(d, "klipper.recommended.freq_hz", 1, 200)
    if not isinstance(name, str):
        raise Fail("klipper.recommended.name is not a string")
    for k in ("name", "freq_hz", "vibrations", "smoothing", "max_accel_mm_s2"):
        get(d, f"klipper.shapers[].{k}")
    num(d, "klipper.shapers[].vibrations", 0, 1)
    return f"{name} {fr:.1f} Hz"


def c_resonance_calibrate_sweep(ctx):
    raw = raw_sweep_csv(ctx)
    csv_out = os.path.join(ctx.tmp, "psd.csv")
    d = ctx.json("resonance", "calibrate", raw, "--axis", "y", "--sweep", "5,80,4,4000",
                 "--json", "--csv", csv_out)
    fn = num(d, "model.natural_frequency_hz", 1, 500)
    z = num(d, "model.damping_ratio", 0, 1)
    close("model.natural_frequency_hz", fn, 40.0, rel=0.01)
    close("model.damping_ratio", z, 0.1, rel=0.1)
    get(d, "klipper.recommended.name")
    if not os.path.getsize(csv_out):
        raise Fail("--csv wrote nothing")
    return f"{fn:.2f} Hz, zeta {z:.3f}"


def c_resonance_calibrate_corpus(ctx):
    f = os.path.join(CORPUS, "accel", "ender3v2neo_y_sweep_1.csv")
    if not os.path.exists(f):
        raise Skip("corpus absent")
    d = ctx.json("resonance", "calibrate", f, "--axis", "y", "--json")
    close("recommended freq (Klipper picks MZV ~25.7 Hz)",
          num(d, "klipper.recommended.freq_hz"), 25.7, abs_=0.5)


def c_resonance_bad_csv(ctx):
    f = ctx.path("bad_accel.csv", "#time,accel_x,accel_y,accel_z\n0.0,1,2,3\n0.001,1,nan,3\n")
    ctx.bad("resonance", "calibrate", f, "--axis", "y", "--json", where=f"{f}:3")


def c_resonance_test_gcode(ctx):
    out = os.path.join(ctx.tmp, "res_x.gcode")
    ctx.ok("resonance", "test-gcode", "--machine", "voron24", "--axis", "x", "-o", out)
    if os.path.getsize(out) < 100:
        raise Fail("test program nearly empty")
    d = ctx.json("estimate", out, "--machine", "voron24", "--json")
    num(d, "total_time_s", 1, 1e4)
    ctx.ok("resonance", "test-gcode", "--machine", "voron24", "--axis", "y", "-o", out)


def c_compensate(ctx, method="fbf", extra=()):
    out = os.path.join(ctx.tmp, f"cmd_{method}.csv")
    d = ctx.json("compensate", CORNER, "--machine", CORNER_CFG, "--method", method,
                 "--natural-frequency-hz", "15.915", "--damping-ratio", "0.5", *extra,
                 "--csv", out, "--json", timeout=60)
    h = csv_header(out)
    if h[:3] != ["time_s", "x_cmd_mm", "y_cmd_mm"]:
        raise Fail(f"CSV header starts {h[:3]}")
    for k in ("motion_time_s", "compute_time_s", "real_time_factor", "max_contour_error_mm",
              "lead_in_s"):
        num(d, k, 0)
    e = num(d, "max_tracking_error_mm", 0, 10)
    u = num(d, "uncompensated_max_tracking_error_mm", 0, 10)
    if d.get("peak_command_accel_mm_s2") is None and method == "invert":
        # the exact inverse of a trapezoid: unbounded, said so (null and the status)
        if "unbounded" not in str(d.get("status")):
            raise Fail("peak_command_accel_mm_s2 null without an 'unbounded' status")
    else:
        num(d, "peak_command_accel_mm_s2", 0)
    if not e <= 0.10 * u:
        raise Fail(f"{method}: max tracking {e:.4g} mm > 10 % of uncompensated {u:.4g} mm")
    with open(out) as f:
        rows = list(csv.reader(f))
    first, last = [float(x) for x in rows[1][:3]], [float(x) for x in rows[-1][:3]]
    dt = [float(rows[i + 1][0]) - float(rows[i][0]) for i in range(1, min(len(rows) - 1, 50))]
    if max(dt) - min(dt) > 1e-9:
        raise Fail("CSV time step not uniform")
    return d, first, last, f"{method}: {e * 1000:.2f} um of {u * 1000:.0f} um"


def c_compensate_methods(ctx):
    notes = []
    for m in ("invert", "fbf", "lpfbf", "rfbf"):
        notes.append(c_compensate(ctx, m)[3])
    return "; ".join(notes)


def c_compensate_collocation(ctx):
    d, _, _, note = c_compensate(ctx, "collocation", ("--max-base-accel-mm-s2", "10000"))
    if not isinstance(get(d, "status"), str):
        raise Fail("status is not a string")
    e = num(d, "max_tracking_error_mm")
    if e > 0.005:
        raise Fail(f"collocation with 10 000 mm/s^2: {e * 1000:.2f} um > 5 um")
    if d["peak_command_accel_mm_s2"] > 10000 * (1 + 1e-6):
        raise Fail(f"peak_command_accel_mm_s2 {d['peak_command_accel_mm_s2']} > 10000")
    load = os.getloadavg()[0] / (os.cpu_count() or 1)
    if d["compute_time_s"] > 1.0:
        if load <= 1.0:
            raise Fail(f"compute_time_s {d['compute_time_s']:.2f} > 1 s")
        note += f"; {d['compute_time_s']:.2f} s at load {load:.1f} per core (not judged)"
    return note


def c_compensate_flags(ctx):
    flags(ctx, "compensate", "--method", "--natural-frequency-hz", "--damping-ratio", "--mode",
          "--max-base-accel-mm-s2", "--plant-natural-frequency-hz", "--plant-damping-ratio",
          "--csv", "--json", "--gcode", "--ignore-machine-limits")
    out = os.path.join(ctx.tmp, "cmd_plant.csv")
    d = ctx.json("compensate", CORNER, "--machine", CORNER_CFG, "--method", "fbf",
                 "--natural-frequency-hz", "15.915", "--damping-ratio", "0.5",
                 "--plant-natural-frequency-hz", "17.5", "--plant-damping-ratio", "0.5",
                 "--csv", out, "--json", "--gcode", os.path.join(ctx.tmp, "cmd.gcode"))
    num(d, "max_tracking_error_mm", 0, 10)


def c_compensate_per_axis_forms(ctx):
    """'[per-axis and --mode forms as in simulate]': simulate's per-axis model flags."""
    sim = ctx.ok("simulate", "--help")
    comp = ctx.ok("compensate", "--help")
    missing = [f for f in ("--natural-frequency-y-hz", "--damping-ratio-y", "--mode")
               if f in sim and f not in comp]
    if missing:
        raise Fail(f"simulate has {missing}, compensate does not")


def c_compare(ctx):
    out = ctx.ok("compare", CORNER, "--machine", CORNER_CFG, "--natural-frequency-hz", "15.915",
                 "--damping-ratio", "0.5", timeout=120)
    for m in ("invert", "fbf", "lpfbf", "rfbf", "collocation", "mzv"):
        if m not in out.lower():
            raise Fail(f"compare table lacks {m}")
    for p in ("-20", "+20"):
        if p not in out:
            raise Fail(f"compare table lacks the plant off by {p} %")


def c_steps_csv_json(ctx):
    g, cfg = small(ctx)
    out = os.path.join(ctx.tmp, "steps.csv")
    d = ctx.json("steps", g, "--machine", cfg, "--csv", out, "--json")
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    if rows[0] != ["stepper", "time_s", "direction"]:
        raise Fail(f"CSV header {rows[0]}")
    names = {r[0] for r in rows[1:]}
    if not names <= {"stepper_x", "stepper_y", "stepper_z", "extruder"} or \
            not {"stepper_x", "stepper_y", "extruder"} <= names:
        raise Fail(f"stepper names {sorted(names)}")
    if {r[2] for r in rows[1:]} - {"1", "-1", "+1"}:
        raise Fail(f"directions {sorted({r[2] for r in rows[1:]})}")
    # X: 10 mm out and back in the square, 80 microsteps/mm, plus the first 10 mm: count rows
    text = json.dumps(d)
    for k in ("peak_step_rate_steps_s", "filtered_peak_step_rate_steps_s",
              "sustained_step_rate_steps_s", "sustained_window_s", "csv_bytes"):
        if f'"{k}"' not in text:
            raise Fail(f"steps --json lacks {k}")
    nx = sum(1 for r in rows[1:] if r[0] == "stepper_x")
    # G28 homes to 0; X moves 0 -> 10 -> 20 -> 20 -> 10 -> 10: 30 mm at 80 steps/mm
    if nx != 2400:
        raise Fail(f"stepper_x has {nx} steps, expected 2400 (30 mm at 80 steps/mm)")
    return f"{len(rows) - 1} steps"


def c_steps_json_per_stepper(ctx):
    g, cfg = small(ctx)
    d = ctx.json("steps", g, "--machine", cfg, "--json")
    st = get(d, "steppers")
    names = [s.get("stepper", s.get("name")) for s in st] if isinstance(st, list) else list(st)
    if "stepper_x" not in names:
        raise Fail(f"steppers = {names}")
    flags(ctx, "steps", "--step-filter")
    ctx.json("steps", g, "--machine", cfg, "--json", "--step-filter", "klipper")


def c_steps_no_extruder(ctx):
    cfg = ctx.path("noext.cfg", SMALL_CFG.split("[extruder]")[0])
    g = ctx.path("travel.gcode", "G28\nG1 X10 Y10 F6000\nG1 X20\n")
    ctx.json("steps", g, "--machine", cfg, "--json")


def stepper_json(ctx, *args, timeout=60):
    return ctx.json("stepper", "simulate", *args, "--json", timeout=timeout)


def c_stepper_simulate_keys(ctx):
    d = stepper_json(ctx, "--scenario", "reversing-strokes", "--speed-mm-s", "90",
                     "--machine", "ender3", "--controller", "open")
    for ax in "xy":
        num(d, f"axes.{ax}.max_tracking_error_mm", 0, 1000)
        num(d, f"axes.{ax}.rms_tracking_error_mm", 0, 1000)
        num(d, f"axes.{ax}.lost_steps", 0)
    m = get(d, "axes.x.motor")
    if not m:
        raise Fail("axes.x.motor empty: the assumed motor is not named")


def c_stepper_controller_names(ctx):
    notes = []
    for c in ("open", "encoder-sequenced", "speed-tracking", "pid", "feedforward"):
        d = stepper_json(ctx, "--scenario", "reversing-strokes", "--speed-mm-s", "90",
                         "--controller", c)
        notes.append(f"{c} {d['axes']['x']['max_tracking_error_mm']:.3g}")
    return ", ".join(notes)


def c_stepper_old_names(ctx):
    """Issue 11's spellings (controller seed003/best, scenario seed003) kept as aliases."""
    for c in ("seed003", "best"):
        d = stepper_json(ctx, "--scenario", "seed003", "--speed-mm-s", "90", "--controller", c)
        num(d, "axes.x.max_tracking_error_mm", 0, 1000)
        num(d, "axes.y.lost_steps", 0)
    help_text = ctx.ok("stepper", "simulate", "--help")
    for alias in ("seed003", "best"):
        if alias not in help_text:
            raise Fail(f"--help does not say that {alias!r} is an alias and of what")


def c_stepper_no_load_feedforward(ctx):
    d = stepper_json(ctx, "--scenario", "reversing-strokes", "--speed-mm-s", "30", "--no-load",
                     "--controller", "open", "--machine", "ender3")
    if d["axes"]["x"]["lost_steps"] or d["axes"]["y"]["lost_steps"]:
        raise Fail("open loop loses steps without the load at 30 mm/s")
    o = stepper_json(ctx, "--scenario", "reversing-strokes", "--speed-mm-s", "90",
                     "--controller", "open", "--machine", "ender3")
    f = stepper_json(ctx, "--scenario", "reversing-strokes", "--speed-mm-s", "90",
                     "--controller", "feedforward", "--machine", "ender3")
    notes = []
    for ax in "xy":
        r = 1 - f["axes"][ax]["max_tracking_error_mm"] / o["axes"][ax]["max_tracking_error_mm"]
        notes.append(f"{ax} -{100 * r:.1f} %")
        if f["axes"][ax]["lost_steps"]:
            raise Fail(f"feedforward loses steps on {ax}")
        if r < 0.98:  # the README states -98.5 / -99.3 %
            raise Fail(f"feedforward cuts {ax}'s max error by {100 * r:.1f} % (< 98 %)")
    return ", ".join(notes)


def c_stepper_csv_and_file(ctx):
    out = os.path.join(ctx.tmp, "trace.csv")
    stepper_json(ctx, "--scenario", "reversing-strokes", "--controller", "pid", "--csv", out)
    if os.path.getsize(out) < 100:
        raise Fail("--csv trace nearly empty")
    g, cfg = small(ctx)
    d = stepper_json(ctx, g, "--machine", cfg, "--controller", "feedforward")
    num(d, "axes.x.max_tracking_error_mm", 0, 1)


def c_stepper_bad_gain(ctx):
    ctx.bad("stepper", "simulate", "--scenario", "reversing-strokes", "--controller", "pid",
            "--kp", "1e9", "--json", where="--kp")


def c_python_core(ctx):
    d = ctx.py(
        "import amctl, json, numpy as np\n"
        f"m = amctl.Machine.load('{V0_CFG}', set={{'printer.max_accel': 5000}})\n"
        f"r = amctl.estimate('{GCODE}', machine=m)\n"
        f"r2 = amctl.estimate('{GCODE}', machine='voron24', set={{'printer.max_accel': 5000}})\n"
        f"mv = amctl.plan('{GCODE}', machine=m)\n"
        f"q = amctl.simulate('{CORNER}', machine='{CORNER_CFG}', natural_frequency_hz=15.915,"
        " damping_ratio=0.5, samples=True, samples_rate_hz=100)\n"
        "print(json.dumps({'t': r['total_time_s'], 't2': r2['total_time_s'],"
        " 'n': int(len(mv)), 'names': list(mv.dtype.names or []),"
        " 'fast': int((mv['cruise_v_mm_s'] > 200).sum()),"
        " 'q': q['max_contour_error_mm'], 'trace': list(q['trace'].keys()),"
        " 'tn': int(len(q['trace']['t_s']))}))\n")
    num(d, "t", 60, 1e5)
    if d["n"] < 100 or "cruise_v_mm_s" not in d["names"]:
        raise Fail(f"plan(): {d['n']} moves, columns {d['names']}")
    close("simulate() max_contour_error_mm", d["q"], 0.4636, abs_=5e-4)
    if d["tn"] < 10:
        raise Fail("simulate() trace empty")
    for k in ("t_s", "cmd_x_mm", "cmd_y_mm", "sim_x_mm", "sim_y_mm", "contour_error_mm"):
        if k not in d["trace"]:
            raise Fail(f"simulate()['trace'] lacks {k}: {d['trace']}")
    cli = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--set", "printer.max_accel=5000",
                   "--json")
    close("Python total_time_s vs CLI", d["t"], cli["total_time_s"], abs_=1e-9)


def c_python_studies(ctx):
    d = ctx.py(
        "import amctl, json\n"
        "s = amctl.sls_margins(kp=0.3, ti=0.5, modes=1)\n"
        "f = amctl.shrink_fit('examples/04_shrink_geometry1.csv')\n"
        "names = ['write_m73','compare_profiles','calibrate_time','shrink_apply',"
        "'resonance_recommend','resonance_test_gcode','sweep','gcode_inputs','shaper_show',"
        "'resonance_calibrate','compensate','compare','steps','stepper_simulate','report',"
        "'estimate_empirical','hotend','sls3d','sls_build']\n"
        "print(json.dumps({'gn': s['margin_on_GN'], 'c': f['factor'],"
        " 'missing': [n for n in names if not callable(getattr(amctl, n, None))]}))\n")
    close("sls_margins margin_on_GN", d["gn"], 2.639e-3, rel=2e-3)
    close("shrink_fit factor", d["c"], 1.00311, abs_=5e-5)
    if d["missing"]:
        raise Fail(f"amctl lacks {d['missing']}")


def c_python_errors(ctx):
    bad = ctx.path("pybad.gcode", "G28\nG1 X10 F6000\nG1 X20 F-5\n")
    d = ctx.py(
        "import amctl, json\n"
        "out = {}\n"
        "try:\n"
        f"    amctl.estimate('{bad}', machine='voron24')\n"
        "except amctl.Error as e:\n"
        "    out['file'] = e.file; out['line'] = e.line; out['column'] = e.column\n"
        "try:\n"
        f"    amctl.estimate('{GCODE}', machine=3.5)\n"
        "except TypeError as e:\n"
        "    out['typeerror'] = str(e)\n"
        "except amctl.Error as e:\n"
        "    out['typeerror'] = 'amctl.Error: ' + str(e)\n"
        "print(json.dumps(out))\n")
    if d.get("file") != bad or d.get("line") != 3 or not d.get("column"):
        raise Fail(f"amctl.Error carries {d}")
    if "machine" not in d.get("typeerror", ""):
        raise Fail(f"wrong type for machine=: {d.get('typeerror')!r} does not name the parameter")


def c_python_fleet(ctx):
    if not os.path.isdir(os.path.join(ctx.pythonpath, "amctl")):
        raise Skip(f"no Python package in {ctx.pythonpath}")
    q = os.path.join(ctx.tmp, "queue")
    os.makedirs(q, exist_ok=True)
    shutil.copy(os.path.join(ROOT, CORNER), q)
    with open(os.path.join(q, "broken.gcode"), "w") as f:
        f.write("G1 X10 F-5\n")
    env = dict(os.environ, PYTHONPATH=ctx.pythonpath)
    p = subprocess.run(["/usr/bin/python3", "-m", "amctl.fleet", q, "--machine", "voron24",
                        "--machine", "prusa-mk3s", "--workers", "1", "--json"],
                       capture_output=True, env=env, timeout=120, cwd=ctx.tmp)
    try:
        rows = json.loads(p.stdout)
    except ValueError:
        raise Fail(f"fleet --json exit {p.returncode}: {p.stderr.decode()[-300:]}")
    if not isinstance(rows, list) or len(rows) != 4:
        raise Fail(f"fleet rows: {rows!r}"[:300])
    good = [r for r in rows if r.get("total_time_s") is not None]
    for r in rows:
        for k in ("file", "machine"):
            if k not in r:
                raise Fail(f"fleet row lacks {k}: {r}")
    if len(good) != 2:
        raise Fail(f"{len(good)} rows with total_time_s, expected 2 (the bad file is an error row)")
    d = ctx.py("import amctl.fleet, json\n"
               "print(json.dumps(callable(getattr(amctl.fleet, 'sweep', None)) and "
               "callable(getattr(amctl.fleet, 'run', None))))")
    if d is not True:
        raise Fail("amctl.fleet.sweep / amctl.fleet.run missing")


def c_report(ctx):
    out = os.path.join(ctx.tmp, "part.html")
    ctx.ok("report", GCODE, "--machine", "voron24", "-o", out, timeout=60)
    with open(out) as f:
        html = f.read()
    if "<html" not in html.lower():
        raise Fail("not an HTML page")
    for bad in ("http://", "https://"):
        for tag in ("src=\"" + bad, "href=\"" + bad):
            if tag in html:
                raise Fail(f"the page loads {tag}...")
    flags(ctx, "report", "--natural-frequency-hz", "--damping-ratio", "--accel", "--accel-axis",
          "--thermal", "-o", "--file-limits")
    ctx.ok("report", GCODE, "--machine", "voron24", "--natural-frequency-hz", "40",
           "--damping-ratio", "0.1", "-o", out, timeout=60)


def c_plan_csv(ctx):
    out = os.path.join(ctx.tmp, "moves.csv")
    ctx.ok("plan", GCODE, "--machine", "voron24", "-o", out)
    h = csv_header(out)
    for k in ("line", "layer", "feature", "cruise_v_mm_s"):
        if k not in h:
            raise Fail(f"plan CSV lacks column {k}: {h}")
    text = ctx.ok("plan", GCODE, "--machine", "voron24", "--layer-begin", "10", "--layer-end", "12")
    if len(text.splitlines()) < 10:
        raise Fail("plan --layer-begin 10 --layer-end 12: almost no rows")


def c_unknown_g2_without_arcs(ctx):
    cfg = ctx.path("noarcs.cfg", SMALL_CFG)
    g = ctx.path("arc.gcode", "G28\nG1 X50 Y50 F6000\nG2 X60 Y60 I5 J5\nG1 X10\n")
    d = ctx.json("estimate", g, "--machine", cfg, "--json")
    if "G2" not in json.dumps(d["unknown_commands"]):
        raise Fail(f"unknown_commands = {d['unknown_commands']}")
    cfg2 = ctx.path("arcs.cfg", SMALL_CFG + "[gcode_arcs]\nresolution: 1.0\n")
    d = ctx.json("estimate", g, "--machine", cfg2, "--json")
    if "G2" in json.dumps(d["unknown_commands"]):
        raise Fail("G2 unknown although [gcode_arcs] is there")


def c_dense_numbers(ctx):
    a = ctx.json("estimate", ctx.path("dense.gcode", "G28\nG1X30Y40E1.5F3000\n"),
                 "--machine", "ender3", "--json")
    b = ctx.json("estimate", ctx.path("spaced.gcode", "G28\nG1 X30 Y40 E1.5 F3000\n"),
                 "--machine", "ender3", "--json")
    close("G1X30Y40E1.5 vs spaced", a["total_time_s"], b["total_time_s"], abs_=0)


def c_file_limits(ctx):
    t = {}
    for m in ("keep", "ignore", "cap"):
        t[m] = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--set", "printer.max_accel=1000",
                        "--file-limits", m, "--json")["total_time_s"]
    t["default"] = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--set",
                            "printer.max_accel=1000", "--json")["total_time_s"]
    if t["default"] != t["keep"]:
        raise Fail("keep is not the default")
    if not t["cap"] > t["keep"]:
        raise Fail(f"cap {t['cap']} not above keep {t['keep']}")
    flags(ctx, "plan", "--file-limits")
    ctx.bad("estimate", GCODE, "--file-limits", "sometimes", where="--file-limits")
    return f"keep {t['keep']:.1f} s, cap {t['cap']:.1f} s"


def c_m503_machine(ctx):
    m = ctx.path("m503.txt", "echo:  M201 X1000 Y1000 Z200 E5000\necho:  M203 X500 Y500 Z12 E120\n"
                 "echo:  M204 P1250 R1250 T1500\necho:  M205 B20000 S0 T0 X8.00 Y8.00 Z0.40 "
                 "E5.00\necho:  M92 X80 Y80 Z400 E93\n")
    d = ctx.json("machine", "show", m, "--json")
    if get(d, "printer.firmware") != "marlin":
        raise Fail(f"printer.firmware = {d['printer'].get('firmware')!r}")
    close("printer.max_accel (M204 P)", num(d, "printer.max_accel"), 1250, abs_=0)
    if list(get(d, "marlin.max_accel")) != [1000, 1000, 200, 5000]:
        raise Fail(f"marlin.max_accel = {d['marlin']['max_accel']}")
    if list(get(d, "marlin.max_feedrate")) != [500, 500, 12, 120]:
        raise Fail(f"marlin.max_feedrate = {d['marlin']['max_feedrate']}")
    if list(get(d, "marlin.jerk")) != [8, 8, 0.4, 5]:
        raise Fail(f"marlin.jerk = {d['marlin']['jerk']}")
    num(ctx.json("estimate", GCODE, "--machine", m, "--json"), "total_time_s", 60, 1e5)


def c_bgcode_3mf_same_numbers(ctx):
    import bgcode_writer
    import make_3mf
    with open(os.path.join(ROOT, GCODE), "rb") as f:
        text = f.read()
    plain = ctx.json("estimate", GCODE, "--machine", "prusa-mk3s", "--json")["total_time_s"]
    bg = ctx.path("part.bgcode", data=bgcode_writer.write_bgcode(text.decode("latin-1"))[0])
    z = ctx.path("part.gcode.3mf", data=make_3mf.sliced_3mf([text]))
    for p in (bg, z):
        t = ctx.json("estimate", p, "--machine", "prusa-mk3s", "--json")["total_time_s"]
        if t != plain:
            raise Fail(f"{os.path.basename(p)}: {t!r} s, plain G-code {plain!r} s")
    model = ctx.path("model.3mf", data=make_3mf.model_3mf())
    err = ctx.bad("estimate", model)
    if "slice it first" not in err:
        raise Fail(f"a model 3MF is not told to slice it first: {err[:200]}")


def c_did_you_mean(ctx):
    p = ctx.run("estmate", GCODE)
    if p.returncode == 0 or "estimate" not in p.stderr.decode():
        raise Fail("misspelt subcommand without a did-you-mean")
    p = ctx.run("estimate", GCODE, "--machin", "voron24")
    if p.returncode == 0 or "--machine" not in p.stderr.decode():
        raise Fail("misspelt flag without a did-you-mean")


def c_several_files_and_stdin(ctx):
    out = ctx.ok("estimate", GCODE, CORNER)
    if GCODE.split("/")[-1] not in out or "30_belt_corner" not in out:
        raise Fail("several files do not give one row each")
    with open(os.path.join(ROOT, GCODE), "rb") as f:
        data = f.read()
    a = ctx.json("estimate", "-", "--machine", V0_CFG, "--json", stdin=data)["total_time_s"]
    b = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--json")["total_time_s"]
    if a != b:
        raise Fail(f"stdin {a} s, file {b} s")
    out = os.path.join(ctx.tmp, "stdin_m73.gcode")
    ctx.ok("estimate", "-", "--machine", V0_CFG, "--write-m73", out, stdin=data)
    if os.path.getsize(out) < len(data):
        raise Fail("--write-m73 from stdin wrote less than its input")


def c_outputs_never_destroy(ctx):
    g = ctx.path("self.gcode", SMALL_GCODE)
    ctx.bad("plan", g, "--machine", "voron24", "-o", g)
    with open(g) as f:
        if f.read() != SMALL_GCODE:
            raise Fail("plan overwrote its input")
    fifo = os.path.join(ctx.tmp, "fifo")
    os.mkfifo(fifo)
    import threading
    got = []
    th = threading.Thread(target=lambda: got.append(open(fifo, "rb").read()))
    th.start()
    ctx.ok("plan", g, "--machine", "voron24", "-o", fifo)
    th.join(10)
    if not os.path.exists(fifo) or not __import__("stat").S_ISFIFO(os.stat(fifo).st_mode):
        raise Fail("the FIFO was replaced by a regular file")
    if not got or b"\n" not in got[0]:
        raise Fail("nothing arrived through the FIFO")
    if os.path.exists("/dev/full"):
        p = subprocess.run(f"'{ctx.amctl}' estimate '{g}' --json > /dev/full", shell=True,
                           capture_output=True, timeout=30)
        if p.returncode != 2:
            raise Fail(f"> /dev/full: exit {p.returncode}, expected 2")


def c_cr_only(ctx):
    g = ctx.path("cr.gcode", SMALL_GCODE.replace("\n", "\r"))
    d = ctx.json("estimate", g, "--machine", "voron24", "--json")
    if not d["moves"]:
        raise Fail("CR-only line ends read as one line (0 moves)")


def c_sls3d_moving_source(ctx):
    d = ctx.json("thermal", "sls3d", "--case", "moving-source", "--power-w", "1",
                 "--beam-radius-mm", "0.1", "--speed-mm-s", "14.4", "--probe-mm", "-0.2,0,0",
                 "--probe-mm", "0,0,0.05", "--cells-per-radius", "4", "--steps-per-radius", "4",
                 "--json", timeout=120)
    num(d, "peak_rise_k", 0.1, 1e5)
    x = num(d, "peak_x_mm", -5, 5)
    r = num(d, "probes[].rise_k", 0, 1e5)
    if len(r) != 2:
        raise Fail(f"{len(r)} probes, asked 2")
    return f"reduced mesh; peak {d['peak_rise_k']:.2f} K at x {x:.3f} mm"


def c_sls3d_slab(ctx):
    d = ctx.json("thermal", "sls3d", "--case", "slab-flux", "--thickness-mm", "5",
                 "--flux-w-m2", "1000", "--times-s", "0.5,2,10", "--json", timeout=60)
    r = num(d, "top_rise_k[]", 0, 1e4)
    if len(r) != 3:
        raise Fail(f"top_rise_k has {len(r)} values for 3 times")
    # early time: a semi-infinite body, 2 U sqrt(t / (pi k rho c)); PA12 powder properties
    d = ctx.json("thermal", "sls3d", "--case", "slab-pi", "--thickness-mm", "5",
                 "--setpoint-rise-k", "10", "--kp", "0.3", "--ti-s", "0.5", "--times-s", "1,5",
                 "--json", timeout=60)
    if len(num(d, "top_rise_k[]", -1e4, 1e4)) != 2:
        raise Fail("slab-pi top_rise_k length")


def c_sls3d_config_path(ctx):
    exists("configs/sls_seed002_3d.toml", "docs/sls3d.md")
    flags(ctx, "thermal sls3d", "--config", "--vtu-dir", "--report", "--json", "--case")
    # The scenario itself takes over ten minutes on two cores: not run here.
    return "path and flags only (the full scenario is a long run)"


def c_docs_paths(ctx):
    exists("docs/architecture.md", "docs/testing.md", "docs/steppers.md", "docs/closedloop.md",
           "docs/thermal.md", "docs/compensation.md", "docs/python.md", "docs/formats.md",
           "docs/sources.md", "docs/dynamics_seed000_sweep.md",
           "docs/data/closedloop_real_prints.csv", "examples/04_coins.sh",
           "examples/slicer/klipper_voron.ini", "configs/klipper-voron-v0-macros.cfg",
           "scripts/closedloop_sweep.py", "scripts/collocation_sweep.py",
           "scripts/klipper_steps_crosscheck.py")


def c_readme_python(ctx):
    d = ctx.py("import amctl, json; print(json.dumps(amctl.estimate("
               f"'{GCODE}', machine='voron24')['total_time_s']))")
    num({"t": d}, "t", 60, 1e5)


def c_estimate_absurd_feedrate(ctx):
    for i, line in enumerate(("G1 X20 F0", "G1 X20 F-100", "G1 Xinf")):
        g = ctx.path(f"absurd{i}.gcode", f"G28\nG1 X10 F6000\n{line}\n")
        ctx.bad("estimate", g, "--machine", "voron24", where=f"{g}:3:")


def c_estimate_pauses_range(ctx):
    g = ctx.path("pause.gcode", "G28\nG1 X10 Y10 F6000\nM600\nG1 X20\nM0\nG1 X30\n")
    d = ctx.json("estimate", g, "--machine", "voron24", "--json")
    p = json.dumps(get(d, "pauses"))
    if "M600" not in p or "M0" not in p:
        raise Fail(f"pauses = {p[:200]}")
    g = ctx.path("range.gcode", "G28\nG1 X10 Y10 F6000\nG1 X900\n")
    d = ctx.json("estimate", g, "--machine", V0_CFG, "--json")
    if not get(d, "range_error"):
        raise Fail("a move past position_max gives no range_error")


def c_marlin_preset_shows_marlin(ctx):
    d = ctx.json("machine", "show", "prusa-mk3s", "--json")
    if get(d, "printer.firmware") != "marlin":
        raise Fail("prusa-mk3s is not a Marlin machine")
    get(d, "marlin.max_accel")
    get(d, "marlin.max_feedrate")
    out = ctx.ok("machine", "show", "prusa-mk3s")
    if "[marlin]" not in out:
        raise Fail("machine show prusa-mk3s (TOML) has no [marlin] section")


def c_empirical_caveat(ctx):
    out = ctx.ok("estimate", GCODE, "--mode", "empirical")
    if "uncalibrated" not in out:
        raise Fail("--mode empirical without --params does not say it is uncalibrated")


def c_calibrate_time(ctx):
    d = os.path.join(ctx.tmp, "timed")
    os.makedirs(d, exist_ok=True)
    shutil.copy(os.path.join(ROOT, GCODE), os.path.join(d, "a.gcode"))
    rows = "gcode,duration_s\na.gcode,860\n"
    for k, (dx, f) in enumerate(((40, 6000), (80, 9000), (120, 3000), (60, 12000))):
        with open(os.path.join(d, f"m{k}.gcode"), "w") as fh:
            fh.write("G28\nG90\n" + "".join(f"G1 X{10 + (j % 2) * dx} Y{10 + j} F{f}\n"
                                            for j in range(60)))
        rows += f"m{k}.gcode,{12 + 3 * k}\n"
    t = os.path.join(d, "prints.csv")
    with open(t, "w") as fh:
        fh.write(rows)
    r = ctx.json("calibrate-time", t, "--machine", "voron24", "--fit", "accel", "--json")
    a = ctx.json("calibrate-time", t, "--machine", "voron24", "--fit", "accel", "--json",
                 "--keep-file-limits")
    if json.dumps(r, sort_keys=True) != json.dumps(a, sort_keys=True):
        raise Fail("--keep-file-limits is not the default")


def c_shaper_bad_damping(ctx):
    ctx.bad("shaper", "show", "--type", "mzv", "--freq-hz", "40", "--damping-ratio", "1",
            "--json", where="--damping-ratio")
    ctx.bad("shaper", "show", "--type", "nope", "--freq-hz", "40", "--damping-ratio", "0.1",
            "--json", where="--type")


def c_simulate_input_shaper_cfg(ctx):
    base = ["simulate", CORNER, "--natural-frequency-hz", "15.915", "--damping-ratio", "0.5",
            "--json"]
    with open(os.path.join(ROOT, CORNER_CFG)) as f:
        cfg = f.read()
    shaped = ctx.path("corner_shaped.cfg", cfg + "\n[input_shaper]\nshaper_type: mzv\n"
                      "shaper_freq_x: 15.915\nshaper_freq_y: 15.915\n")
    plain = ctx.json(*base, "--machine", CORNER_CFG)["max_contour_error_mm"]
    a = ctx.json(*base, "--machine", shaped)["max_contour_error_mm"]
    b = ctx.json(*base, "--machine", shaped, "--no-shaper")["max_contour_error_mm"]
    if a == plain:
        raise Fail("[input_shaper] in the printer.cfg changes nothing")
    if b != plain:
        raise Fail("--no-shaper does not give the unshaped result")
    m593 = ctx.path("m593.gcode", "M593 F15.915 D0.1\n" + open(os.path.join(ROOT, CORNER)).read())
    c = ctx.json("simulate", m593, "--natural-frequency-hz", "15.915", "--damping-ratio", "0.5",
                 "--json", "--machine", "prusa-mk3s")["max_contour_error_mm"]
    d = ctx.json("simulate", CORNER, "--natural-frequency-hz", "15.915", "--damping-ratio", "0.5",
                 "--json", "--machine", "prusa-mk3s")["max_contour_error_mm"]
    if c == d:
        raise Fail("M593 in the G-code changes nothing on a Marlin machine")


def c_resonance_table_stdin_axis(ctx):
    f = "tests/reference/resonance/calibration_data_y_sweep_1.csv"
    out = ctx.ok("resonance", "calibrate", f, "--axis", "y")
    if "mzv" not in out.lower():
        raise Fail("no human table without --json")
    d = ctx.json("resonance", "calibrate", f, "--json")
    get(d, "klipper.recommended.name")
    with open(os.path.join(ROOT, f), "rb") as fh:
        e = ctx.json("resonance", "calibrate", "-", "--axis", "y", "--json", stdin=fh.read())
    if e["klipper"]["recommended"] != d["klipper"]["recommended"]:
        raise Fail("'-' (stdin) gives another recommendation")


def c_resonance_response_csv(ctx):
    raw = raw_sweep_csv(ctx)
    out = os.path.join(ctx.tmp, "response.csv")
    ctx.json("resonance", "calibrate", raw, "--axis", "y", "--sweep", "5,80,4,4000",
             "--response-csv", out, "--json")
    h = csv_header(out)
    if h[:4] != ["freq_hz", "gain", "phase_rad", "coherence"]:
        raise Fail(f"--response-csv header {h}")


def c_stepper_motor_presets(ctx):
    seen = []
    for m in ("17hs4401", "ldo-42sth48-2504ac", "ldo-42sth48-2004mah", "ldo-42sth40-1004a"):
        steps = ["--set", "stepper_x.full_steps_per_rotation=400", "--set",
                 "stepper_y.full_steps_per_rotation=400"] if m.endswith("2004mah") else []
        d = stepper_json(ctx, "--scenario", "reversing-strokes", "--controller", "open",
                         "--set", f"stepper_x.motor={m}", "--set", f"stepper_y.motor={m}", *steps)
        name = json.dumps(get(d, "axes.x.motor"))
        if m not in name.lower():
            raise Fail(f"stepper_x.motor={m}: axes.x.motor = {name[:120]}")
        seen.append(m)
    out = ctx.ok("stepper", "simulate", "--scenario", "reversing-strokes")
    if "17hs4401" not in out.lower():
        raise Fail("the assumed motor is not named in the text output")


def c_steps_shaper_pa(ctx):
    g, cfg = small(ctx)
    plain = ctx.json("steps", g, "--machine", cfg, "--json")
    cfg2 = ctx.path("shaped.cfg", SMALL_CFG + "pressure_advance: 0.04\n[input_shaper]\n"
                    "shaper_type: mzv\nshaper_freq_x: 40\nshaper_freq_y: 40\n")
    d = ctx.json("steps", g, "--machine", cfg2, "--json", "--step-filter", "klipper")
    if not d.get("input_shaper") or not d.get("pressure_advance"):
        raise Fail(f"input_shaper = {d.get('input_shaper')!r}, pressure_advance = "
                   f"{d.get('pressure_advance')!r}")
    if json.dumps(d["steppers"]) == json.dumps(plain["steppers"]):
        raise Fail("[input_shaper] and pressure_advance change no step")
    bad = ctx.path("badshaper.cfg", SMALL_CFG + "[input_shaper]\nshaper_type: nope\n"
                   "shaper_freq_x: 40\n")
    ctx.bad("steps", g, "--machine", bad, "--json", where=f"{bad}:")
    badpa = ctx.path("badpa.cfg", SMALL_CFG + "pressure_advance: -0.1\n")
    ctx.bad("steps", g, "--machine", badpa, "--json", where=f"{badpa}:")


def c_python_file_limits_fleet_dir(ctx):
    q = os.path.join(ctx.tmp, "queue2")
    os.makedirs(q, exist_ok=True)
    shutil.copy(os.path.join(ROOT, CORNER), q)
    open(os.path.join(q, "empty.gcode"), "w").close()
    d = ctx.py(
        "import amctl, amctl.fleet, json\n"
        f"a = amctl.estimate('{GCODE}', machine='{V0_CFG}', set={{'printer.max_accel': 1000}},"
        " file_limits='cap')['total_time_s']\n"
        f"rows = amctl.fleet.run(['{q}'], ['voron24'], workers=1)\n"
        "rows = rows.to_dict('records') if hasattr(rows, 'to_dict') else rows\n"
        "print(json.dumps({'a': a, 'rows': rows}, default=str))\n", timeout=180)
    cli = ctx.json("estimate", GCODE, "--machine", V0_CFG, "--set", "printer.max_accel=1000",
                   "--file-limits", "cap", "--json")["total_time_s"]
    close("Python file_limits='cap' vs CLI", d["a"], cli, abs_=1e-9)
    rows = d["rows"]
    if len(rows) != 2:
        raise Fail(f"fleet.run on a directory: {len(rows)} rows, expected 2")
    empty = [r for r in rows if "empty" in str(r.get("file"))]
    if not empty or "no moves" not in json.dumps(empty[0]):
        raise Fail(f"the empty file's row does not say 'no moves': {empty}")


def c_python_sls3d(ctx):
    d = ctx.py("import amctl, json\n"
               "r = amctl.sls3d(case='slab-flux', thickness_mm=5, flux_w_m2=1000,"
               " times_s=[0.5, 2])\n"
               "print(json.dumps(r['top_rise_k']))\n", timeout=120)
    if not isinstance(d, list) or len(d) != 2:
        raise Fail(f"amctl.sls3d(case='slab-flux')['top_rise_k'] = {d!r}")


def c_report_no_moves(ctx):
    g = ctx.path("nomoves.gcode", "M104 S200\nM140 S60\n")
    out = os.path.join(ctx.tmp, "nomoves.html")
    ctx.ok("report", g, "--machine", "voron24", "-o", out)
    with open(out) as f:
        if "no moves" not in f.read().lower():
            raise Fail("the page for a file without moves does not say so")


def sls3d_small(ctx, *extra, timeout=120):
    return ctx.json("thermal", "sls3d", "--config", "tests/sls3d/small_scenario.toml", *extra,
                    "--json", timeout=timeout)


def c_sls3d_config_small(ctx):
    import tomllib
    with open(os.path.join(ROOT, "configs/sls_seed002_3d.toml"), "rb") as f:
        times = tomllib.load(f)["output"]["snapshot_times_s"]
    for t in (14.0, 15.1, 28.1):
        if t not in times:
            raise Fail(f"configs/sls_seed002_3d.toml: snapshot_times_s {times} lacks {t}")
    vtu = os.path.join(ctx.tmp, "vtu")
    page = os.path.join(ctx.tmp, "sls3d.html")
    d = sls3d_small(ctx, "--vtu-dir", vtu, "--report", page)
    num(d, "snapshots[].time_s", 0, 1e4)
    for f in get(d, "snapshots[].file"):
        if not os.path.exists(f if os.path.isabs(f) else os.path.join(ROOT, f)):
            raise Fail(f"snapshot file {f} not written")
    e = num(d, "energy_balance_rel_error", 0, 1e-6)
    num(d, "wall_s", 0, 1e5)
    if not os.path.getsize(page):
        raise Fail("--report wrote nothing")
    return f"reduced config (tests/sls3d/small_scenario.toml); energy {e:.1e}"


def c_sls3d_mpi(ctx):
    mpirun = shutil.which("mpirun")
    if not mpirun:
        raise Skip("no mpirun")
    one = sls3d_small(ctx)
    try:
        p = subprocess.run([mpirun, "--allow-run-as-root", "-np", "2", ctx.amctl, "thermal",
                            "sls3d", "--config", "tests/sls3d/small_scenario.toml", "--json"],
                           capture_output=True, timeout=180, cwd=ROOT)
    except subprocess.TimeoutExpired:
        raise Fail("mpirun -np 2 timed out")
    if p.returncode != 0:
        raise Fail(f"mpirun -np 2: exit {p.returncode}: {p.stderr.decode()[-300:]}")
    two = json.loads(p.stdout)
    if two.get("mpi_ranks") != 2:
        raise Fail(f"mpi_ranks = {two.get('mpi_ranks')}")
    for a, b in zip(one["snapshots"], two["snapshots"]):
        close(f"measured_c at {a['time_s']} s, 2 ranks", b["measured_c"], a["measured_c"],
              abs_=1e-4)
    return "reduced config"


def c_existing_spellings(ctx):
    """Spellings that exist today and that the one-parameter-table work may rename: the old
    names must stay accepted (aliases for one release)."""
    d = stepper_json(ctx, "--scenario", "reversing-strokes", "--controller", "pid",
                     "--drag-n", "2", "--ki", "50", "--kp", "1")
    num(d, "axes.x.peak_step_rate_hz", 0)
    g, cfg = small(ctx)
    num(ctx.json("steps", g, "--machine", cfg, "--json"), "steppers[].peak_step_rate_steps_s", 0)
    r = ctx.py("import amctl, json\n"
               "d = amctl.stepper_simulate(scenario='reversing-strokes', controller='pid',"
               " drag_n=2, ki=50, kp=1)\n"
               "print(json.dumps(d['axes']['x']['max_tracking_error_mm']))\n")
    num({"e": r}, "e", 0, 1000)


def c_resonance_bad_csvs(ctx):
    h = "#time,accel_x,accel_y,accel_z\n"
    ok = "".join(f"{i / 1000:.3f},1,2,3\n" for i in range(5))
    cases = {
        "text": (h + ok + "0.005,abc,2,3\n", 7),
        "short_row": (h + ok + "0.005,1,2\n", 7),
        "backwards": (h + ok + "0.001,1,2,3\n", 7),
        "wrong_columns": ("#time,foo,bar\n0,1,2\n", 1),
    }
    for name, (text, line) in cases.items():
        f = ctx.path(f"accel_{name}.csv", text)
        ctx.bad("resonance", "calibrate", f, "--axis", "y", "--json", where=f"{f}:{line}")
    for name, data in (("empty", b""), ("binary", bytes(range(256)) * 4)):
        f = ctx.path(f"accel_{name}.csv", data=data)
        ctx.bad("resonance", "calibrate", f, "--axis", "y", "--json", where=f)


def c_simulate_csv_range(ctx):
    out = os.path.join(ctx.tmp, "sim.csv")
    ctx.json("simulate", CORNER, "--machine", CORNER_CFG, "--natural-frequency-hz", "15.915",
             "--damping-ratio", "0.5", "--csv", out, "--csv-rate-hz", "200", "--t-begin", "0.05",
             "--t-end", "0.2", "--json")
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    for k in ("t_s", "cmd_x_mm", "cmd_y_mm", "sim_x_mm", "sim_y_mm", "contour_error_mm"):
        if k not in rows[0]:
            raise Fail(f"simulate CSV lacks {k}: {rows[0]}")
    t = [float(r[0]) for r in rows[1:]]
    if abs(t[0] - 0.05) > 1e-9 or abs(t[-1] - 0.2) > 1e-9 or len(t) != 31:
        raise Fail(f"CSV rows {t[0]}..{t[-1]} s ({len(t)}), expected 0.05..0.2 s at 200 Hz (31)")


def c_test_gcode_whole_program(ctx):
    out = os.path.join(ctx.tmp, "res_prog.gcode")
    ctx.ok("resonance", "test-gcode", "--machine", V0_CFG, "--axis", "y", "-o", out)
    with open(out) as f:
        text = f.read()
    for k in ("G28", "ACCELEROMETER_MEASURE"):
        if k not in text:
            raise Fail(f"the test program lacks {k}")


CONTRACTS = [
    # (issue, name, fast, function)
    (2, "estimate --machine printer.cfg --json: total_time_s, layers, features, heater_waits, "
        "unknown_commands, planner.forced_flushes", True, c_estimate_json_total),
    (2, "estimate --json: the report's other keys", True, c_estimate_keys_readme),
    (2, "SET_KINEMATIC_POSITION understood", True, c_estimate_set_kinematic_position),
    (2, "bad G-code: FILE:LINE:COL on stderr, exit 2", True, c_estimate_bad_line_col),
    (2, "default machine, presets, TOML file", True, c_estimate_default_machine_and_presets),
    (2, "--set section.key=value", True, c_estimate_set_override),
    (2, "--write-m73 OUT", True, c_estimate_write_m73),
    (2, "--brief: one line", True, c_estimate_brief_one_line),
    (2, "make demo/test/fuzz/bench, presets, scripts, AMCTL_FUZZ", True, c_skeleton_paths),
    (3, "estimate --compare-profiles: trapezoid, bezier5, scurve7", True,
     c_estimate_compare_profiles),
    (3, "simulate --natural-frequency-hz --damping-ratio --json: motion_time_s, "
        "max/rms_contour_error_mm; base case 0.4636 mm", True, c_simulate_json),
    (3, "simulate plans as estimate does", False, c_simulate_same_plan_as_estimate),
    (3, "square_corner_velocity 0: full stop at corners", True, c_simulate_scv0_full_stop),
    (3, "damping ratio < 0 named, exit 2", True, c_simulate_bad_damping),
    (3, "sweep: table with the base case; --json", True, c_sweep_table),
    (4, "thermal sls-margins --json: margin_on_GN, margin_on_G, hinf_G_minus_GN", True,
     c_sls_margins),
    (4, "Ti <= 0 named, exit 2", True, c_sls_margins_bad_ti),
    (4, "thermal sls --config configs/sls_pa12.toml; hotend; bed", True, c_thermal_sls_config),
    (5, "shrink fit --json: slope, intercept, factor = 1/(1+slope); Table 1 C", True,
     c_shrink_fit),
    (5, "shrink fit: header nominal_mm,measured_mm with more columns", True,
     c_shrink_fit_minimal_csv),
    (5, "shrink apply --model/--gcode; estimate --mode empirical; calibrate-time", True,
     c_shrink_apply_and_empirical),
    (9, "shaper show --json: amplitudes/times_s (Klipper's, unnormalised), smoothing_mm, "
        "max_accel_mm_s2, residual_vibration", True, c_shaper_show),
    (9, "shaper frequency <= 0 named, exit 2", True, c_shaper_bad_freq),
    (9, "simulate --shaper --shaper-freq-hz and per-axis forms", True, c_simulate_shaper_flags),
    (9, "resonance calibrate --json: klipper.recommended.{name,freq_hz}, klipper.shapers[]",
     True, c_resonance_calibrate_psd),
    (9, "resonance calibrate --sweep: model.natural_frequency_hz (1 %), model.damping_ratio "
        "(10 %), --csv", False, c_resonance_calibrate_sweep),
    (9, "resonance calibrate on the corpus sweep: MZV near 25.7 Hz", False,
     c_resonance_calibrate_corpus),
    (9, "resonance test-gcode --machine --axis x|y", True, c_resonance_test_gcode),
    (10, "compensate invert|fbf|lpfbf|rfbf: CSV header, JSON keys, <= 10 % of uncompensated",
     True, c_compensate_methods),
    (10, "compensate collocation, 10 000 mm/s^2: status, <= 5 um, limit kept, < 1 s", True,
     c_compensate_collocation),
    (10, "compensate: plant flags, --gcode, --ignore-machine-limits", True, c_compensate_flags),
    (10, "compensate: per-axis model forms as in simulate", True, c_compensate_per_axis_forms),
    (10, "compare: every method and shaper, plant off by -20..+20 %", False, c_compare),
    (11, "steps --csv --json: header stepper,time_s,direction, names, +1/-1, counts", True,
     c_steps_csv_json),
    (11, "steps --json: per stepper; --step-filter klipper", True, c_steps_json_per_stepper),
    (11, "stepper simulate --json: axes.{x,y}.{max,rms}_tracking_error_mm, lost_steps, motor",
     True, c_stepper_simulate_keys),
    (11, "stepper simulate: --controller seed003|best, --scenario seed003 (aliases, named in "
         "--help)", True, c_stepper_old_names),
    (11, "stepper simulate --csv; a G-code file", True, c_stepper_csv_and_file),
    (11, "unstable gain named, exit 2", True, c_stepper_bad_gain),
    (19, "controllers open, encoder-sequenced, speed-tracking, pid, feedforward on the default "
         "machine", False, c_stepper_controller_names),
    (19, "no load at 30 mm/s: open loop loses none; feedforward >= 98 % at 90 mm/s, no loss",
     False, c_stepper_no_load_feedforward),
    (12, "Python: Machine.load(set=), estimate = CLI, plan numpy, simulate arrays", True,
     c_python_core),
    (12, "Python: sls_margins, shrink_fit and every CLI job", True, c_python_studies),
    (12, "Python: amctl.Error file/line/column; wrong type names the parameter", True,
     c_python_errors),
    (12, "python3 -m amctl.fleet DIR --machine A --machine B --json; fleet.sweep/run", False,
     c_python_fleet),
    (12, "report -o page.html, self-contained; belt flags", False, c_report),
    (13, "plan -o moves.csv; --layer-begin/--layer-end", True, c_plan_csv),
    (14, "unknown_commands names G2 without [gcode_arcs]", True, c_unknown_g2_without_arcs),
    (14, "G1X30Y40E1.5 read as Y40 E1.5", True, c_dense_numbers),
    (14, "resonance calibrate on a bad CSV: FILE:LINE, exit 2", True, c_resonance_bad_csv),
    (21, "--file-limits keep|ignore|cap (keep the default)", True, c_file_limits),
    (21, "M503 output: machine show --json printer.firmware/max_accel, marlin.*", True,
     c_m503_machine),
    (21, "FILE.bgcode and FILE.gcode.3mf: the plain file's numbers; a model: slice it first",
     True, c_bgcode_3mf_same_numbers),
    (21, "did-you-mean for a subcommand and a flag", True, c_did_you_mean),
    (21, "several files one row each; '-' for stdin, read once", True,
     c_several_files_and_stdin),
    (23, "input never overwritten, FIFO streamed, /dev/full exit 2", True,
     c_outputs_never_destroy),
    (23, "CR-only line ends", True, c_cr_only),
    (24, "shaper show --firmware marlin", True, c_shaper_marlin),
    (24, "steps on a printer.cfg without [extruder]", True, c_steps_no_extruder),
    (24, "simulate --motor-space on a delta: an error naming --motor-space", True,
     c_simulate_motor_space_nonlinear),
    (20, "sls3d --case moving-source: peak_rise_k, peak_x_mm, probes[].rise_k (reduced mesh)",
     False, c_sls3d_moving_source),
    (20, "sls3d --case slab-flux / slab-pi --times-s: top_rise_k[]", False, c_sls3d_slab),
    (20, "sls3d --config configs/sls_seed002_3d.toml: path and flags", True,
     c_sls3d_config_path),
    (0, "paths the docs and closing notes name", True, c_docs_paths),
    (12, "README: PYTHONPATH=build/release/python import amctl", True, c_readme_python),
    (2, "F0, negative feed rate, inf: FILE:LINE:COL, exit 2", True, c_estimate_absurd_feedrate),
    (14, "pauses (M600, M0) listed apart; a move out of range: range_error", True,
     c_estimate_pauses_range),
    (21, "machine show of a Marlin preset: Marlin's limits", True, c_marlin_preset_shows_marlin),
    (21, "--mode empirical without a calibration says so", True, c_empirical_caveat),
    (5, "calibrate-time prints.csv --json; --keep-file-limits = the default", False,
     c_calibrate_time),
    (9, "shaper damping outside [0, 1), unknown type: named, exit 2", True, c_shaper_bad_damping),
    (9, "simulate reads [input_shaper] and M593; --no-shaper", True, c_simulate_input_shaper_cfg),
    (21, "resonance calibrate: a table without --json, --axis optional, '-' for stdin", True,
     c_resonance_table_stdin_axis),
    (9, "resonance calibrate --sweep --response-csv: freq_hz,gain,phase_rad,coherence", False,
     c_resonance_response_csv),
    (19, "motor presets by stepper_x.motor, named in JSON and text", True, c_stepper_motor_presets),
    (24, "steps: [input_shaper] and pressure_advance applied; bad values at FILE:LINE, exit 2",
     True, c_steps_shaper_pa),
    (21, "Python file_limits=; fleet.run on a directory; an empty file says 'no moves'", False,
     c_python_file_limits_fleet_dir),
    (20, "Python amctl.sls3d(case='slab-flux')['top_rise_k']", False, c_python_sls3d),
    (12, "report on a file without moves says so", True, c_report_no_moves),
    (20, "sls3d --config --vtu-dir --report --json: snapshots[].{time_s,file}, "
         "energy_balance_rel_error, wall_s (reduced config); the bundled config's 14/15.1/28.1 s",
     False, c_sls3d_config_small),
    (20, "mpirun -np 2 amctl thermal sls3d --config: same result (reduced config)", False,
     c_sls3d_mpi),
    (22, "today's spellings kept: --drag-n, --ki, drag_n=, ki=, peak_step_rate_hz, "
         "peak_step_rate_steps_s", True, c_existing_spellings),
    (9, "accelerometer CSV with text, a short row, time backwards, wrong columns: FILE:LINE; "
        "empty or binary: named; exit 2", True, c_resonance_bad_csvs),
    (3, "simulate --csv --csv-rate-hz --t-begin --t-end: the path in the range", True,
     c_simulate_csv_range),
    (21, "resonance test-gcode on a printer.cfg: a whole program (homing, accelerometer)", True,
     c_test_gcode_whole_program),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--amctl", default=os.path.join(ROOT, "build/release/apps/amctl/amctl"))
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("-k", default="")
    ap.add_argument("--list", action="store_true")
    a = ap.parse_args()
    rows = [c for c in CONTRACTS if (not a.fast or c[2]) and a.k in c[1] + c[3].__name__]
    if a.list:
        for issue, name, fast, fn in rows:
            print(f"{issue:3d} {'fast' if fast else 'slow'} {fn.__name__}: {name}")  # the table's data
        return 0
    amctl = os.path.abspath(a.amctl)
    if not os.access(amctl, os.X_OK):
        print(f"no amctl binary at {amctl}", file=sys.stderr)
        return 2
    counts = {"PASS": 0, "FAIL": 0, "SKIP": 0}
    with tempfile.TemporaryDirectory(prefix="amctl_contracts_") as tmp:
        ctx = Ctx(amctl, tmp)
        for issue, name, fast, fn in rows:
            t0 = time.monotonic()
            try:
                note = fn(ctx)
                status = "PASS"
            except Skip as e:
                status, note = "SKIP", str(e)
            except Fail as e:
                status, note = "FAIL", str(e)
            except Exception as e:  # a broken row is a failure, not a crash of the table
                status, note = "FAIL", f"{type(e).__name__}: {e}"
            counts[status] += 1
            dt = time.monotonic() - t0
            extra = f" -- {note}" if isinstance(note, str) and note else ""
            print(f"{status} {name} ({dt:.1f} s){extra}", flush=True)
    print(f"{counts['PASS']} PASS, {counts['FAIL']} FAIL, {counts['SKIP']} SKIP")
    return 1 if counts["FAIL"] else 0


if __name__ == "__main__":
    sys.exit(main())
