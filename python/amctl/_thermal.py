"""Temperatures: the SLS powder bed and the FDM hotend/bed loops (docs/thermal.md). Each
function runs the study behind one `amctl thermal` command and returns its --json dict."""

from . import _amctl
from . import _args


def sls_margins(*, kp_w_m2k=None, ti_s=None, modes=1, length_mm=0.1, density_kg_m3=None,
                specific_heat_j_kgk=None, conductivity_w_mk=None, beta_1_s=None,
                hamiltonian_modes=60, kp=None, ti=None, rho=None, cp=None, k=None, beta=None):
    """Additive-uncertainty margins of a PI on the SLS powder bed (the SLS temperature-control
    paper, 2018, section 4).

    The dict of ``amctl thermal sls-margins --json`` (``thermal::run_margin_study``):
    ``margin_on_GN``, ``margin_on_G``, ``hinf_G_minus_GN``, the Hamiltonian margins, Theorem 2,
    closed-loop stability and the Hankel bound (docs/thermal.md).

    Args:
        kp_w_m2k:  PI gain kp [W/(m^2 K)] (default 0.3).
        ti_s:      PI integral time Ti [s] (default 0.5).
        modes:     modal truncation order N (>= 1).
        length_mm: powder depth l [mm].
        density_kg_m3 [kg/m^3], specific_heat_j_kgk [J/(kg K)], conductivity_w_mk [W/(m K)]:
                   the powder (defaults: PA12, 1010, 1928, 0.28).
        beta_1_s:  stability margin beta < 0 of the Hankel bound [1/s] (default -0.01).
        hamiltonian_modes: modes M of the model used for the second margin on G (>= 1).
        kp, ti, rho, cp, k, beta: the command line's spellings of kp_w_m2k, ti_s,
                   density_kg_m3, specific_heat_j_kgk, conductivity_w_mk, beta_1_s.
    """
    kp_w_m2k = _args.alias(kp_w_m2k, "kp_w_m2k", kp, "kp", 0.3)
    ti_s = _args.alias(ti_s, "ti_s", ti, "ti", 0.5)
    density_kg_m3 = _args.alias(density_kg_m3, "density_kg_m3", rho, "rho", 1010.0)
    specific_heat_j_kgk = _args.alias(specific_heat_j_kgk, "specific_heat_j_kgk", cp, "cp", 1928.0)
    conductivity_w_mk = _args.alias(conductivity_w_mk, "conductivity_w_mk", k, "k", 0.28)
    beta_1_s = _args.alias(beta_1_s, "beta_1_s", beta, "beta", -0.01)
    return _amctl._sls_margins(
        _args.number(kp_w_m2k, "kp_w_m2k", "W/(m^2 K)"), _args.number(ti_s, "ti_s", "s"),
        _args.integer(modes, "modes"), _args.number(length_mm, "length_mm", "mm"),
        _args.number(density_kg_m3, "density_kg_m3", "kg/m^3"),
        _args.number(specific_heat_j_kgk, "specific_heat_j_kgk", "J/(kg K)"),
        _args.number(conductivity_w_mk, "conductivity_w_mk", "W/(m K)"),
        _args.number(beta_1_s, "beta_1_s", "1/s"), _args.integer(hamiltonian_modes, "hamiltonian_modes"))


def sls_build(config=None, *, layers=None, anti_windup=None, trace=True):
    """Closed-loop SLS build: the growing 1-D heat equation under the PI (``amctl thermal sls``).

    Returns the dict of ``amctl thermal sls --json`` (``thermal::run_sls_build``):
    ``max_overshoot_k`` [K], ``max_dip_k`` [K], ``mean_settling_time_s`` [s],
    ``total_effort_j_m2`` [J/m^2], ``rms_flux_w_m2`` [W/m^2], ... plus
    ``per_layer`` (one dict per layer addition: setpoint_c [C], dip_k, overshoot_k [K],
    settling_time_s [s], settled, final_error_k [K], effort_j_m2 [J/m^2], saturated_fraction)
    and, with trace=True, ``trace``: numpy arrays t_s [s], layers, depth_m [m], y_c,
    setpoint_c [C], flux_w_m2, disturbance_w_m2, integral_w_m2 [W/m^2] (the --csv columns).

    Args:
        config: TOML configuration (configs/sls_pa12.toml); None: the built-in PA12 values.
        layers: number of layer additions (overrides the configuration).
        anti_windup: 'none', 'clamp_integral', 'back_calculation' or
            'conditional_integration' (overrides the configuration).
        trace: keep the time trace.
    """
    n = _args.optional_integer(layers, "layers")
    return _amctl._sls_build(_args.optional_path(config, "config"), -1 if n is None else n,
                             _args.optional_text(anti_windup, "anti_windup"), _args.boolean(trace, "trace"))


