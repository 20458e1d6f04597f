"""Fleet runs: every G-code file of a queue on every printer, on a Dask cluster.

    python3 -m amctl.fleet DIR_OR_GLOB [...] --machine M [--machine M2 ...]
        [--set section.key=value ...] [--file-limits keep|ignore|cap] [--workers N]
        [--scheduler ADDRESS] [--batch K] [--json | --csv OUT]

Each (file, machine) pair is one ``amctl.estimate`` (the same numbers as ``amctl estimate
--json``); pairs are grouped ``--batch`` at a time into Dask tasks. Without ``--scheduler`` a
local cluster of ``--workers`` single-thread workers (default: one per core) runs them, in
this process: amctl releases the GIL while it plans, so they run in parallel; with it, an
existing Dask scheduler does, which is how a run grows past one machine (every worker must be
able to ``import amctl``: the same build on each, ``PYTHONPATH`` set; the G-code paths must be
readable on the workers). ``--workers 0`` runs everything in this process, without Dask.

A file that fails (malformed G-code, unreadable, bad machine) is one row with its ``error``
and does not stop the batch (the exit code is then 1; 2 for bad arguments). Rows come back in input order (files sorted, then machines in
the order given) whatever order the workers finish in.

``sweep(files, machine, grid)`` runs a parameter grid (for example ``printer.max_accel`` x
``printer.square_corner_velocity`` over a farm's queue) and returns a pandas DataFrame.
See docs/python.md, "Fleet runs".
"""

import argparse
import csv
import glob
import io
import itertools
import json
import logging
import math
import os
import sys
import time

#: Columns of a fleet row, in order (units in the names; ``error`` is None on success).
ROW_KEYS = (
    "file", "machine", "set", "total_time_s", "motion_time_s", "dwell_time_s",
    "travel_time_s", "extrude_time_s", "filament_mm", "moves", "layers",
    "slicer_estimate_s", "compute_time_s", "error", "note",
)

#: Names a directory's G-code files end with (any case), as amctl.gcode_inputs reads them.
GCODE_SUFFIXES = (".gcode", ".gco", ".g", ".bgcode", ".gcode.3mf", ".gcode.gz")


def expand_inputs(inputs):
    """Files named by ``inputs``: a file as is, a directory's G-code files (not recursive:
    text, binary G-code, sliced 3MF, gzip; see GCODE_SUFFIXES), a glob pattern's matches, and
    a 3MF of several plates as its plates (amctl.gcode_inputs). Sorted, without duplicates.
    Raises amctl.Error when an input matches nothing."""
    from ._errors import Error
    from ._planning import gcode_inputs
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    out = []
    for item in inputs:
        item = os.fspath(item)
        if os.path.exists(item):
            found = [item]
        else:
            found = [f for f in glob.glob(item) if os.path.isfile(f)]
        if not found:
            raise Error(f"{item}: no G-code file there (a file, a directory or a glob pattern)")
        out.extend(gcode_inputs(found))
    return sorted(set(out))


def _row(file, machine, overrides, report=None, error=None):
    row = dict.fromkeys(ROW_KEYS)
    row["file"] = file
    row["machine"] = machine if isinstance(machine, str) else getattr(machine, "name", str(machine))
    row["set"] = dict(overrides or {})
    if report is not None:
        for key in ("total_time_s", "motion_time_s", "dwell_time_s", "travel_time_s",
                    "extrude_time_s", "filament_mm", "moves", "slicer_estimate_s",
                    "compute_time_s"):
            value = report.get(key)
            # JSON has no Infinity or NaN (amctl writes them as null): never pass one on.
            row[key] = None if isinstance(value, float) and not math.isfinite(value) else value
        row["layers"] = len(report.get("layers", []))
        if report.get("moves") == 0:
            row["note"] = "no moves"  # an empty file, or only comments: not a print of 0 s
    row["error"] = error
    return row


def estimate_jobs(jobs, file_limits="keep"):
    """Runs on a worker: ``jobs`` is a list of (file, machine, overrides); returns one row per
    job. Never raises for a bad job: the error is in the row. ``file_limits`` as
    amctl.estimate."""
    import amctl
    rows = []
    for file, machine, overrides in jobs:
        try:
            rows.append(_row(file, machine, overrides,
                             report=amctl.estimate(file, machine=machine, set=overrides or None,
                                                   file_limits=file_limits)))
        except amctl.Error as e:
            rows.append(_row(file, machine, overrides, error=str(e)))
        except Exception as e:  # noqa: BLE001 - one bad job is one error row
            rows.append(_row(file, machine, overrides, error=f"{type(e).__name__}: {e}"))
    return rows


def _chunks(items, size):
    for i in range(0, len(items), size):
        yield items[i:i + size]


