// `amctl simulate` and `amctl sweep`: what the printer physically does with a plan.
//   amctl simulate FILE --machine SPEC --natural-frequency-hz F --damping-ratio Z [--json]
//                  [--sample-rate-hz R] [--csv OUT --csv-rate-hz C] [--t-begin/--t-end S]
//                  [--layer-begin/--layer-end N] [--profile P --jerk J] [--motor-space]
//                  [--shaper T --shaper-freq-hz F | --shaper-x T --shaper-freq-x-hz F
//                   --shaper-y T --shaper-freq-y-hz F] [--shaper-damping-ratio Z]
//   amctl sweep [--json]   seed 000 tables 3.2/3.3 with real look-ahead and zero junction speed
// The work is dynamics::simulate_print and dynamics::seed000_sweep; this file parses flags
// and prints.
#include <cmath>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/core/input.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/dynamics/print_simulation.hpp"
#include "amctl/dynamics/seed000_sweep.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/simulation/shaped_simulation.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

namespace dy = amctl::dynamics;

struct ModelFlags {
  std::optional<double> f_hz, zeta, mass_kg, stiffness, damping;
  std::optional<double> f_hz_y, zeta_y;
  std::vector<std::string> modes;  ///< "f_hz,zeta[,participation]" for both axes
};

dy::AxisModel build_model(const ModelFlags& m, bool y_axis, double sample_rate_hz) {
  if (!m.modes.empty()) {
    if (m.f_hz || m.mass_kg) throw Error("--mode replaces the belt flags; give one or the other");
    std::vector<dy::Mode> modes;
    for (const auto& t : m.modes) modes.push_back(dy::parse_mode_spec(t));
    return dy::AxisModel::from_modes(std::move(modes));
  }
  const auto f = y_axis && m.f_hz_y ? m.f_hz_y : m.f_hz;
  const auto z = y_axis && m.zeta_y ? m.zeta_y : m.zeta;
  if (f) require_mode_frequency_flag(y_axis && m.f_hz_y ? "--natural-frequency-y-hz" : "--natural-frequency-hz", *f, sample_rate_hz);
  if (z) require_damping_ratio_flag(y_axis && m.zeta_y ? "--damping-ratio-y" : "--damping-ratio", *z);
  if (m.damping && !m.mass_kg) throw Error("--damping-n-s-per-m: given without --mass-kg and --stiffness-n-per-m, expected the three together");
  if (m.mass_kg || m.stiffness) {
    if (!m.mass_kg || !m.stiffness) {
      throw Error("--mass-kg and --stiffness-n-per-m must be given together");
    }
    require_range_flag("--mass-kg", kMassRange, *m.mass_kg);
    require_range_flag("--stiffness-n-per-m", kStiffnessRange, *m.stiffness);
    if (m.damping) require_range_flag("--damping-n-s-per-m", kViscousDampingRange, *m.damping);
    // The natural frequency they give must be one the simulation can sample.
    const double f_n = std::sqrt(*m.stiffness / *m.mass_kg) / (2.0 * std::numbers::pi);
    if (f_n >= 0.5 * sample_rate_hz) {
      throw Error(fmt::format("--stiffness-n-per-m: with --mass-kg {} gives a natural frequency of {:g} Hz, "
                              "expected one below half the sample rate ({} Hz at --sample-rate-hz {})",
                              *m.mass_kg, f_n, 0.5 * sample_rate_hz, sample_rate_hz));
    }
    return dy::AxisModel::belt(dy::BeltParameters{*m.mass_kg, *m.stiffness, m.damping.value_or(0.0)});
  }
  if (!f) throw Error("give the belt model: --natural-frequency-hz (with --damping-ratio) or --mass-kg and --stiffness-n-per-m");
  return dy::AxisModel::belt(*f, z.value_or(0.1));
}

machine::VelocityProfile parse_profile(const std::string& s) {
  if (s == "trapezoid") return machine::VelocityProfile::trapezoid;
  if (s == "scurve7") return machine::VelocityProfile::scurve7;
  if (s == "bezier5") return machine::VelocityProfile::bezier5;
  throw Error(fmt::format("--profile: must be trapezoid, scurve7 or bezier5, got '{}'", s));
}

