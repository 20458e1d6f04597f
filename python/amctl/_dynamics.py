"""What the printer physically does with a plan: amctl simulate (docs/dynamics.md)."""

from . import _amctl
from . import _args
from ._amctl import AxisModel
from ._errors import Error


def _axis_models(natural_frequency_hz, damping_ratio, natural_frequency_y_hz, damping_ratio_y,
                 mass_kg, stiffness_n_per_m, damping_n_s_per_m, modes, model_x, model_y):
    """The belt models of X and Y, from the same choices as the flags of `amctl simulate`."""
    if model_x is not None or model_y is not None:
        for name, v in (("model_x", model_x), ("model_y", model_y)):
            if not isinstance(v, AxisModel):
                raise TypeError(f"{name} must be an amctl.AxisModel (give both), got {type(v).__name__}")
        if natural_frequency_hz is not None or mass_kg is not None or modes is not None:
            raise Error("model_x/model_y replace the belt parameters; give one or the other")
        return model_x, model_y
    if modes is not None:
        if natural_frequency_hz is not None or mass_kg is not None:
            raise Error("modes replaces the belt parameters; give one or the other")
        if not isinstance(modes, (list, tuple)):
            raise TypeError(f"modes must be a list of (natural_frequency_hz, damping_ratio[, participation]), "
                            f"got {type(modes).__name__}")
        spec = []
        for i, md in enumerate(modes):
            if not isinstance(md, (list, tuple)) or len(md) not in (2, 3):
                raise TypeError(f"modes[{i}] must be (natural_frequency_hz, damping_ratio[, participation])")
            f = _args.number(md[0], f"modes[{i}][0] (natural_frequency_hz)", "Hz")
            z = _args.number(md[1], f"modes[{i}][1] (damping_ratio)")
            g = _args.number(md[2], f"modes[{i}][2] (participation)") if len(md) == 3 else 1.0
            spec.append((f, z, g))
        model = AxisModel.from_modes(spec)
        return model, model
    if mass_kg is not None or stiffness_n_per_m is not None:
        if mass_kg is None or stiffness_n_per_m is None:
            raise Error("mass_kg and stiffness_n_per_m must be given together")
        model = AxisModel.from_belt(_args.number(mass_kg, "mass_kg", "kg"),
                                    _args.number(stiffness_n_per_m, "stiffness_n_per_m", "N/m"),
                                    _args.number(0.0 if damping_n_s_per_m is None else damping_n_s_per_m,
                                                 "damping_n_s_per_m", "N s/m"))
        return model, model
    if natural_frequency_hz is None:
        raise Error("give the belt model: natural_frequency_hz (with damping_ratio), mass_kg and "
                    "stiffness_n_per_m, modes, or model_x and model_y")
    f = _args.number(natural_frequency_hz, "natural_frequency_hz", "Hz")
    z = 0.1 if damping_ratio is None else _args.number(damping_ratio, "damping_ratio")
    fy = f if natural_frequency_y_hz is None else _args.number(natural_frequency_y_hz, "natural_frequency_y_hz", "Hz")
    zy = z if damping_ratio_y is None else _args.number(damping_ratio_y, "damping_ratio_y")
    return AxisModel.belt(f, z), AxisModel.belt(fy, zy)


