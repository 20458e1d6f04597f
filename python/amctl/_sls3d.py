"""The SLS powder bed in 3D (docs/sls3d.md): the closed-loop scenario of a configuration file
or one of the verification cases, exactly as ``amctl thermal sls3d ... --json``.

The finite-element engine (deal.II with Open MPI) cannot be loaded into this process: the
extension links IPOPT, whose sequential MUMPS defines stub MPI functions that would replace
Open MPI's. So this function runs the engine's own executable, ``amctl-sls3d``, and returns
the JSON it prints; with ``mpi_ranks`` it runs it under ``mpirun``."""

import json
import os
import pathlib
import re
import shutil
import subprocess

from . import _args
from ._errors import Error, InternalError

_CASES = ("scenario", "moving-source", "slab-flux", "slab-pi", "lumping-patch")


def _command():
    env = os.environ.get("AMCTL_SLS3D_COMMAND")
    if env:
        return env
    here = pathlib.Path(__file__).resolve().parent
    for guess in (here / "amctl-sls3d", here.parent.parent / "apps" / "amctl" / "amctl-sls3d"):
        if guess.is_file() and os.access(guess, os.X_OK):
            return str(guess)
    found = shutil.which("amctl-sls3d")
    if found:
        return found
    raise Error("amctl-sls3d: not found next to the package, in the build tree or on PATH, expected "
                "the 3D powder-bed executable (set AMCTL_SLS3D_COMMAND to its path)")


def _error(stderr):
    text = stderr.strip().splitlines()[-1] if stderr.strip() else "amctl-sls3d failed"
    text = re.sub(r"^amctl: (error: )?", "", text)
    m = re.match(r"^(.+?):(\d+):(\d+): (.*)$", text)
    if m:
        return Error(text, m.group(1), int(m.group(2)), int(m.group(3)), m.group(4))
    return Error(text)


def sls3d(config=None, *, case="scenario", vtu_dir=None, report=None, csv=None, mpi_ranks=None,
          power_w=None, beam_radius_mm=None, speed_mm_s=None, probes_mm=None,
          thickness_mm=None, flux_w_m2=None, setpoint_rise_k=None, kp=None, ti_s=None, times_s=None,
          cells=None, dt_s=None, scheme=None, patch_mm=None, hatch_mm=None):
    """Runs ``amctl thermal sls3d`` and returns its --json dict.

    Args:
        config:   scenario TOML (configs/sls_seed002_3d.toml); None: the built-in values.
        case:     'scenario', 'moving-source', 'slab-flux', 'slab-pi' or 'lumping-patch'.
        vtu_dir, report, csv: scenario outputs (VTU + .pvd directory, HTML page, U/y CSV).
        mpi_ranks: run under ``mpirun -np N`` (Open MPI; the result agrees to solver tolerance).
        power_w [W], beam_radius_mm [mm] (1/e^2), speed_mm_s [mm/s], probes_mm [(x, y, z) mm]:
                  moving-source (and lumping-patch).
        thickness_mm [mm], flux_w_m2 [W/m^2], setpoint_rise_k [K], kp [W/(m^2 K)], ti_s [s],
        times_s [s], cells, dt_s [s], scheme: slab-flux and slab-pi.
        patch_mm, hatch_mm [mm]: lumping-patch.

    Scenario keys: ``snapshots`` (time_s, file, measured_c, ...), ``energy_balance_rel_error``,
    ``wall_s``; moving-source: ``peak_rise_k``, ``peak_x_mm``, ``probes`` (rise_k); slab cases:
    ``top_rise_k``.
    """
    case = _args.text(case, "case")
    if case not in _CASES:
        raise Error(f"case: found '{case}', expected one of {', '.join(_CASES)}")
    argv = [_command(), "--case", case, "--json"]
    if config is not None:
        argv += ["--config", str(_args.path(config, "config"))]
    for flag, value in (("--vtu-dir", vtu_dir), ("--report", report), ("--csv", csv)):
        if value is not None:
            argv += [flag, str(_args.path(value, flag[2:].replace("-", "_")))]
    numbers = (("--power-w", power_w, "power_w", "W"), ("--beam-radius-mm", beam_radius_mm, "beam_radius_mm", "mm"),
               ("--speed-mm-s", speed_mm_s, "speed_mm_s", "mm/s"), ("--thickness-mm", thickness_mm, "thickness_mm", "mm"),
               ("--flux-w-m2", flux_w_m2, "flux_w_m2", "W/m^2"),
               ("--setpoint-rise-k", setpoint_rise_k, "setpoint_rise_k", "K"), ("--kp", kp, "kp", "W/(m^2 K)"),
               ("--ti-s", ti_s, "ti_s", "s"), ("--dt-s", dt_s, "dt_s", "s"), ("--patch-mm", patch_mm, "patch_mm", "mm"),
               ("--hatch-mm", hatch_mm, "hatch_mm", "mm"))
    for flag, value, name, unit in numbers:
        if value is not None:
            argv += [flag, repr(_args.number(value, name, unit))]
    if cells is not None:
        argv += ["--cells", str(_args.integer(cells, "cells"))]
    if scheme is not None:
        argv += ["--scheme", _args.text(scheme, "scheme")]
    if times_s is not None:
        ts = [times_s] if isinstance(times_s, (int, float)) else list(times_s)
        argv += ["--times-s", ",".join(repr(_args.number(t, "times_s", "s")) for t in ts)]
    for p in probes_mm or ():
        if isinstance(p, (str, bytes)) or len(p) != 3:
            raise TypeError(f"probes_mm must hold (x, y, z) in mm, got {p!r}")
        argv += ["--probe-mm", ",".join(repr(_args.number(v, "probes_mm", "mm")) for v in p)]
    if mpi_ranks is not None:
        n = _args.integer(mpi_ranks, "mpi_ranks")
        if n < 1:
            raise Error(f"mpi_ranks: found {n}, expected at least 1")
        mpirun = shutil.which("mpirun")
        if not mpirun:
            raise Error("mpi_ranks: mpirun not found, expected Open MPI (Debian: openmpi-bin)")
        argv = [mpirun, "--allow-run-as-root", "-np", str(n)] + argv
    proc = subprocess.run(argv, capture_output=True, text=True, check=False)
    if proc.returncode == 2:
        raise _error(proc.stderr)
    if proc.returncode != 0:
        raise InternalError(f"amctl-sls3d exited with {proc.returncode}: {proc.stderr.strip()[-2000:]}")
    return json.loads(proc.stdout)