// ------------------------------------------------------------------------------ simulate
struct SimulateArgs {
  std::string file;
  MachineOptions machine;
  ModelFlags model;
  double rate_hz = 1000.0;
  std::optional<double> csv_rate_hz;
  std::string csv;
  std::optional<double> t_begin, t_end;
  std::optional<int> layer_begin, layer_end;
  std::string profile;
  std::optional<double> jerk;
  bool motor_space = false;
  bool json_out = false;
  std::size_t worst = 10;
  double corner_window_s = 0.25;
  // input shaping
  std::optional<std::string> shaper, shaper_x, shaper_y;
  std::optional<double> shaper_freq, shaper_freq_x, shaper_freq_y;
  double shaper_damping = 0.1;
  bool compare_shaper = false;
  bool no_shaper = false;
  std::string shaper_firmware;
  bool shaper_firmware_given = false;  ///< an empty --shaper-firmware "" is refused, not ignored
};

void print_report(const dy::QualityReport& rep) {
  std::cout << fmt::format("contour error: max {:.4f} mm, RMS {:.4f} mm (printing: max {:.4f}, RMS {:.4f})\n",
                           rep.max_contour_error_mm, rep.rms_contour_error_mm,
                           rep.max_contour_error_printing_mm, rep.rms_contour_error_printing_mm);
  std::cout << fmt::format("corners {}: max overshoot {:.4f} mm; ringing wavelength {:.3f} mm, amplitude {:.4f} mm\n",
                           rep.corner_count, rep.max_corner_overshoot_mm, rep.ringing_wavelength_mm,
                           rep.ringing_amplitude_mm);
  std::cout << fmt::format("residual vibration: max {:.4f} mm, at the end {:.4g} mm\n",
                           rep.max_residual_vibration_mm, rep.final_residual_vibration_mm);
}

void do_shaped(const SimulateArgs& a, const machine::Machine& mach, const dy::AxisModel& mx,
               const dy::AxisModel& my, const dy::PrintSimulationOptions& o,
               const simulation::ShaperSettings& shapers, InputFile& input) {
  const simulation::ShapedPrintResult r = simulation::simulate_shaped_print(input, mach, mx, my, o, shapers);
  const bool peaks = mach.profile != machine::VelocityProfile::trapezoid || !a.profile.empty();
  if (a.json_out) {
    std::cout << simulation::to_json(r, peaks).dump(2) << "\n";
    return;
  }
  const dy::QualityReport& rep = r.shaped.report;
  std::cout << fmt::format("{}: {} moves, motion {:.3f} s, profile {}\n", a.file, r.shaped.moves,
                           rep.motion_time_s, r.shaped.profile);
  auto axis = [](const char* name, const std::optional<shaping::Shaper>& s,
                 const std::optional<simulation::AxisShaperSetting>& set) {
    if (!s) return fmt::format("{} none", name);
    const std::string whose = s->spec.firmware == shaping::Firmware::marlin
                                  ? (s->spec.sample_rate_hz > 0.0
                                         ? fmt::format(", Marlin FT_MOTION's on its {:g} Hz grid", s->spec.sample_rate_hz)
                                         : std::string(", Marlin's"))
                                  : std::string();
    return fmt::format("{} {} {:g} Hz damping {:g} ({}{}; {:.1f} ms)", name, shaping::to_string(s->spec),
                       s->freq_hz, s->damping_ratio, set->source, whose, 1e3 * s->duration_s());
  };
  std::cout << fmt::format("input shaper: {}; {} (the shaped pieces through the plant engine, measured "
                           "against the planned path)\n",
                           axis("X", r.shaper_x, r.settings.x), axis("Y", r.shaper_y, r.settings.y));
  for (const auto& w : r.warnings) std::cout << "warning: " << w << "\n";
  std::cout << "with the shaper:\n";
  print_report(rep);
  std::cout << fmt::format("shaped command vs plan (smoothing): max {:.4f} mm, RMS {:.4f} mm, at corners max {:.4f} mm\n",
                           r.smoothing.max_mm, r.smoothing.rms_mm, r.smoothing.max_at_corners_mm);
  std::cout << "without the shaper:\n";
  print_report(r.without.report);
  std::cout << "worst places (shaped):\n";
  for (const auto& w : rep.worst) {
    std::cout << fmt::format("  line {:>8}  layer {:>4}  t {:9.3f} s  ({:8.3f}, {:8.3f})  {:.4f} mm\n",
                             w.line, w.layer, w.t_s, w.x_mm, w.y_mm, w.contour_error_mm);
  }
  std::cout << fmt::format("simulated {} samples in {:.3f} s (plan and unshaped run included)\n", rep.samples,
                           r.shaped.compute_time_s);
}

