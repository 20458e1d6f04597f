"""Print time and planned moves: amctl estimate and amctl plan (docs/planner.md)."""

import os

import numpy as np

from . import _amctl
from . import _args


def estimate(path, machine=None, set=None, *, lenient=False, mode="planner", params=None,
             file_limits="keep"):
    """Plans every move as the firmware does and reports the print time.

    The same dict as ``amctl estimate FILE --json`` (``plan::estimate_file`` +
    ``plan::to_json``): ``total_time_s`` [s], ``motion_time_s``, ``dwell_time_s``,
    ``travel_time_s``, ``extrude_time_s``, ``filament_mm`` [mm], ``filament_volume_mm3``,
    ``max_speed_mm_s`` [mm/s], ``moves``, ``layers`` (list), ``features`` (list),
    ``heater_waits``, ``unknown_commands``, ``slicer_estimate_s``, ..., and
    ``compute_time_s`` (wall-clock time of this run, the only key that differs between runs).

    Args:
        path:    G-code file (str or os.PathLike).
        machine: preset name, machine .toml, Klipper printer.cfg or amctl.Machine
                 (None: the 'default' preset).
        set:     {"section.key": value} overrides, as ``--set`` (units in docs/machine.md).
        lenient: skip malformed lines (counted in ``skipped_lines``) instead of raising.
        mode:    "planner" (default) or "empirical": the process-planning study's
                 average-speed model, the
                 dict of ``amctl estimate --mode empirical --json`` (see estimate_empirical).
        params:  empirical mode only: parameter file (JSON), None for the study's FDM 2000 speeds
                 (uncalibrated for your printer).
        file_limits: the file's own limits commands (M204, SET_VELOCITY_LIMIT, M201, M203,
                 M205, M566), as ``--file-limits``: "keep" (default, as the firmware does:
                 they override the machine's), "ignore" (the machine's limits alone) or "cap"
                 (applied, never above the machine's). The dict's ``file_limits`` says what
                 the file set and what was done with it.

    The GIL is released while the file is planned. Raises amctl.Error (with file, line,
    column) for malformed G-code or a bad machine.
    """
    p = _args.path(path, "path")
    lenient = _args.boolean(lenient, "lenient")
    mode = _args.text(mode, "mode")
    if mode == "empirical":
        from ._process import estimate_empirical
        return estimate_empirical(p, params=params)
    if mode != "planner":
        raise _amctl_error(f"mode must be 'planner' or 'empirical', got '{mode}'")
    m = _args.machine(machine, set)
    return _amctl._estimate(p, m, not lenient, _args.text(file_limits, "file_limits"))


def _amctl_error(message):
    from ._errors import Error
    return Error(message)


def iter_plan(path, machine=None, set=None, *, batch_moves=4096, lenient=False,
              t_begin=None, t_end=None, layer_begin=None, layer_end=None, file_limits="keep"):
    """Yields the planned moves batch by batch, each a numpy structured array of MOVE_DTYPE.

    Memory stays bounded on a whole print: one batch of about ``batch_moves`` moves (the
    planner may release a few more at once; 192 bytes per move) plus the planner's
    look-ahead. Each batch comes from one
    ``plan::PlanSource::next()`` call, run with the GIL released.

    Fields (the columns of ``amctl plan``, docs/planner.md "The planned moves as CSV"):
        line (uint64), layer (int32, -1 before the first), feature (str, the slicer's name),
        start_time_s, duration_s [s]; x0_mm, y0_mm, z0_mm, e0_mm, x1_mm, y1_mm, z1_mm, e1_mm
        [mm]; distance_mm [mm]; start_v_mm_s, cruise_v_mm_s, end_v_mm_s [mm/s];
        accel_mm_s2 [mm/s^2]; jerk_mm_s3 [mm/s^3]; accel_t_s, cruise_t_s, decel_t_s [s];
        profile (str: trapezoid, scurve7, bezier5); extrude_only (bool).
    The doubles are the planner's own, bit for bit (the CSV reads back to the same values).

    Args:
        path, machine, set, lenient, file_limits: as estimate().
        batch_moves: moves asked for per batch (>= 1); the plan does not depend on it.
        t_begin, t_end: keep moves overlapping this print-time range [s] (``--t-begin``...).
        layer_begin, layer_end: keep moves of these layers (inclusive).
    """
    p = _args.path(path, "path")
    n = _args.integer(batch_moves, "batch_moves")
    if n < 1:
        raise _amctl_error(f"batch_moves must be >= 1, got {n}")
    m = _args.machine(machine, set)
    reader = _amctl._PlanReader(
        p, m, not _args.boolean(lenient, "lenient"), n,
        _args.optional_number(t_begin, "t_begin", "s"), _args.optional_number(t_end, "t_end", "s"),
        _args.optional_integer(layer_begin, "layer_begin"), _args.optional_integer(layer_end, "layer_end"),
        _args.text(file_limits, "file_limits"))
    return _batches(reader)


def _batches(reader):
    while True:
        batch = reader.next()
        if batch is None:
            return
        yield batch


def plan(path, machine=None, set=None, *, lenient=False, t_begin=None, t_end=None,
         layer_begin=None, layer_end=None, batch_moves=65536, file_limits="keep"):
    """Every planned move as one numpy structured array (MOVE_DTYPE; see iter_plan).

    The same rows and values as ``amctl plan FILE`` (one row per move, in plan order). The
    array holds the whole print: 192 bytes per move (a 2-hour print of 10^6 moves is
    ~190 MB, twice that for a moment while the batches are joined). Use iter_plan() or a
    t_/layer_ range for less. Arguments as iter_plan().
    """
    batches = list(iter_plan(path, machine, set, batch_moves=batch_moves, lenient=lenient,
                             t_begin=t_begin, t_end=t_end, layer_begin=layer_begin,
                             layer_end=layer_end, file_limits=file_limits))
    if not batches:
        return np.zeros(0, dtype=_amctl.MOVE_DTYPE)
    if len(batches) == 1:
        return batches[0]
    return np.concatenate(batches)


def gcode_inputs(inputs):
    """The G-code inputs that ``inputs`` name, in order (``formats::expand_gcode_inputs``, as
    ``amctl estimate A B DIR ...`` expands them): a file as it is, a directory's G-code files
    (not recursive: .gcode, .gco, .g, .bgcode, .gcode.3mf, .gcode.gz; sorted), and a 3MF with
    several plates as one path per plate ("print.gcode.3mf/Metadata/plate_2.gcode", which
    ``estimate`` reads). A path that does not exist is kept (reading it raises).

    Raises amctl.Error for a directory without G-code.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    return _amctl._gcode_inputs([_args.path(p, "inputs") for p in inputs])
