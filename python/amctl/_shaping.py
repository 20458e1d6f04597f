"""Input shapers and resonance calibration (docs/shaping.md, docs/resonance.md)."""

import numbers
import os

from . import _amctl
from . import _args


def shaper_show(type, freq_hz, damping_ratio=0.1, *, residual_at_hz=None, test_damping_ratio=None,
                firmware=None, marlin_sample_rate_hz=1000.0):
    """A shaper's impulses and Klipper's measures of it, in Klipper's or Marlin's definition.

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
        firmware: 'klipper' or 'marlin' (FT_MOTION): whose definition of the type (default:
              the type's own, Marlin's for zvdd/zvddd). ``firmware``, ``residual_at_design``
              and ``compared_with`` (the other firmware's definition, its residual and the
              largest differences; None when it lacks the type) say where the two differ.
        marlin_sample_rate_hz: Marlin's trajectory rate FTM_FS [Hz]; its impulse times are
              whole samples of it (0: the exact times of the definition).
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
    fw = "" if firmware is None else _args.text(firmware, "firmware")
    rate = _args.number(marlin_sample_rate_hz, "marlin_sample_rate_hz", "Hz")
    return _amctl._shaper_show(t, f, z, at, tz, fw, rate)


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
              (freq,psd_x,psd_y,psd_z,psd_xyz, also the older calibration_data_*.csv with a
              column per shaper and the several-record freq,NAME1,NAME2,...) or the corpus CSV
              (#time_s,accel_x_mm_s2,...); or a list of them, joined in one fit as
              ``calibrate_shaper.py A.csv B.csv`` joins them (``sources`` lists them).
        axis: 'x' or 'y', the axis the record excited; None as calibrate_shaper.py (no axis
              peak; the fit uses x+y+z either way). A sweep needs it.
        sweep: the commanded sine sweep, (f0_hz, f1_hz, rate_hz_s, accel_mm_s2) or the
              command line's "F0,F1,RATE,ACCEL".
    """
    paths = [path] if isinstance(path, (str, os.PathLike)) else list(path)
    p = [_args.path(x, "path") for x in paths]
    a = "" if axis is None else _args.text(axis, "axis")
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
           thermal=None, file_limits="keep"):
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
        file_limits: the file's own limits: "keep" (default), "ignore" or "cap", as
            amctl.estimate.
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
    return _amctl._report(p, m, out, f, z, r, not _args.boolean(lenient, "lenient"), acc, ax, th,
                          _args.text(file_limits, "file_limits"))


def steps(path, machine=None, set=None, *, csv=None, step_filter="none"):
    """Exact step times of every stepper (``amctl steps``, docs/steppers.md): Klipper's
    convention (a step when the commanded motor position crosses a half-step point), cartesian
    and corexy, Z and the extruder, from the machine's [stepper_*] / [extruder] sections.

    Returns the dict of ``amctl steps --json``: per stepper the step count, the peak step rate
    [steps/s] and its time [s], ... With ``csv`` the steps are written there
    (``stepper,time_s,direction``, whole or not at all); without it they are only counted.
    ``step_filter="klipper"`` drops a step and the step back within 750 us, as Klipper does
    before its MCU (``--step-filter klipper``; ``filtered_pairs`` per stepper).
    """
    p = _args.path(path, "path")
    m = _args.machine(machine, set)
    out = "" if csv is None else _args.path(csv, "csv")
    return _amctl._steps(p, m, out, _args.text(step_filter, "step_filter"))