void do_simulate(const SimulateArgs& a) {
  machine::Machine mach = resolve_machine(a.machine);
  // --profile/--jerk time the plan with another ramp shape: the planner plans it (the same
  // look-ahead with that profile's reachable speeds), exactly as --set printer.profile=P.
  if (!a.profile.empty()) mach.profile = parse_profile(a.profile);
  if (a.jerk) {
    require_range_flag("--jerk", kJerkRange, *a.jerk);
    mach.max_jerk_mm_s3 = *a.jerk;
  }
  require_range_flag("--sample-rate-hz", kSampleRateRange, a.rate_hz);
  const dy::AxisModel mx = build_model(a.model, false, a.rate_hz), my = build_model(a.model, true, a.rate_hz);
  dy::PrintSimulationOptions o;
  if (!(a.shaper_damping >= 0.0 && a.shaper_damping < 1.0)) {
    throw Error(fmt::format("--shaper-damping-ratio: must be in [0, 1) (flags), got {}", a.shaper_damping));
  }
  for (const auto& [flag, f] : {std::pair{"--shaper-freq-hz", a.shaper_freq}, std::pair{"--shaper-freq-x-hz", a.shaper_freq_x},
                                std::pair{"--shaper-freq-y-hz", a.shaper_freq_y}}) {
    if (f && *f > 0.0) require_range_flag(flag, kFrequencyRange, *f);  // <= 0: the shaper's own message
  }
  if (a.csv_rate_hz) require_range_flag("--csv-rate-hz", kSampleRateRange, *a.csv_rate_hz);
  // CLI11 reads "-1" for an unsigned flag as 2^64 - 1: a count beyond any file is refused.
  if (a.worst > 1000000) throw Error(fmt::format("--worst: must be a count in [0, 1000000], got {}", a.worst));
  require_range_flag("--corner-window-s", kDurationRange, a.corner_window_s);
  // A range bound is a time of the print: finite (an open end is simply not given).
  if (a.t_begin && !std::isfinite(*a.t_begin)) throw Error(fmt::format("--t-begin: must be a finite time [s], got {}", *a.t_begin));
  if (a.t_end && !std::isfinite(*a.t_end)) throw Error(fmt::format("--t-end: must be a finite time [s], got {}", *a.t_end));
  o.simulation.sample_rate_hz = a.rate_hz;
  o.simulation.motor_space = a.motor_space;
  if (a.motor_space) o.simulation.motor_rows = machine::motor_space(mach).rows;
  o.simulation.vibration_per_sample = !a.csv.empty();
  o.metrics.worst_count = a.worst;
  o.metrics.corner_window_s = a.corner_window_s;
  o.metrics.keep_per_move = false;  // bounded memory
  if (a.t_begin) o.metrics.t_begin_s = *a.t_begin;
  if (a.t_end) o.metrics.t_end_s = *a.t_end;
  if (a.layer_begin) o.metrics.layer_begin = *a.layer_begin;
  if (a.layer_end) o.metrics.layer_end = *a.layer_end;
  o.csv_path = a.csv;
  o.csv_rate_hz = a.csv_rate_hz;
  simulation::ShaperRequest req;
  req.type = a.shaper;
  req.type_x = a.shaper_x;
  req.type_y = a.shaper_y;
  req.freq_hz = a.shaper_freq;
  req.freq_x_hz = a.shaper_freq_x;
  req.freq_y_hz = a.shaper_freq_y;
  req.damping_ratio = a.shaper_damping;
  req.none = a.no_shaper;
  if (!a.shaper_firmware.empty() || a.shaper_firmware_given) {
    try {
      req.firmware = shaping::parse_firmware(a.shaper_firmware);
    } catch (const Error& e) {
      throw Error(fmt::format("--shaper-firmware: {}", e.what()));
    }
  }
  // M593 before the first move, then the simulation: two passes over one rewindable input
  // (standard input and a FIFO are read once).
  InputFile input(a.file, gcode::gcode_input_options(true));
  const simulation::ShaperSettings shapers = simulation::resolve_shapers(req, mach, input);
  if (!shapers.any()) {
    for (const auto& w : shapers.warnings) std::cerr << "warning: " << w << "\n";
  }
  if (shapers.any() || a.compare_shaper) {
    if (!shapers.any()) throw Error("--compare-shaper needs a shaper: --shaper T --shaper-freq-hz F");
    do_shaped(a, mach, mx, my, o, shapers, input);
    return;
  }
  const dy::PrintSimulationResult r = dy::simulate_print(input, mach, mx, my, o);
  const bool peaks = mach.profile != machine::VelocityProfile::trapezoid || !a.profile.empty();
  if (a.json_out) {
    std::cout << dy::to_json(r, peaks).dump(2) << "\n";
    return;
  }
  const dy::QualityReport& rep = r.report;
  std::cout << fmt::format("{}: {} moves, motion {:.3f} s, profile {}\n", a.file, r.moves,
                           rep.motion_time_s, r.profile);
  print_report(rep);
  std::cout << "worst places:\n";
  for (const auto& w : rep.worst) {
    std::cout << fmt::format("  line {:>8}  layer {:>4}  t {:9.3f} s  ({:8.3f}, {:8.3f})  {:.4f} mm\n",
                             w.line, w.layer, w.t_s, w.x_mm, w.y_mm, w.contour_error_mm);
  }
  std::cout << fmt::format("simulated {} samples in {:.3f} s (plan included)\n", rep.samples,
                           r.compute_time_s);
}

