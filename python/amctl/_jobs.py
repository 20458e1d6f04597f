"""The remaining command-line jobs as functions: progress lines (estimate --write-m73), the
three velocity profiles side by side (estimate --compare-profiles), calibrate-time, shrink
slicing and shrink apply, resonance recommend and test-gcode, and the corner study (sweep).
Each returns what the command's --json prints (the test-gcode program: its text)."""

import os

from . import _amctl
from . import _args


def _point(value, param):
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
        raise TypeError(f"{param} must be (x, y, z) in mm, got {value!r}")
    return tuple(_args.number(v, param, "mm") for v in value)


def _names(value, param):
    if value is None:
        return []
    if isinstance(value, str):
        return [v for v in value.split(",") if v]
    if not all(isinstance(v, str) for v in value):
        raise TypeError(f"{param} must be a list of str or one comma-separated str")
    return list(value)


def write_m73(path, output, machine=None, set=None, *, interval_s=60.0, lenient=False,
              file_limits="keep"):
    """Writes the G-code back with ``M73 P<percent> R<minutes left>`` progress lines computed
    from the planned timeline (``amctl estimate FILE --write-m73 OUT --m73-interval S``).

    Returns {"file", "output", "lines" (M73 lines written), "total_time_s"}. The output is
    written whole or not at all. Arguments as amctl.estimate; interval_s [s] of print time
    between the lines.
    """
    return _amctl._write_m73(_args.path(path, "path"), _args.machine(machine, set),
                             _args.path(output, "output"),
                             _args.number(interval_s, "interval_s", "s"),
                             not _args.boolean(lenient, "lenient"), _args.text(file_limits, "file_limits"))


def compare_profiles(path, machine=None, set=None, *, lenient=False):
    """Plans the file with the trapezoid, Marlin's Bezier and the S-curve (jerk
    ``printer.max_jerk``) and returns print time, peak acceleration and peak jerk of each: the
    dict of ``amctl estimate FILE --compare-profiles --json``."""
    return _amctl._compare_profiles(_args.path(path, "path"), _args.machine(machine, set),
                                    not _args.boolean(lenient, "lenient"))


def calibrate_time(timings_csv, machine=None, set=None, *, mode="planner", fit=None,
                   file_limits="keep", absolute=False, params=None, fix=None,
                   separate_contour=False, save=None):
    """Fits machine limits (planner mode) or the empirical model's speeds (empirical mode) to
    measured print durations: the dict of ``amctl calibrate-time CSV --json``.

    Args:
        timings_csv: CSV gcode,duration_s[,layer] (paths relative to the CSV).
        machine, set: the machine to start from (planner mode).
        mode: "planner" or "empirical".
        fit: limits to fit, a list or "accel,scv": accel, scv, jd, jerk, max_velocity (None: the
            machine's junction policy's defaults).
        file_limits: the files' own limits commands: "keep" (default, as the firmware does),
            "ignore" or "cap" (``--file-limits``).
        absolute: minimise residuals in seconds, not relative ones.
        params, fix, separate_contour: empirical mode (``--params``, ``--fix``,
            ``--separate-contour``).
        save: write the calibrated machine (TOML) or parameters (JSON) there.
    """
    m = _args.machine(machine, set)
    return _amctl._calibrate_time(
        _args.path(timings_csv, "timings_csv"), _args.text(mode, "mode"), m, _names(fit, "fit"),
        _args.text(file_limits, "file_limits"), _args.boolean(absolute, "absolute"),
        _args.optional_path(params, "params"), _names(fix, "fix"),
        _args.boolean(separate_contour, "separate_contour"), _args.optional_path(save, "save"))


