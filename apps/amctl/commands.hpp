#pragma once
#include <string>
#include <string_view>

#include <CLI/CLI.hpp>

#include "amctl/core/process_ranges.hpp"

namespace amctl::cli {
// One register function per subcommand family, defined in cmd_<family>.cpp. Each adds its
// subcommand(s) to `app` with a callback that does the work (callbacks run inside app.parse,
// so amctl::Error thrown there reaches main's handler).
void register_all(CLI::App& app);
/// Adds to every FLOAT option of `app` and its subcommands a check refusing NaN, infinities and
/// subnormal numbers, naming the flag (called by register_all).
void refuse_non_finite_flags(CLI::App& app);

/// `amctl estimate` (cmd_estimate.cpp): the main job.
void register_estimate(CLI::App& app);
/// `amctl plan`: the planned moves as CSV (cmd_plan.cpp).
void register_plan(CLI::App& app);
/// `amctl report`: one self-contained HTML page about a print (cmd_report.cpp).
void register_report(CLI::App& app);
/// `amctl simulate`, `amctl sweep` (cmd_dynamics.cpp).
void register_dynamics(CLI::App& app);
/// `amctl thermal ...` (cmd_thermal.cpp).
void register_thermal(CLI::App& app);
/// `amctl thermal sls3d` (cmd_sls3d.cpp), added to the thermal subcommand by register_thermal:
/// checks the options, then runs amctl-sls3d with them (the 3D engine's own executable).
void register_thermal_sls3d(CLI::App* thermal);
/// The same options as the whole command line of amctl-sls3d (apps/amctl/sls3d_main.cpp).
void register_sls3d_command(CLI::App& app);
/// `amctl shrink ...`, `amctl calibrate-time` (cmd_process.cpp).
void register_process(CLI::App& app);

/// `amctl estimate FILE --mode empirical [--params fitted.json]`: the seed-004 empirical
/// estimator (cmd_process.cpp), called from cmd_estimate.cpp.
void run_empirical_estimate(const std::string& file, const std::string& params_json, bool as_json);
/// `amctl machine show|list|keys` (cmd_machine.cpp).
void register_machine(CLI::App& app);
/// `amctl shaper show` (cmd_shaper.cpp).
void register_shaper(CLI::App& app);
/// `amctl resonance calibrate` (cmd_resonance.cpp).
void register_resonance(CLI::App& app);
/// `amctl steps`: exact step times per stepper (cmd_steps.cpp).
void register_steps(CLI::App& app);
/// `amctl compensate` (cmd_compensate.cpp).
void register_compensate(CLI::App& app);
/// `amctl stepper simulate`, `amctl stepper sweep` (cmd_stepper.cpp).
void register_stepper(CLI::App& app);
/// `amctl compare` (cmd_compare.cpp).
void register_compare(CLI::App& app);

/// Command-line values in amctl's form for bad input, with the flag as the place:
/// "--damping-ratio: must be a finite number >= 0, got -1" (amctl::Error otherwise).
void require_positive_flag(std::string_view flag, double value);
void require_non_negative_flag(std::string_view flag, double value);
/// "--sample-rate-hz: must be a sample rate in [1, 1e+06] Hz, got 1e+12" (core/quantity.hpp).
void require_range_flag(std::string_view flag, const PhysicalRange& range, double value);
/// A mode's natural frequency flag: a frequency (core/quantity.hpp) below half the sample rate
/// (the Nyquist limit of the simulation at --sample-rate-hz), named as the user gave it.
void require_mode_frequency_flag(std::string_view flag, double f_hz, double sample_rate_hz);
/// Ranges of command-line quantities that are not machine keys (core/quantity.hpp has those):
/// a moving mass from 1 mg to 1 t, a belt or frame stiffness, a viscous damping.
inline constexpr PhysicalRange kMassRange{"mass", "kg", 1e-6, 1e3};
inline constexpr PhysicalRange kStiffnessRange{"stiffness", "N/m", 1e-3, 1e12};
inline constexpr PhysicalRange kViscousDampingRange{"viscous damping", "N s/m", 0.0, 1e9};

/// A damping ratio of a physical mode: [0, 10] (0 undamped, 1 critical; beyond 10 no belt or
/// frame is, and the model's poles spread over six decades).
void require_damping_ratio_flag(std::string_view flag, double zeta);
}  // namespace amctl::cli