def _heater(bed, target_c, noise_k, cycles, rule, power_w, capacity_j_k, loss_w_k, fan_loss_w_k,
            sensor_tau_s, sensor_delay_s=None, core_capacity_j_k=None, core_to_block_w_k=None):
    return _amctl._heater(
        bed, _args.optional_number(target_c, "target_c", "C"), _args.optional_number(noise_k, "noise_k", "K"),
        _args.optional_integer(cycles, "cycles"), _args.optional_text(rule, "rule"),
        _args.optional_number(power_w, "power_w", "W"), _args.optional_number(capacity_j_k, "capacity_j_k", "J/K"),
        _args.optional_number(loss_w_k, "loss_w_k", "W/K"), _args.optional_number(fan_loss_w_k, "fan_loss_w_k", "W/K"),
        _args.optional_number(sensor_tau_s, "sensor_tau_s", "s"),
        _args.optional_number(sensor_delay_s, "sensor_delay_s", "s"),
        _args.optional_number(core_capacity_j_k, "core_capacity_j_k", "J/K"),
        _args.optional_number(core_to_block_w_k, "core_to_block_w_k", "W/K"))


_HEATER_DOC = """

    Relay autotune (M303-like), M306-like model identification, then the same scenario
    (heat-up, fan step, flow square wave) under the tuned PID, classic Ziegler-Nichols and
    the identified MPC. Returns the dict of ``amctl thermal {cmd} --json``
    (``thermal::run_heater_study``): ``autotune`` (ku_per_k, tu_s, gains), ``identified``,
    ``true_plant``, ``runs`` (heat_up_time_s [s], overshoot_k [K], fan_max_dev_k [K],
    fan_recovery_s [s], flow_ripple_k [K], flow_rms_k [K], energy_j [J]) and ``traces``:
    {{controller: {{t_s [s], measured_c [C], duty [0..1]}}}} as numpy arrays.

    Args (None keeps the {what} default of the study):
        target_c: target temperature [C].
        noise_k: standard deviation of the sensor noise [K].
        cycles: autotune cycles (M303 C, >= 3).
        rule: 'classic_zn', 'some_overshoot' or 'no_overshoot'.
        power_w [W], capacity_j_k [J/K], loss_w_k [W/K] (fan off), fan_loss_w_k [W/K] (extra
        at 100 % fan), sensor_tau_s [s], sensor_delay_s [s] (transport delay to the reading),
        core_capacity_j_k [J/K] (0: no heater-core node), core_to_block_w_k [W/K]: the
        simulated plant (``--power-w`` ... ``--core-to-block-w-k``).
    """


def hotend(*, target_c=None, noise_k=None, cycles=None, rule=None, power_w=None,
           capacity_j_k=None, loss_w_k=None, fan_loss_w_k=None, sensor_tau_s=None, target=None,
           noise=None, sensor_delay_s=None, core_capacity_j_k=None, core_to_block_w_k=None):
    target_c = _args.alias(target_c, "target_c", target, "target", None)
    noise_k = _args.alias(noise_k, "noise_k", noise, "noise", None)
    return _heater(False, target_c, noise_k, cycles, rule, power_w, capacity_j_k, loss_w_k,
                   fan_loss_w_k, sensor_tau_s, sensor_delay_s, core_capacity_j_k, core_to_block_w_k)


def bed(*, target_c=None, noise_k=None, cycles=None, rule=None, power_w=None,
        capacity_j_k=None, loss_w_k=None, fan_loss_w_k=None, sensor_tau_s=None, target=None,
        noise=None, sensor_delay_s=None, core_capacity_j_k=None, core_to_block_w_k=None):
    target_c = _args.alias(target_c, "target_c", target, "target", None)
    noise_k = _args.alias(noise_k, "noise_k", noise, "noise", None)
    return _heater(True, target_c, noise_k, cycles, rule, power_w, capacity_j_k, loss_w_k,
                   fan_loss_w_k, sensor_tau_s, sensor_delay_s, core_capacity_j_k, core_to_block_w_k)


hotend.__doc__ = ("Hotend loop (an E3D V6 with a 40 W cartridge, Prusa-Firmware's thermal model of it,"
                  " at 210 C, classic Ziegler-Nichols)."
                  + _HEATER_DOC.format(cmd="hotend", what="hotend"))
bed.__doc__ = ("Heated-bed loop (a 220 W bed at 60 C, the no-overshoot rule)."
               + _HEATER_DOC.format(cmd="bed", what="bed"))