def stepper_simulate(path=None, machine=None, set=None, *, controller="open", scenario=None,
                     speed_mm_s=90.0, load=True, csv=None, kp=None, ki=None, kd=None,
                     alpha=None, corrupt_probability=0.0, drag_n=None, drag_n_s_per_m=None,
                     bump_n=None, end_load_n_per_mm=None, backlash_mm=None, run_current_a=None,
                     max_current_a=None, drag_gain=None, load_angle_deg=None,
                     model_mass_scale=None, model_stiffness_scale=None, encoder_rate_hz=None,
                     encoder_resolution_um=None, governor=True, speed_change_mm_s=None):
    """Stepper motors, drives, AS5311 encoders, a controller and its command governor simulated
    together (``amctl stepper simulate``, docs/closedloop.md) on a G-code file (``path``) or on
    ``scenario="reversing-strokes"`` (the closed-loop stepper paper's X and Y strokes at
    ``speed_mm_s`` [mm/s], with its load unless ``load=False``). ``controller``: 'open',
    'encoder-sequenced' (the paper's law as published), 'speed-tracking' (that law against the
    time-based reference), 'pid' or 'feedforward' (model feed-forward with current scaling);
    the old names 'seed003' and 'best' still work for one release (with a note).

    Returns the dict of ``amctl stepper simulate --json``: ``notes`` and ``axes.x`` /
    ``axes.y`` with ``max_tracking_error_mm``, ``rms_tracking_error_mm``,
    ``max_path_error_mm``, ``lost_steps`` (microsteps), ``lost_full_steps``,
    ``max_load_angle_deg``, the governor's ``degraded_moves``, ``governor_limited_periods``,
    the ``motor``, ``drive`` and ``mechanics`` simulated, ... With ``csv`` the traces are
    written there. The other keywords are the command's flags of the same names (None: the
    default): kp [-], ki [1/s], kd [s] override the pid/feedforward gains, alpha [1/s] and
    speed_change_mm_s (D* [mm/s]) the paper's; the scenario's load (drag_n [N], drag_n_s_per_m [N s/m], bump_n [N],
    end_load_n_per_mm), backlash_mm, run_current_a (RMS, as Klipper's run_current),
    max_current_a (peak, feedforward's boost limit); feedforward's drag_gain [1/s],
    load_angle_deg and the model error it runs with (model_mass_scale, model_stiffness_scale);
    the encoder's frame rate [Hz] and resolution [um]; ``governor=False`` for the raw laws.
    """
    p = "" if path is None else _args.path(path, "path")
    m = _args.machine(machine, set)
    sc = "" if scenario is None else _args.text(scenario, "scenario")
    v = _args.number(speed_mm_s, "speed_mm_s", "mm/s")
    out = "" if csv is None else _args.path(csv, "csv")
    given = dict(kp=kp, ki=ki, kd=kd, alpha=alpha, drag_n=drag_n, drag_n_s_per_m=drag_n_s_per_m,
                 bump_n=bump_n, end_load_n_per_mm=end_load_n_per_mm, backlash_mm=backlash_mm,
                 run_current_a=run_current_a, max_current_a=max_current_a, drag_gain=drag_gain,
                 load_angle_deg=load_angle_deg, model_mass_scale=model_mass_scale,
                 model_stiffness_scale=model_stiffness_scale, encoder_rate_hz=encoder_rate_hz,
                 encoder_resolution_um=encoder_resolution_um, speed_change_mm_s=speed_change_mm_s)
    overrides = {k: _args.number(x, k) for k, x in given.items() if x is not None}
    return _amctl._stepper_simulate(p, m, _args.text(controller, "controller"), sc, v,
                                    _args.boolean(load, "load"), out, overrides,
                                    _args.number(corrupt_probability, "corrupt_probability"),
                                    _args.boolean(governor, "governor"))


def stepper_sweep(machine=None, set=None, *, load=True, csv=None, svg=None):
    """The reversing-strokes scenario for every controller (open, encoder-sequenced,
    speed-tracking, pid, feedforward) at 30, 60, 90, 120 and 150 mm/s (``amctl stepper sweep
    --json``, docs/closedloop.md section 4), with its load unless ``load=False``. Returns a list
    of dicts ``{controller, speed_mm_s, x, y}`` with the axes as in :func:`stepper_simulate`.
    ``csv`` writes the table, ``svg`` the chart of the maximum error against speed (each whole
    or not at all).
    """
    m = _args.machine(machine, set)
    out_csv = "" if csv is None else _args.path(csv, "csv")
    out_svg = "" if svg is None else _args.path(svg, "svg")
    return _amctl._stepper_sweep(m, _args.boolean(load, "load"), out_csv, out_svg)


