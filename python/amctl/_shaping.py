"""Input shapers and resonance calibration (docs/shaping.md, docs/resonance.md)."""

import numbers

from . import _amctl
from . import _args


def shaper_show(type, freq_hz, damping_ratio=0.1, *, residual_at_hz=None, test_damping_ratio=None):
    """A shaper's impulses and Klipper's measures of it.

    The dict of ``amctl shaper show --type T --freq-hz F --damping-ratio Z --json``:
    ``amplitudes`` and ``times_s`` [s] (as Klipper's definitions give them, unnormalised),
    ``smoothing_mm`` [mm] (at 5000 mm/s^2 and square corner velocity 5 mm/s),
    ``max_accel_mm_s2`` [mm/s^2] (smoothing 0.12 mm at scv 5), ``residual_vibration``
    (fraction of the vibration left at each of ``residual_at_hz``), ``duration_s``, ...

    Args:
        type: zv, mzv, zvd, ei, 2hump_ei, 3hump_ei, zvdd, zvddd, or Klipper's
              mzv(n=N, t=T) / ei(v_tol=V) spellings.
        freq_hz: design frequency [Hz], > 0.
        damping_ratio: design damping ratio, in [0, 1).
        residual_at_hz: frequencies [Hz] at which to report the remaining vibration
              (default: the design frequency).
        test_damping_ratio: damping ratio of the vibrating mode for the residual (default:
              damping_ratio).
    """
    t = _args.text(type, "type")
    f = _args.number(freq_hz, "freq_hz", "Hz")
    z = _args.number(damping_ratio, "damping_ratio")
    at = []
    if residual_at_hz is not None:
        if isinstance(residual_at_hz, numbers.Real):
            residual_at_hz = [residual_at_hz]
        at = [_args.number(x, "residual_at_hz", "Hz") for x in residual_at_hz]
    tz = None if test_damping_ratio is None else _args.number(test_damping_ratio, "test_damping_ratio")
    return _amctl._shaper_show(t, f, z, at, tz)


def resonance_calibrate(path, axis="x", *, sweep=None):
    """Klipper's shaper calibration of an accelerometer record, and the modal fit of a known
    sweep.

    The dict of ``amctl resonance calibrate FILE --axis A --json``: the record's
    ``sample_rate_hz``, jitter, gaps and clipping; ``klipper.recommended.{name, freq_hz}`` and
    ``klipper.shapers`` (``name``, ``freq_hz``, ``vibrations`` (fraction), ``smoothing``,
    ``max_accel_mm_s2``), equal to Klipper's calibrate_shaper.py; with ``sweep``, ``model``
    (``natural_frequency_hz``, ``damping_ratio``, gain, uncertainties).

    Args:
        path: Klipper raw accelerometer CSV (#time,accel_x,accel_y,accel_z), Klipper PSD CSV
              (freq,psd_x,psd_y,psd_z,psd_xyz) or the corpus CSV (#time_s,accel_x_mm_s2,...).
        axis: 'x' or 'y', the axis the record excited.
        sweep: the commanded sine sweep, (f0_hz, f1_hz, rate_hz_s, accel_mm_s2) or the
              command line's "F0,F1,RATE,ACCEL".
    """
    p = _args.path(path, "path")
    a = _args.text(axis, "axis")
    s = ""
    if sweep is not None:
        if isinstance(sweep, str):
            s = sweep
        else:
            vals = [_args.number(v, "sweep") for v in sweep]
            if len(vals) != 4:
                raise TypeError("sweep must be (f0_hz, f1_hz, rate_hz_s, accel_mm_s2)")
            s = ",".join(repr(v) for v in vals)
    return _amctl._resonance_calibrate(p, a, s)


def report(path, machine=None, set=None, *, output=None, natural_frequency_hz=None,
           damping_ratio=0.1, sample_rate_hz=1000.0, lenient=False, accel=None, accel_axis="x",
           thermal=None):
    """Writes the self-contained HTML report of a print (``amctl report``, docs/report.md) and
    returns the dict of ``amctl report --json``: ``output`` (the page's path), ``bytes``,
    ``moves``, ``layers``, ``toolpath_points``, ``speed_buckets``, ``simulated``, ...

    Args:
        path: G-code file.
        machine, set: as for amctl.estimate.
        output: the page to write (default report.html, as the command line).
        natural_frequency_hz, damping_ratio: a belt model [Hz, -]: simulate and colour the
            toolpath by contour error.
        sample_rate_hz: simulation rate [Hz] with a belt model.
        lenient: skip malformed lines instead of raising.
        accel, accel_axis: an accelerometer record and the axis it excited: adds the
            resonance section (Klipper's calibration, the PSD and the shaper curves).
        thermal: "hotend" or "bed": adds the heater loop section (temperature, set point and
            effort of the tuned PID and the MPC).
    """
    p = _args.path(path, "path")
    m = _args.machine(machine, set)
    out = _args.path("report.html" if output is None else output, "output")
    f = None if natural_frequency_hz is None else _args.number(natural_frequency_hz, "natural_frequency_hz", "Hz")
    z = _args.number(damping_ratio, "damping_ratio")
    r = _args.number(sample_rate_hz, "sample_rate_hz", "Hz")
    acc = "" if accel is None else _args.path(accel, "accel")
    ax = _args.text(accel_axis, "accel_axis")
    th = "" if thermal is None else _args.text(thermal, "thermal")
    return _amctl._report(p, m, out, f, z, r, not _args.boolean(lenient, "lenient"), acc, ax, th)


def steps(path, machine=None, set=None, *, csv=None):
    """Exact step times of every stepper (``amctl steps``, docs/steppers.md): Klipper's
    convention (a step when the commanded motor position crosses a half-step point), cartesian
    and corexy, Z and the extruder, from the machine's [stepper_*] / [extruder] sections.

    Returns the dict of ``amctl steps --json``: per stepper the step count, the peak step rate
    [steps/s] and its time [s], ... With ``csv`` the steps are written there
    (``stepper,time_s,direction``, whole or not at all); without it they are only counted.
    """
    p = _args.path(path, "path")
    m = _args.machine(machine, set)
    out = "" if csv is None else _args.path(csv, "csv")
    return _amctl._steps(p, m, out)