def shrink_slicing(csv_path, *, measured_column=None, observed_slicing_column=None, factors=None,
                   scaling="dimension", layer_mm=0.254, first_layer_mm=None, plane_fraction=None):
    """Slicing, dimensional and total error of layered heights (Table 2 of the UTFPR
    process-planning study): the dict of ``amctl shrink slicing CSV --json``. ``factors`` is a
    Z compensation such as "z=0.9902:10:1.0032"; ``scaling`` "dimension", "position" or "none"."""
    return _amctl._shrink_slicing(
        _args.path(csv_path, "csv_path"), _args.optional_text(measured_column, "measured_column"),
        _args.optional_text(observed_slicing_column, "observed_slicing_column"),
        _args.optional_text(factors, "factors"), _args.text(scaling, "scaling"),
        _args.number(layer_mm, "layer_mm", "mm"), _args.optional_number(first_layer_mm, "first_layer_mm", "mm"),
        _args.optional_number(plane_fraction, "plane_fraction"))


def shrink_apply(output, *, factors, model=None, gcode=None, origin_mm=None, stl_format=None,
                 layer_mm=None, first_layer_mm=None, plane_fraction=0.5, scale_e=True):
    """Scales an STL model or a G-code file by shrinkage factors (``amctl shrink apply``):
    exactly one of ``model`` (STL) or ``gcode``; ``factors`` "x=F,y=F,z=F1:BREAK:F2" or the
    JSON file of ``shrink fit``; the output is written whole or not at all. Returns the dict of
    ``--json``."""
    return _amctl._shrink_apply(
        _args.optional_path(model, "model"), _args.optional_path(gcode, "gcode"),
        os.fspath(factors) if isinstance(factors, os.PathLike) else _args.text(factors, "factors"),
        _args.path(output, "output"), _point(origin_mm, "origin_mm"),
        _args.optional_text(stl_format, "stl_format"), _args.optional_number(layer_mm, "layer_mm", "mm"),
        _args.optional_number(first_layer_mm, "first_layer_mm", "mm"),
        _args.number(plane_fraction, "plane_fraction"), _args.boolean(scale_e, "scale_e"))


def resonance_recommend(natural_frequency_hz, damping_ratio, machine=None, set=None, *,
                        max_smoothing_mm=None):
    """The shaper and frequency that minimise the simulated contour error of a modal model on a
    ringing-tower path within a smoothing budget, beside Klipper's pick for the model: the dict
    of ``amctl resonance recommend --json``."""
    return _amctl._resonance_recommend(
        _args.number(natural_frequency_hz, "natural_frequency_hz", "Hz"),
        _args.number(damping_ratio, "damping_ratio"), _args.machine(machine, set),
        _args.optional_number(max_smoothing_mm, "max_smoothing_mm", "mm"))


def resonance_test_gcode(axis, machine=None, set=None, *, style="klipper", freq_start_hz=None,
                         freq_end_hz=None, accel_per_hz=None, accel_mm_s2=None, hz_per_sec=None,
                         point_mm=None, home=True, output=None):
    """The resonance-test program of ``amctl resonance test-gcode`` as text: homing, the test
    at each of the machine's ``[resonance_tester] probe_points`` (or ``point_mm``, or the middle
    of its position limits), bracketed by Klipper's ACCELEROMETER_MEASURE. With ``output`` the
    text is also written there (whole or not at all)."""
    return _amctl._resonance_test_gcode(
        _args.machine(machine, set), _args.text(axis, "axis"), _args.text(style, "style"),
        _args.optional_number(freq_start_hz, "freq_start_hz", "Hz"),
        _args.optional_number(freq_end_hz, "freq_end_hz", "Hz"),
        _args.optional_number(accel_per_hz, "accel_per_hz", "mm/s^2/Hz"),
        _args.optional_number(accel_mm_s2, "accel_mm_s2", "mm/s^2"),
        _args.optional_number(hz_per_sec, "hz_per_sec", "Hz/s"), _point(point_mm, "point_mm"),
        _args.boolean(home, "home"), _args.optional_path(output, "output"))


def sweep(*, square_corner_velocity_mm_s=5.0):
    """The feedforward study's corner cases (Tables 3.2 and 3.3 of the UFLA thesis) with the
    look-ahead and with a full stop at the corner: the dict of ``amctl sweep --json``."""
    return _amctl._sweep(_args.number(square_corner_velocity_mm_s, "square_corner_velocity_mm_s", "mm/s"))