// ------------------------------------------------------------------------------ sweep
void do_sweep(bool json_out, double scv) {
  if (scv != 0.0) require_range_flag("--square-corner-velocity", kSpeedRange, scv);
  const std::vector<dy::Seed000Row> rows = dy::seed000_sweep(scv);
  if (json_out) {
    std::cout << dy::to_json(rows, scv).dump(2) << "\n";
    return;
  }
  std::cout << "the feedforward study's corner (Tables 3.2 and 3.3 of the UFLA thesis), square corner "
               "velocity " << scv << " mm/s with look-ahead\n";
  std::cout << fmt::format("{:<12} {:<10} {:>9} {:>8} {:>10} {:>10} {:>10} {:>10} {:>9}\n", "case",
                           "junction", "time_s", "samples", "max_err", "rms_err", "overshoot",
                           "residual", "junc_v");
  for (const dy::Seed000Row& r : rows) {
    std::cout << fmt::format("{:<12} {:<10} {:>9.4f} {:>8} {:>10.4f} {:>10.4f} {:>10.4f} {:>10.3g} {:>9.3f}\n",
                             r.c.name, r.lookahead ? "lookahead" : "zero", r.motion_time_s, r.samples,
                             r.max_contour_error_mm, r.rms_contour_error_mm,
                             r.max_corner_overshoot_mm, r.final_residual_vibration_mm,
                             r.junction_speed_mm_s);
  }
}

}  // namespace