class _Progress:
    """A one-line progress bar on stderr (only when it is a terminal, unless forced)."""

    def __init__(self, total, enabled):
        self.total, self.done, self.enabled, self.t0 = total, 0, enabled, time.monotonic()

    def advance(self, n):
        self.done += n
        if not self.enabled:
            return
        width = 30
        filled = int(width * self.done / max(1, self.total))
        rate = self.done / max(1e-9, time.monotonic() - self.t0)
        sys.stderr.write(f"\r[{'#' * filled}{' ' * (width - filled)}] {self.done}/{self.total}"
                         f" runs, {rate:.1f}/s")
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def _local_client(workers):
    """A local cluster of `workers` single-thread workers in this process. amctl releases the
    GIL while it plans, so threads run in parallel; and no worker process has to re-import the
    caller's __main__ (which fails, and makes Dask restart workers forever, when the caller is
    a script read from standard input)."""
    from distributed import Client, LocalCluster
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=False,
                           dashboard_address=None, silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _check_workers(client):
    """Every worker must import the same amctl: fail early and clearly otherwise."""
    from ._errors import Error
    from ._amctl import __version__ as here

    def version():
        import amctl
        return amctl.__version__

    try:
        found = client.run(version)
    except Exception as e:  # noqa: BLE001
        raise Error(f"the Dask workers cannot import amctl ({type(e).__name__}: {e}); "
                    "set PYTHONPATH=<build>/python on every worker") from None
    bad = {w: v for w, v in found.items() if v != here}
    if bad:
        raise Error(f"Dask workers run another amctl version: {bad} (here {here})")


