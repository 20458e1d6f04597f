#!/usr/bin/python3
"""One and two MPI ranks give the same powder bed (docs/sls3d.md, "Cost and ranks").

Runs `amctl thermal sls3d --config tests/sls3d/small_scenario.toml --json --csv FILE` under
`mpirun -np 1` and `mpirun -np 2` and compares what a user reads: the measured and mean top
temperatures at the snapshots, the controller's flux U and measurement y at every step (the CSV),
the final enthalpy and the mesh. The two runs partition the mesh differently, so the AMG
preconditioner and the order of the sums differ, and each run stops Newton at its own
iterate: the temperatures agree to the Newton tolerance (a step may stop with 1e-5 of its
residual left, on this case a few 1e-7 K), asked here to 1e-5 K; the enthalpy to 1e-8
relative; the CSV's y to 1e-5 K and U to 1e-4 W/m^2, each plus its printing (9 significant
digits).

Usage: mpi_agreement.py AMCTL SOURCE_DIR. Exits 77 (CTest's skip code) when mpirun is absent or
amctl was built without the finite-element engine.
"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

SKIP = 77
TEMP_TOL_K = 1e-5
FLUX_TOL_W_M2 = 1e-4  # kp times the temperature tolerance, with room
CSV_REL_TOL = 1e-8  # the CSV's 9 significant digits
ENTHALPY_REL_TOL = 1e-8


def run(mpirun, amctl, config, ranks, workdir):
    csv_path = os.path.join(workdir, f"uy_{ranks}.csv")
    cmd = [mpirun, "--allow-run-as-root", "--oversubscribe", "-np", str(ranks), amctl, "thermal", "sls3d",
           "--config", config, "--csv", csv_path, "--json"]
    env = dict(os.environ)
    # Ranks waiting in MPI give the core away (the test machine may run other jobs).
    env.setdefault("OMPI_MCA_mpi_yield_when_idle", "1")
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if p.returncode == 2 and "without deal.II" in p.stderr:
        print("SKIP: amctl built without the finite-element engine:", p.stderr.strip())
        sys.exit(SKIP)
    if p.returncode != 0:
        print(" ".join(cmd))
        print(p.stdout)
        print(p.stderr)
        sys.exit(f"-np {ranks} exited with {p.returncode}")
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    return json.loads(p.stdout), rows


def main():
    amctl, source = sys.argv[1], sys.argv[2]
    mpirun = shutil.which("mpirun")
    if mpirun is None:
        print("SKIP: mpirun not found (Debian: openmpi-bin)")
        sys.exit(SKIP)
    config = os.path.join(source, "tests", "sls3d", "small_scenario.toml")
    failures = []
    with tempfile.TemporaryDirectory() as d:
        one, rows1 = run(mpirun, amctl, config, 1, d)
        two, rows2 = run(mpirun, amctl, config, 2, d)
    if one["mpi_ranks"] != 1 or two["mpi_ranks"] != 2:
        failures.append(f"ranks reported {one['mpi_ranks']} and {two['mpi_ranks']}, expected 1 and 2")
    if one["mesh"]["dofs_at_end"] != two["mesh"]["dofs_at_end"]:
        failures.append(f"dofs {one['mesh']['dofs_at_end']} (1 rank) != {two['mesh']['dofs_at_end']} (2 ranks)")
    worst_t = 0.0
    for a, b in zip(one["snapshots"], two["snapshots"]):
        for key in ("measured_c", "top_mean_c"):
            diff = abs(a[key] - b[key])
            worst_t = max(worst_t, diff)
            if not diff <= TEMP_TOL_K:
                failures.append(f"snapshot {a['time_s']} s {key}: {a[key]!r} vs {b[key]!r} ({diff:.3g} K)")
    if len(one["snapshots"]) != len(two["snapshots"]) or not one["snapshots"]:
        failures.append("snapshot lists differ or are empty")
    if len(rows1) != len(rows2) or not rows1:
        failures.append(f"CSV rows {len(rows1)} vs {len(rows2)}")
    flux_key = next(k for k in rows1[0] if k.startswith("flux"))
    y_key = next(k for k in rows1[0] if k.startswith("measured"))
    worst_u = worst_y = 0.0
    for a, b in zip(rows1, rows2):
        for key, tol in ((flux_key, FLUX_TOL_W_M2), (y_key, TEMP_TOL_K)):
            x, y = float(a[key]), float(b[key])
            if not abs(x - y) <= tol + CSV_REL_TOL * max(abs(x), abs(y)):
                failures.append(f"t = {a['t_s']} s {key}: {x!r} vs {y!r}")
        worst_u = max(worst_u, abs(float(a[flux_key]) - float(b[flux_key])))
        worst_y = max(worst_y, abs(float(a[y_key]) - float(b[y_key])))
    e1, e2 = one["energy_j"]["final"], two["energy_j"]["final"]
    rel = abs(e1 - e2) / abs(e1)
    if not rel <= ENTHALPY_REL_TOL:
        failures.append(f"final enthalpy {e1!r} vs {e2!r} J ({rel:.3g} relative)")
    print(f"1 vs 2 ranks: snapshots {worst_t:.3g} K, y {worst_y:.3g} K, U {worst_u:.3g} W/m^2, "
          f"enthalpy {rel:.3g} relative, {len(rows1)} steps, {one['mesh']['dofs_at_end']} dofs")
    if failures:
        print("\n".join(failures))
        sys.exit(1)


if __name__ == "__main__":
    main()