void register_dynamics(CLI::App& app) {
  auto a = std::make_shared<SimulateArgs>();
  CLI::App* sim = app.add_subcommand("simulate", "Simulate the nozzle through the belt dynamics and measure print quality");
  sim->add_option("file", a->file, "G-code file")->required();
  add_machine_options(*sim, a->machine);
  sim->add_option("--natural-frequency-hz", a->model.f_hz, "belt natural frequency of X and Y [Hz]");
  sim->add_option("--damping-ratio", a->model.zeta, "belt damping ratio of X and Y (default 0.1)");
  sim->add_option("--natural-frequency-y-hz", a->model.f_hz_y, "Y natural frequency if different [Hz]");
  sim->add_option("--damping-ratio-y", a->model.zeta_y, "Y damping ratio if different");
  sim->add_option("--mass-kg", a->model.mass_kg, "moving mass [kg] (instead of the frequency)");
  sim->add_option("--stiffness-n-per-m", a->model.stiffness, "belt stiffness [N/m]");
  sim->add_option("--damping-n-s-per-m", a->model.damping, "belt damping [N s/m]");
  sim->add_option("--mode", a->model.modes,
                  "a vibration mode 'f_hz,damping_ratio[,participation]' of X and Y (repeatable; replaces the belt flags)");
  sim->add_option("--sample-rate-hz", a->rate_hz, "simulation output rate [Hz] (default 1000)");
  sim->add_option("--csv", a->csv,
                  "write commanded and simulated path to this CSV file (a name ending in .npy: "
                  "numpy's binary format, the same columns at full precision)");
  sim->add_option("--csv-rate-hz", a->csv_rate_hz, "CSV row rate [Hz]; must divide the sample rate");
  sim->add_option("--t-begin", a->t_begin, "only measure/write from this print time [s]");
  sim->add_option("--t-end", a->t_end, "only measure/write up to this print time [s]");
  sim->add_option("--layer-begin", a->layer_begin, "only measure/write from this layer");
  sim->add_option("--layer-end", a->layer_end, "only measure/write up to this layer");
  sim->add_option("--profile", a->profile, "plan with this velocity profile: trapezoid, scurve7 or bezier5 (as --set printer.profile=P)");
  sim->add_option("--jerk", a->jerk, "jerk limit for scurve7 [mm/s^3] (as --set printer.max_jerk=J)");
  sim->add_flag("--motor-space", a->motor_space, "apply the belt models to the motors (corexy A, B)");
  sim->add_option("--worst", a->worst, "how many worst places to list (default 10)");
  sim->add_option("--corner-window-s", a->corner_window_s, "time watched after each corner [s]");
  sim->add_option("--shaper", a->shaper, "input shaper type of X and Y (as `amctl shaper show`: zv, mzv, ei, ...)");
  sim->add_option("--shaper-freq-hz", a->shaper_freq, "input shaper frequency of X and Y [Hz]");
  sim->add_option("--shaper-x", a->shaper_x, "input shaper type of X");
  sim->add_option("--shaper-freq-x-hz", a->shaper_freq_x, "input shaper frequency of X [Hz]");
  sim->add_option("--shaper-y", a->shaper_y, "input shaper type of Y");
  sim->add_option("--shaper-freq-y-hz", a->shaper_freq_y, "input shaper frequency of Y [Hz]");
  sim->add_option("--shaper-damping-ratio", a->shaper_damping, "damping ratio the shapers are designed for (default 0.1)");
  CLI::Option* shaper_fw = sim->add_option("--shaper-firmware", a->shaper_firmware,
                  "klipper or marlin: whose shaper definitions to apply (marlin: FT_MOTION's, times on "
                  "its 1 kHz grid; default: Klipper's, and Marlin's stepper ZV for M593)");
  sim->add_flag("--no-shaper", a->no_shaper, "ignore the machine's [input_shaper] (and M593): simulate the plan unshaped");
  sim->add_flag("--compare-shaper", a->compare_shaper, "report with and without the shaper (always done when a shaper is given)");
  sim->add_flag("--json", a->json_out, "print one JSON object");
  sim->callback([a, shaper_fw] {
    a->shaper_firmware_given = shaper_fw->count() > 0;
    do_simulate(*a);
  });

  auto sj = std::make_shared<bool>(false);
  auto scv = std::make_shared<double>(5.0);
  CLI::App* sw = app.add_subcommand("sweep", "The feedforward study's corner cases (Tables 3.2 and 3.3 of the UFLA thesis): base case and "
                                    "variations, look-ahead vs zero junction speed");
  sw->add_option("--square-corner-velocity", *scv, "junction model of the look-ahead runs [mm/s] (default 5)");
  sw->add_flag("--json", *sj, "print one JSON object");
  sw->callback([sj, scv] { do_sweep(*sj, *scv); });
}

}  // namespace amctl::cli