def simulate(path, machine=None, set=None, *, natural_frequency_hz=None, damping_ratio=None,
             natural_frequency_y_hz=None, damping_ratio_y=None, mass_kg=None,
             stiffness_n_per_m=None, damping_n_s_per_m=None, modes=None, model_x=None,
             model_y=None, sample_rate_hz=1000.0, t_begin=None, t_end=None, layer_begin=None,
             layer_end=None, profile=None, jerk_mm_s3=None, motor_space=False, worst=10,
             corner_window_s=0.25, samples=False, samples_rate_hz=None, jerk=None,
             shaper=None, shaper_freq_hz=None, shaper_x=None, shaper_freq_x_hz=None,
             shaper_y=None, shaper_freq_y_hz=None, shaper_damping_ratio=0.1, no_shaper=False,
             shaper_firmware=None):
    """Simulates the nozzle through the belt dynamics of X and Y and measures print quality.

    Returns the dict of ``amctl simulate FILE --json`` (``dynamics::simulate_print`` +
    ``to_json``): ``motion_time_s`` [s], ``samples``, ``max_contour_error_mm`` [mm],
    ``rms_contour_error_mm``, ``max_contour_error_printing_mm``, ``max_corner_overshoot_mm``,
    ``ringing_wavelength_mm`` (None if not measured), ``worst`` (list of places),
    ``layers``, ``features``, ``model``, ... (``compute_time_s`` differs between runs).

    The belt model, as the flags of ``amctl simulate`` (one of):
        natural_frequency_hz [Hz] with damping_ratio (default 0.1), optionally
            natural_frequency_y_hz / damping_ratio_y for Y;
        mass_kg [kg] and stiffness_n_per_m [N/m] (damping_n_s_per_m [N s/m], default 0);
        modes: [(natural_frequency_hz, damping_ratio[, participation]), ...] for X and Y;
        model_x and model_y: amctl.AxisModel values.

    Other args:
        path, machine, set: as amctl.estimate().
        sample_rate_hz: simulation output rate [Hz] (> the models' Nyquist limit).
        t_begin, t_end [s]; layer_begin, layer_end: only measure (and sample) this range.
        profile: plan with 'trapezoid', 'scurve7' or 'bezier5' (as --set printer.profile=P);
            jerk_mm_s3 (or jerk, as the flag): the scurve7 jerk [mm/s^3] (as
            --set printer.max_jerk=J). With either,
            or a jerk-limited machine, the dict has peak_accel_mm_s2 and peak_jerk_mm_s3.
        motor_space: apply the models to the motors (corexy A, B) instead of X and Y.
        worst: how many worst places to list; corner_window_s [s]: time watched per corner.
        samples: also return the samples, under the key "trace" (the key "samples" is the
            metrics' sample count, as in the CLI's JSON): a dict of 1-D numpy arrays ``t_s`` [s], ``cmd_x_mm``, ``cmd_y_mm``, ``cmd_z_mm`` (commanded),
            ``sim_x_mm``, ``sim_y_mm`` (simulated nozzle) [mm], ``contour_error_mm`` [mm],
            ``vibration_mm`` [mm] (free-vibration amplitude) and ``line`` (G-code line):
            the rows of ``amctl simulate --csv`` (samples inside the measured range).
            Memory: 72 bytes per kept sample (up to twice that while the arrays grow), i.e.
            72 kB per second of print at 1 kHz, ~520 MB for a 2-hour print: use
            samples_rate_hz or a t_/layer_ range for long prints. The metrics themselves
            need bounded memory whatever the length.
        samples_rate_hz: keep every (sample_rate_hz / samples_rate_hz)-th sample [Hz]; must
            divide sample_rate_hz (default: every sample).

    Input shaping, as ``amctl simulate --shaper ...`` (docs/dynamics.md section 7):
        shaper (type, e.g. 'mzv') and shaper_freq_hz [Hz] for X and Y, or per axis shaper_x /
        shaper_freq_x_hz and shaper_y / shaper_freq_y_hz; shaper_damping_ratio (default 0.1).
        Without them the machine's [input_shaper] applies, then an M593 before the first
        move; no_shaper=True simulates without any. shaper_firmware 'klipper' or 'marlin'
        (FT_MOTION's, times on its 1 kHz grid) applies that firmware's definitions to every
        shaper in use (default: Klipper's, and Marlin's stepper ZV for M593). With a shaper the
        dict has ``shaper``,
        ``smoothing_mm`` figures and ``without_shaper`` (the same metrics unshaped), and the
        trace is the shaped nozzle against the planned path.

    The GIL is released while the simulation runs. Raises amctl.Error for bad input.
    """
    jerk_mm_s3 = _args.alias(jerk_mm_s3, "jerk_mm_s3", jerk, "jerk", None)
    p = _args.path(path, "path")
    n_worst = _args.integer(worst, "worst")
    if n_worst < 0:
        raise Error(f"worst must be >= 0, got {n_worst}")
    m = _args.machine(machine, set)
    overrides = {}
    if profile is not None:
        overrides["printer.profile"] = _args.text(profile, "profile")
    if jerk_mm_s3 is not None:
        overrides["printer.max_jerk"] = _args.number(jerk_mm_s3, "jerk_mm_s3", "mm/s^3")
    with_peaks = m.profile != "trapezoid" or profile is not None
    if overrides:
        m = m.with_set(overrides)
    mx, my = _axis_models(natural_frequency_hz, damping_ratio, natural_frequency_y_hz,
                          damping_ratio_y, mass_kg, stiffness_n_per_m, damping_n_s_per_m, modes,
                          model_x, model_y)
    return _amctl._simulate(
        p, m, mx, my, _args.number(sample_rate_hz, "sample_rate_hz", "Hz"),
        _args.boolean(motor_space, "motor_space"), n_worst,
        _args.number(corner_window_s, "corner_window_s", "s"),
        _args.optional_number(t_begin, "t_begin", "s"), _args.optional_number(t_end, "t_end", "s"),
        _args.optional_integer(layer_begin, "layer_begin"), _args.optional_integer(layer_end, "layer_end"),
        with_peaks, _args.boolean(samples, "samples"),
        _args.optional_number(samples_rate_hz, "samples_rate_hz", "Hz"),
        _amctl._shaper_request(
            None if shaper is None else _args.text(shaper, "shaper"),
            None if shaper_x is None else _args.text(shaper_x, "shaper_x"),
            None if shaper_y is None else _args.text(shaper_y, "shaper_y"),
            _args.optional_number(shaper_freq_hz, "shaper_freq_hz", "Hz"),
            _args.optional_number(shaper_freq_x_hz, "shaper_freq_x_hz", "Hz"),
            _args.optional_number(shaper_freq_y_hz, "shaper_freq_y_hz", "Hz"),
            _args.number(shaper_damping_ratio, "shaper_damping_ratio"),
            _args.boolean(no_shaper, "no_shaper"),
            "" if shaper_firmware is None else _args.text(shaper_firmware, "shaper_firmware")))