def compensate(path, machine=None, set=None, *, method="invert", natural_frequency_hz=None,
               damping_ratio=0.1, plant_natural_frequency_hz=None, plant_damping_ratio=None,
               model_x=None, model_y=None, sample_rate_hz=1000.0, lead_in_s=None, tail_s=None,
               knot_spacing_s=None, degree=3, window_s=None, overlap_s=None,
               max_base_accel_mm_s2=None, effort_weight_s2=1e-9, max_iterations=500, csv=None,
               gcode=None, ignore_machine_limits=False):
    """Feedforward compensation of the belt model (``amctl compensate``, docs/compensation.md).

    Returns the dict of ``amctl compensate --json`` (``max_tracking_error_mm``,
    ``uncompensated_max_tracking_error_mm``, ``peak_command_accel_mm_s2`` (None when
    unbounded), ``lead_in_s``, ``status``, ...) plus ``trace``: numpy arrays ``t_s`` [s],
    ``x_cmd_mm``, ``y_cmd_mm`` (the motor-side command), ``x_des_mm``, ``y_des_mm`` (the
    planned path), ``x_sim_mm``, ``y_sim_mm`` (the plant driven by the command).

    Args:
        method: "invert" (the exact inverse of the model), "fbf" (filtered B-splines), "lpfbf"
            (limited-preview FBF over windows; in Python the whole result is kept in memory, use
            the CLI to stream a long print), "rfbf" (robust FBF over a set of models) or
            "collocation" (Hermite-Simpson direct collocation solved by IPOPT).
        natural_frequency_hz [Hz], damping_ratio: the model the method uses (X and Y), or
            model_x / model_y as amctl.AxisModel.
        plant_natural_frequency_hz, plant_damping_ratio: the plant the result is simulated
            on (default: the model).
        sample_rate_hz [Hz]: the command's time step; lead_in_s, tail_s [s] (None: automatic);
        knot_spacing_s [s] (None: automatic) and degree: FBF's B-splines.
        window_s, overlap_s [s]: LPFBF's and collocation's window and overlap (None: automatic).
        max_base_accel_mm_s2 [mm/s^2]: bound on the command's acceleration; collocation
            enforces it, the other methods report ``status: "base_accel_limit_exceeded"``.
            Without it the command is judged against the machine's own acceleration limit
            (Klipper ``printer.max_accel``, Marlin ``marlin.max_accel`` X/Y): ``status:
            "machine_accel_limit_exceeded"`` and ``machine_accel_limit`` {key, mm_s2, ratio};
            ``ignore_machine_limits=True`` (``--ignore-machine-limits``) skips that.
        effort_weight_s2 [s^2], max_iterations: collocation's effort term and IPOPT's limit.
            When collocation finds no command (``status`` "infeasible" or "solver_failed",
            ``message`` says why) the trace is empty and no CSV is written.
        csv: also write the command as ``amctl compensate --csv`` does.
        gcode: also write the command as dense G-code (``amctl compensate --gcode``).
    """
    p = _args.path(path, "path")
    m = _args.machine(machine, set)
    if model_x is None:
        if natural_frequency_hz is None:
            raise TypeError("give natural_frequency_hz (with damping_ratio) or model_x/model_y")
        f = _args.number(natural_frequency_hz, "natural_frequency_hz", "Hz")
        z = _args.number(damping_ratio, "damping_ratio")
        model_x = _amctl.AxisModel.belt(f, z)
    if model_y is None:
        model_y = model_x
    if plant_natural_frequency_hz is None:
        plant_x, plant_y = model_x, model_y
    else:
        pf = _args.number(plant_natural_frequency_hz, "plant_natural_frequency_hz", "Hz")
        pz = _args.number(damping_ratio if plant_damping_ratio is None else plant_damping_ratio,
                          "plant_damping_ratio")
        plant_x = plant_y = _amctl.AxisModel.belt(pf, pz)
    opt = lambda v, name, unit: -1.0 if v is None else _args.number(v, name, unit)
    return _amctl._compensate(p, m, _args.text(method, "method"), model_x, model_y, plant_x, plant_y,
                              _args.number(sample_rate_hz, "sample_rate_hz", "Hz"),
                              opt(lead_in_s, "lead_in_s", "s"), opt(tail_s, "tail_s", "s"),
                              opt(knot_spacing_s, "knot_spacing_s", "s"), _args.integer(degree, "degree"),
                              opt(window_s, "window_s", "s"), opt(overlap_s, "overlap_s", "s"),
                              float("inf") if max_base_accel_mm_s2 is None
                              else _args.number(max_base_accel_mm_s2, "max_base_accel_mm_s2", "mm/s^2"),
                              _args.number(effort_weight_s2, "effort_weight_s2", "s^2"),
                              _args.integer(max_iterations, "max_iterations"),
                              "" if csv is None else _args.path(csv, "csv"),
                              "" if gcode is None else _args.path(gcode, "gcode"),
                              _args.boolean(ignore_machine_limits, "ignore_machine_limits"))


def compare(path, machine=None, set=None, *, natural_frequency_hz, damping_ratio=0.1,
            methods=None, plant_offsets_pct=None, sample_rate_hz=1000.0, layer=None,
            max_base_accel_mm_s2=None):
    """Every compensation method and the ZV/MZV/EI shapers on one file, with the plant at the
    model and off by each offset (``amctl compare --json``, docs/compensation.md): a dict with
    ``rows`` (method, plant_offset_pct, max_contour_error_mm, max_tracking_error_mm,
    peak_command_accel_mm_s2, compute_time_s, ...). ``pandas.DataFrame(r["rows"])`` makes the
    table.

    Args:
        natural_frequency_hz [Hz], damping_ratio: the model (and the shapers' design).
        methods: default invert, fbf, lpfbf, rfbf, collocation, zv, mzv, ei.
        max_base_accel_mm_s2 [mm/s^2]: bound on the compensation commands (collocation
            enforces it; None: no bound).
        plant_offsets_pct: default -20, -10, 0, 10, 20 (% of the model's frequency).
        layer: only that layer's moves.
    """
    p = _args.path(path, "path")
    m = _args.machine(machine, set)
    meth = [] if methods is None else [_args.text(x, "methods") for x in methods]
    offs = [] if plant_offsets_pct is None else [_args.number(x, "plant_offsets_pct", "%") for x in plant_offsets_pct]
    return _amctl._compare(p, m, _args.number(natural_frequency_hz, "natural_frequency_hz", "Hz"),
                           _args.number(damping_ratio, "damping_ratio"), meth, offs,
                           _args.number(sample_rate_hz, "sample_rate_hz", "Hz"),
                           _args.optional_integer(layer, "layer"),
                           float("inf") if max_base_accel_mm_s2 is None
                           else _args.number(max_base_accel_mm_s2, "max_base_accel_mm_s2", "mm/s^2"))