def run(files, machines, *, overrides=None, workers=None, scheduler=None, client=None,
        batch=1, progress=False, file_limits="keep"):
    """Estimates every file on every machine; returns the rows (dicts with ROW_KEYS) in input
    order.

    files:     list of paths; a directory stands for its G-code files and a 3MF of several
               plates for its plates, in place (amctl.gcode_inputs); patterns: expand_inputs.
    machines:  list of machine specs (preset, .toml, printer.cfg) or amctl.Machine objects.
    overrides: one {"section.key": value} dict applied to every machine, or a list of such
               dicts, one per run of the grid (sweep uses it); None for none.
    workers:   local cluster size (default os.cpu_count()): threads of this process, which run
               in parallel because amctl releases the GIL; 0 runs without Dask.
    scheduler: address of an existing Dask scheduler (then workers is ignored).
    client:    an existing distributed.Client (then scheduler and workers are ignored).
    batch:     (file, machine) runs per Dask task (> 1 amortises the per-task overhead of
               small files).
    progress:  draw a progress bar on stderr.
    file_limits: the files' own limits commands: "keep" (default, as the firmware does),
               "ignore" or "cap" (as ``amctl estimate --file-limits``).
    """
    from ._errors import Error
    if file_limits not in ("keep", "ignore", "cap"):
        raise Error(f"file_limits: found {file_limits!r}, expected one of keep, ignore, cap")
    from ._planning import gcode_inputs
    files = gcode_inputs([os.fspath(f) for f in files]) if files else []
    if isinstance(machines, (str, os.PathLike)) or not hasattr(machines, "__iter__"):
        machines = [machines]
    machines = list(machines)
    if not files:
        raise Error("fleet run: no G-code files")
    if not machines:
        raise Error("fleet run: no machine (give at least one --machine)")
    if not isinstance(batch, int) or batch < 1:
        raise Error(f"batch must be an integer >= 1, got {batch!r}")
    sets = overrides if isinstance(overrides, list) else [overrides]
    jobs = [(f, m, s) for s in sets for f in files for m in machines]
    bar = _Progress(len(jobs), progress)

    if client is None and scheduler is None and workers == 0:
        rows = []
        for chunk in _chunks(jobs, batch):
            rows.extend(estimate_jobs(chunk, file_limits))
            bar.advance(len(chunk))
        return rows

    from distributed import as_completed
    own = None
    if client is None:
        if scheduler is not None:
            from distributed import Client
            try:
                client = Client(scheduler, timeout="30s")
            except OSError as e:
                raise Error(f"cannot reach the Dask scheduler at {scheduler}: {e}") from None
            own = (client, None)
        else:
            if workers is not None and (not isinstance(workers, int) or workers < 0):
                raise Error(f"workers must be an integer >= 0, got {workers!r}")
            client, cluster = _local_client(workers or os.cpu_count() or 1)
            own = (client, cluster)
    try:
        try:
            client.wait_for_workers(1, timeout=60)
        except Exception as e:  # noqa: BLE001 - a cluster without workers must not hang
            raise Error(f"no Dask worker came up within 60 s ({type(e).__name__})") from None
        _check_workers(client)
        chunks = list(_chunks(jobs, batch))
        futures = client.map(estimate_jobs, chunks, file_limits=file_limits, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        results = [None] * len(chunks)
        for fut in as_completed(futures):
            results[index[fut.key]] = fut.result()
            bar.advance(len(chunks[index[fut.key]]))
        return [row for chunk_rows in results for row in chunk_rows]
    finally:
        if own is not None:
            own[0].close()
            if own[1] is not None:
                own[1].close()


def sweep(files, machine, grid, *, workers=None, scheduler=None, client=None, batch=1,
          progress=False, file_limits="keep"):
    """A parameter grid over a queue, as a pandas DataFrame: one row per (grid point, file),
    with a column per grid key (the value used), the estimate's figures and ``error``.

    grid: {"section.key": [values, ...]} (machine keys of docs/machine.md), e.g.
          {"printer.max_accel": [3000, 5000, 10000],
           "printer.square_corner_velocity": [0, 5, 10]}.
    """
    import pandas as pd
    from ._errors import Error
    if not isinstance(grid, dict) or not grid:
        raise TypeError("grid must be a non-empty dict {'section.key': [values, ...]}")
    keys = list(grid)
    for k in keys:
        if isinstance(grid[k], (str, bytes)) or not hasattr(grid[k], "__iter__"):
            raise TypeError(f"grid['{k}'] must be a list of values")
    points = [dict(zip(keys, values)) for values in itertools.product(*(list(grid[k]) for k in keys))]
    if not points:
        raise Error("sweep: the grid is empty")
    rows = run(files, [machine], overrides=points, workers=workers, scheduler=scheduler,
               client=client, batch=batch, progress=progress, file_limits=file_limits)
    table = []
    for row in rows:
        flat = {k: row["set"].get(k) for k in keys}
        flat.update({k: v for k, v in row.items() if k != "set"})
        table.append(flat)
    return pd.DataFrame(table, columns=keys + [k for k in ROW_KEYS if k != "set"])


def _parse_set(items):
    from ._errors import Error
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise Error(f"--set '{item}': expected section.key=value")
        out[key.strip()] = value.strip()
    return out


def _write_csv(rows, path, inputs=()):
    """The rows as CSV through amctl's one output writer (a regular file whole or not at all;
    '-', a device or a FIFO streamed; amctl.Error naming the path when it cannot be written)."""
    from . import _amctl
    fh = io.StringIO(newline="")
    w = csv.writer(fh)
    w.writerow(ROW_KEYS)
    for row in rows:
        w.writerow([json.dumps(row[k], sort_keys=True) if k == "set" else
                    ("" if row[k] is None else row[k]) for k in ROW_KEYS])
    _amctl._write_output(path, fh.getvalue(), "--csv", list(inputs))


def _hms(s):
    if s is None:
        return "-"
    s = int(round(s))
    return f"{s // 3600}h {s % 3600 // 60:02d}m {s % 60:02d}s" if s >= 3600 else f"{s // 60}m {s % 60:02d}s"


def main(argv=None):
    from ._errors import Error
    p = argparse.ArgumentParser(
        prog="python3 -m amctl.fleet",
        description="Estimate every G-code file on every machine, on a Dask cluster.")
    p.add_argument("inputs", nargs="+", help="G-code files, directories or glob patterns")
    p.add_argument("--machine", "-m", action="append", default=None,
                   help="preset, machine .toml or Klipper printer.cfg (repeatable; default: default)")
    p.add_argument("--set", action="append", default=None, help="section.key=value for every machine")
    p.add_argument("--file-limits", choices=("keep", "ignore", "cap"), default="keep",
                   help="the files' own limits (M204, SET_VELOCITY_LIMIT, ...): keep (default, as "
                        "the firmware does), ignore, or cap at the machine's")
    p.add_argument("--workers", type=int, default=None,
                   help="local cluster workers (default: one per core; 0: no Dask)")
    p.add_argument("--scheduler", default=None, help="address of an existing Dask scheduler")
    p.add_argument("--batch", type=int, default=1, help="runs per Dask task (default 1)")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print a JSON list of rows")
    out.add_argument("--csv", metavar="OUT", help="write the rows as CSV (whole or not at all)")
    p.add_argument("--progress", action="store_true", help="progress bar even when stderr is not a terminal")
    a = p.parse_args(argv)
    try:
        files = expand_inputs(a.inputs)
        # What the runs read (the G-code files, the machine files) is never the output.
        inputs = list(files) + [m for m in (a.machine or []) if os.path.exists(m)]
        if a.csv:
            from . import _amctl
            _amctl._check_output(a.csv, "--csv", inputs)  # fails before the runs
        rows = run(files, a.machine or ["default"], overrides=_parse_set(a.set) or None,
                   workers=a.workers, scheduler=a.scheduler, batch=a.batch,
                   progress=a.progress or sys.stderr.isatty(), file_limits=a.file_limits)
    except Error as e:
        print(f"amctl.fleet: error: {e}", file=sys.stderr)
        return 2
    if a.json:
        json.dump(rows, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    elif a.csv:
        try:
            _write_csv(rows, a.csv, inputs)
        except Error as e:
            print(f"amctl.fleet: error: {e}", file=sys.stderr)
            return 2
        if a.csv != "-":
            print(f"{len(rows)} rows written to {a.csv}")
    else:
        name_w = max(len(os.path.basename(r["file"])) for r in rows)
        mach_w = max(len(r["machine"]) for r in rows)
        for r in rows:
            figure = _hms(r["total_time_s"]) if r["error"] is None else f"error: {r['error']}"
            if r["error"] is None and r["note"]:
                figure = r["note"]
            print(f"{os.path.basename(r['file']):<{name_w}}  {r['machine']:<{mach_w}}  {figure}")
    failed = sum(1 for r in rows if r["error"] is not None)
    if failed:
        print(f"amctl.fleet: {failed} of {len(rows)} runs failed (see their error)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
