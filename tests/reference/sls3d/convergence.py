#!/usr/bin/python3
"""Mesh and time-step convergence of the 3D powder-bed model, with the observed orders
(docs/sls3d.md, "Observed orders").

Runs `amctl thermal sls3d` at successive refinements of the mesh size h and of the time step dt
(each halved at every level) and prints, for each study, the quantity at every level, its
error against the independent reference where there is one (the slab's series, the Eagar-Tsai
integral), the differences between successive levels and the observed order

    p = log2(e_k / e_k+1)          (errors against the reference), or
    p = log2(d_k / d_k+1)          (d_k = |q_k - q_k+1|, self-convergence, no reference needed).

Studies (all on one rank, each a few CPU seconds to a minute):

  slab-space     slab 1 mm under 1000 W/m^2, top rise at 2 s; 8, 16, 32, 64 cells across,
                 Crank-Nicolson at dt 0.5 ms (time error < 1e-3 of the space error)
  slab-time-be   the same, 64 cells, backward Euler at dt 40, 20, 10, 5, 2.5 ms
  slab-time-cn   the same, 64 cells, Crank-Nicolson at dt 40, 20, 10, 5, 2.5 ms
  ms-space       moving Gaussian source, Peclet 5 (P 1 W, W 0.1 mm, v 14.4 mm/s, PA12): peak
                 rise, the rise one radius behind the beam and half a radius below it,
                 2, 4, 8 cells per radius at 16 steps per radius (Crank-Nicolson)
  ms-time        the same at 4 cells per radius, 2, 4, 8, 16 steps per radius
  scen-space     the reduced scenario (tests/sls3d/small_scenario.toml: two layers, the ring
                 exposed with the part-scale source, melting, losses, the PI on the measured
                 top): 0, 1, 2 uniform refinements of its mesh (numerics.global_refinements:
                 every cell halved in every direction, the refined zones with them), dt 0.1 s
  scen-time      the same at coarse cells 2 mm, 1 cell per layer, dt 0.1, 0.05, 0.025,
                 0.0125, 0.00625 s (the second layer spread at 0.4 s at every dt)

usage: convergence.py AMCTL SOURCE_DIR [--only STUDY[,STUDY...]] [--json OUT.json]
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import tomllib


def run(amctl, args):
    start = os.times()
    p = subprocess.run([amctl, "thermal", "sls3d", *args, "--json"], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"amctl {' '.join(args)} failed ({p.returncode}): {p.stderr}")
    end = os.times()
    out = json.loads(p.stdout)
    out["_cpu_s"] = (end.children_user - start.children_user) + (end.children_system - start.children_system)
    return out


def orders(values):
    """log2 of successive ratios of |values| (None where a ratio is undefined)."""
    out = []
    for a, b in zip(values, values[1:]):
        out.append(math.log2(abs(a) / abs(b)) if a != 0 and b != 0 else None)
    return out


def fmt_order(p):
    return "-" if p is None else f"{p:.2f}"


def report(name, label, levels, quantities, reference=None):
    """levels: labels; quantities: {name: [value per level]}; reference: {name: exact}."""
    print(f"\n### {name}\n")
    result = {"study": name, "levels": levels, "quantities": {}}
    for q, vals in quantities.items():
        diffs = [a - b for a, b in zip(vals, vals[1:])]
        row = {"values": vals, "differences": diffs, "self_orders": orders(diffs)}
        print(f"{q}:")
        print(f"| {label} | value | difference to the next level |" + (" error |" if reference and q in reference else ""))
        print("|---|---|---|" + ("---|" if reference and q in reference else ""))
        errs = None
        if reference and q in reference:
            errs = [v - reference[q] for v in vals]
            row["reference"] = reference[q]
            row["errors"] = errs
            row["error_orders"] = orders(errs)
        for i, v in enumerate(vals):
            d = f"{diffs[i]:+.4e}" if i < len(diffs) else ""
            e = f" {errs[i]:+.4e} |" if errs else ""
            print(f"| {levels[i]} | {v:.10g} | {d} |{e}")
        print(f"observed order from the differences: {', '.join(fmt_order(p) for p in row['self_orders'])}")
        if errs:
            print(f"observed order from the errors: {', '.join(fmt_order(p) for p in row['error_orders'])}")
        result["quantities"][q] = row
    return result


def slab(amctl, cells, dt, scheme):
    return run(amctl, ["--case", "slab-flux", "--thickness-mm", "1", "--flux-w-m2", "1000", "--times-s", "2",
                       "--cells", str(cells), "--dt-s", repr(dt), "--scheme", scheme])


def study_slab_space(amctl):
    rs = [slab(amctl, n, 5e-4, "crank_nicolson") for n in (8, 16, 32, 64)]
    return report("slab-space (Crank-Nicolson, dt 0.5 ms)", "cells", [8, 16, 32, 64],
                  {"top_rise_k at 2 s": [r["top_rise_k"][0] for r in rs]},
                  {"top_rise_k at 2 s": rs[0]["series_top_rise_k"][0]})


def study_slab_time(amctl, scheme):
    dts = (0.04, 0.02, 0.01, 0.005, 0.0025)
    rs = [slab(amctl, 64, dt, scheme) for dt in dts]
    return report(f"slab-time ({scheme}, 64 cells)", "dt s", list(dts),
                  {"top_rise_k at 2 s": [r["top_rise_k"][0] for r in rs]},
                  {"top_rise_k at 2 s": rs[0]["series_top_rise_k"][0]})


def moving(amctl, cpr, spr):
    return run(amctl, ["--case", "moving-source", "--power-w", "1", "--beam-radius-mm", "0.1", "--speed-mm-s", "14.4",
                       "--probe-mm", "-0.1,0,0", "--probe-mm", "0,0,0.05", "--cells-per-radius", str(cpr),
                       "--steps-per-radius", str(spr)])


def moving_quantities(rs):
    return {"peak_rise_k": [r["peak_rise_k"] for r in rs],
            "rise_k at (-W, 0, 0)": [r["probes"][0]["rise_k"] for r in rs],
            "rise_k at (0, 0, W/2 deep)": [r["probes"][1]["rise_k"] for r in rs]}


def moving_reference(r):
    return {"peak_rise_k": r["analytic_peak_rise_k"],
            "rise_k at (-W, 0, 0)": r["probes"][0]["analytic_rise_k"],
            "rise_k at (0, 0, W/2 deep)": r["probes"][1]["analytic_rise_k"]}


def study_ms_space(amctl):
    levels = (2, 4, 8)
    rs = [moving(amctl, c, 16) for c in levels]
    for c, r in zip(levels, rs):
        print(f"  (cells per radius {c}: {r['mesh']['cells']} cells, {r['mesh']['dofs']} dofs, {r['steps']} steps,"
              f" {r['_cpu_s']:.1f} CPU s)", file=sys.stderr)
    return report("ms-space (Peclet 5, 16 steps per radius)", "cells per radius", list(levels),
                  moving_quantities(rs), moving_reference(rs[0]))


def study_ms_time(amctl):
    levels = (2, 4, 8, 16)
    rs = [moving(amctl, 4, s) for s in levels]
    return report("ms-time (Peclet 5, 4 cells per radius)", "steps per radius", list(levels),
                  moving_quantities(rs), moving_reference(rs[0]))


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return repr(v)


def scenario(amctl, base, overrides, workdir, name):
    cfg = {k: dict(v) for k, v in base.items()}
    for section, values in overrides.items():
        cfg.setdefault(section, {}).update(values)
    path = os.path.join(workdir, name + ".toml")
    with open(path, "w") as f:
        for section, values in cfg.items():
            f.write(f"[{section}]\n")
            for k, v in values.items():
                f.write(f"{k} = {toml_value(v)}\n")
    return run(amctl, ["--config", path])


def scenario_quantities(rs):
    def snap(r, t, key):
        return next(s[key] for s in r["snapshots"] if abs(s["time_s"] - t) < 1e-9)
    return {"measured_c at 0.3 s (first layer, before its exposure)": [snap(r, 0.3, "measured_c") for r in rs],
            "measured_c at 0.9 s (second layer exposed)": [snap(r, 0.9, "measured_c") for r in rs],
            "top_mean_c at 0.9 s (whole top, the rings included)": [snap(r, 0.9, "top_mean_c") for r in rs]}


def small_base(source_dir):
    with open(os.path.join(source_dir, "tests", "sls3d", "small_scenario.toml"), "rb") as f:
        base = tomllib.load(f)
    return base


def exposure_end(amctl, base, workdir):
    r = scenario(amctl, base, {}, workdir, "probe")
    return r["layers"][0]["exposure_end_s"]


def study_scen_space(amctl, source_dir, workdir):
    base = small_base(source_dir)
    levels = (0, 1, 2)
    rs = []
    for g in levels:
        r = scenario(amctl, base, {"numerics": {"global_refinements": g}}, workdir, f"space_{g}")
        print(f"  (global refinements {g}: {r['mesh']['max_cells']} cells, {r['mesh']['max_dofs']} dofs,"
              f" {r['steps']} steps, {r['_cpu_s']:.1f} CPU s)", file=sys.stderr)
        rs.append(r)
    return report("scen-space (reduced scenario, dt 0.1 s)", "uniform refinements (h = 2 mm / 2^g in the plane)",
                  list(levels), scenario_quantities(rs))


def study_scen_time(amctl, source_dir, workdir):
    base = small_base(source_dir)
    # The second layer is spread at the first step boundary after the first exposure ends
    # (plus the recoat time): a recoat time that ends the first exposure's step at 0.4 s
    # keeps the spreading at 0.4 s at every step size.
    end = exposure_end(amctl, base, workdir)
    recoat = 0.4 - end
    dts = (0.1, 0.05, 0.025, 0.0125, 0.00625)
    rs = []
    for dt in dts:
        r = scenario(amctl, base, {"numerics": {"dt_s": dt}, "laser": {"recoat_s": recoat}}, workdir,
                     f"time_{len(rs)}")
        spread = r["layers"][1]["spread_s"]
        if abs(spread - 0.4) > 1e-9:
            sys.exit(f"dt {dt}: the second layer was spread at {spread} s, not 0.4 s")
        print(f"  (dt {dt} s: {r['steps']} steps, {r['_cpu_s']:.1f} CPU s)", file=sys.stderr)
        rs.append(r)
    return report("scen-time (reduced scenario, coarse cells 2 mm)", "dt s", list(dts), scenario_quantities(rs))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("amctl")
    ap.add_argument("source_dir")
    ap.add_argument("--only", default="")
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    studies = {
        "slab-space": lambda w: study_slab_space(a.amctl),
        "slab-time-be": lambda w: study_slab_time(a.amctl, "backward_euler"),
        "slab-time-cn": lambda w: study_slab_time(a.amctl, "crank_nicolson"),
        "ms-space": lambda w: study_ms_space(a.amctl),
        "ms-time": lambda w: study_ms_time(a.amctl),
        "scen-space": lambda w: study_scen_space(a.amctl, a.source_dir, w),
        "scen-time": lambda w: study_scen_time(a.amctl, a.source_dir, w),
    }
    chosen = [s for s in a.only.split(",") if s] or list(studies)
    for s in chosen:
        if s not in studies:
            sys.exit(f"--only: found '{s}', expected one of {', '.join(studies)}")
    results = []
    with tempfile.TemporaryDirectory() as w:
        for s in chosen:
            results.append(studies[s](w))
            sys.stdout.flush()
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
