// `amctl compensate FILE --machine M --method invert|fbf|lpfbf|rfbf|collocation --natural-frequency-hz F
//  --damping-ratio Z [--natural-frequency-y-hz FY --damping-ratio-y ZY] [--mode F,Z[,G] ...] [--plant-natural-frequency-hz F2 --plant-damping-ratio Z2]
//  [--knot-spacing-s T --degree D] [--sample-rate-hz R] --csv OUT.csv [--json]`:
// feedforward compensation of the belt model (compensation::compensate_file,
// docs/compensation.md).
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/compensation/compensate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/core/memory.hpp"
#include "amctl/core/output.hpp"
#include "amctl/dynamics/print_simulation.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct CompensateArgs {
  std::string file;
  MachineOptions machine;
  std::string method = "invert";
  std::optional<double> f_hz, zeta, plant_f_hz, plant_zeta;
  std::optional<double> f_hz_y, zeta_y;  ///< Y's model where it differs from X's (as in simulate)
  std::vector<std::string> modes;
  std::optional<double> knot_spacing_s;
  int degree = 3;
  double rate_hz = 1000.0;
  std::optional<double> lead_in_s;
  std::optional<double> window_s, overlap_s;
  std::optional<double> max_base_accel_mm_s2;
  double effort_weight_s2 = 1e-9;
  int max_iterations = 500;
  std::string csv;
  std::string gcode;
  bool json = false;
  bool ignore_machine_limits = false;
};

void run_compensate(const CompensateArgs& a) {
  namespace cp = compensation;
  cp::CompensationOptions o;
  o.method = cp::parse_method(a.method);
  if (!a.modes.empty()) {
    if (a.f_hz || a.f_hz_y || a.zeta_y)
      throw Error("--mode replaces --natural-frequency-hz; give one or the other");
    std::vector<dynamics::Mode> modes;
    for (const auto& t : a.modes) modes.push_back(dynamics::parse_mode_spec(t));
    o.model_x = o.model_y = dynamics::AxisModel::from_modes(modes);
  } else {
    if (!a.f_hz) throw Error("--natural-frequency-hz is required (or --mode F,Z[,G])");
    require_range_flag("--sample-rate-hz", kSampleRateRange, a.rate_hz);
    require_mode_frequency_flag("--natural-frequency-hz", *a.f_hz, a.rate_hz);
    const double z = a.zeta.value_or(0.1);
    require_damping_ratio_flag("--damping-ratio", z);
    o.model_x = o.model_y = dynamics::AxisModel::belt(*a.f_hz, z);
    if (a.f_hz_y || a.zeta_y) {
      if (a.f_hz_y) require_mode_frequency_flag("--natural-frequency-y-hz", *a.f_hz_y, a.rate_hz);
      if (a.zeta_y) require_damping_ratio_flag("--damping-ratio-y", *a.zeta_y);
      o.model_y = dynamics::AxisModel::belt(a.f_hz_y.value_or(*a.f_hz), a.zeta_y.value_or(z));
    }
  }
  o.plant_x = o.model_x;
  o.plant_y = o.model_y;
  if (a.plant_f_hz || a.plant_zeta) {
    require_range_flag("--sample-rate-hz", kSampleRateRange, a.rate_hz);
    if (a.plant_f_hz) require_mode_frequency_flag("--plant-natural-frequency-hz", *a.plant_f_hz, a.rate_hz);
    if (a.plant_zeta) require_damping_ratio_flag("--plant-damping-ratio", *a.plant_zeta);
    if (o.model_x.modes().size() != 1)
      throw Error("--plant-natural-frequency-hz needs a one-mode model (--natural-frequency-hz)");
    if (a.f_hz_y || a.zeta_y)
      throw Error("--plant-natural-frequency-hz and --plant-damping-ratio set the plant of both "
                  "axes; give them without --natural-frequency-y-hz / --damping-ratio-y");
    const dynamics::Mode& m = o.model_x.modes()[0];
    o.plant_x = o.plant_y = dynamics::AxisModel::belt(a.plant_f_hz.value_or(m.natural_frequency_hz),
                                                      a.plant_zeta.value_or(m.damping_ratio));
  }
  require_range_flag("--sample-rate-hz", kSampleRateRange, a.rate_hz);
  o.sample_rate_hz = a.rate_hz;
  if (a.knot_spacing_s && !(*a.knot_spacing_s > 0.0 && *a.knot_spacing_s <= 1.0))
    throw Error(fmt::format("--knot-spacing-s: must be in (0, 1] s (a B-spline knot every so many seconds), got {}",
                            *a.knot_spacing_s));
  if (a.lead_in_s && !(*a.lead_in_s >= 0.0))
    throw Error(fmt::format("--lead-in-s: must be >= 0, got {}", *a.lead_in_s));
  o.knot_spacing_s = a.knot_spacing_s.value_or(-1.0);
  o.degree = a.degree;
  o.lead_in_s = a.lead_in_s.value_or(-1.0);
  if ((a.window_s || a.overlap_s) && o.method != cp::Method::lpfbf && o.method != cp::Method::collocation)
    throw Error("--window-s and --overlap-s are options of --method lpfbf and collocation");
  if (a.max_base_accel_mm_s2) {
    require_range_flag("--max-base-accel-mm-s2", kAccelRange, *a.max_base_accel_mm_s2);
    o.max_base_accel_mm_s2 = *a.max_base_accel_mm_s2;
  }
  o.judge_machine_accel = !a.ignore_machine_limits;
  if (!(std::isfinite(a.effort_weight_s2) && a.effort_weight_s2 >= 0.0 && a.effort_weight_s2 <= 1.0))
    throw Error(fmt::format("--effort-weight-s2: must be in [0, 1] s^2, got {}", a.effort_weight_s2));
  o.effort_weight_s2 = a.effort_weight_s2;
  o.max_solver_iterations = a.max_iterations;
  if (a.window_s && !(*a.window_s > 0.0))
    throw Error(fmt::format("--window-s: must be > 0, got {}", *a.window_s));
  if (a.overlap_s && !(*a.overlap_s >= 0.0))
    throw Error(fmt::format("--overlap-s: must be >= 0, got {}", *a.overlap_s));
  o.window_s = a.window_s.value_or(-1.0);
  o.overlap_s = a.overlap_s.value_or(-1.0);
  const machine::Machine m = resolve_machine(a.machine);
  // The methods other than LPFBF hold the whole command: said before it is computed.
  o.on_memory_estimate = [](const cp::MemoryEstimate& e) {
    if (e.bytes > (256ull << 20)) {
      std::cerr << fmt::format("amctl: note: --method {} holds the whole command: {} samples, about {} of "
                               "memory (--method lpfbf streams)\n",
                               e.method, e.samples, memory_text(e.bytes));
    }
  };
  cp::CompensationResult r;
  o.sample_z_e = !a.gcode.empty();
  require_distinct_outputs(a.csv, "--csv", a.gcode, "--gcode");
  if (a.json && (a.csv == "-" || a.gcode == "-")) {
    throw Error("--json: prints on standard output, expected the --csv and --gcode outputs in files");
  }
  // Both outputs opened before the work: one that cannot be written (or is the input) fails now.
  OutputFile csv(a.csv, OutputOptions{"--csv", {a.file}, {}});
  std::optional<OutputFile> gcode;
  if (!a.gcode.empty()) gcode.emplace(a.gcode, OutputOptions{"--gcode", {a.file}, {}});
  // LPFBF streams to the CSV; with --gcode it runs in memory (the same windows and command).
  if (o.method == cp::Method::lpfbf && a.gcode.empty()) {
    r = cp::compensate_file_streaming(a.file, m, o, csv);  // writes the CSV as it goes
    if (r.samples > 0) csv.commit();
  } else {
    r = cp::compensate_file(a.file, m, o);
    if (!r.t_s.empty()) {
      if (gcode) cp::write_gcode(r, *gcode);  // first: it refuses an unbounded command
      cp::write_csv(r, csv);
      if (gcode) gcode->commit();
      csv.commit();
    }
  }
  // A solver that found no command (infeasible bound, iteration limit) writes no CSV.
  const bool no_command = r.t_s.empty() && r.samples == 0;
  if (a.json) std::cout << cp::to_json(r).dump(2) << "\n";
  if (no_command)
    throw Error(fmt::format("{}: {} found no command ({}): {}; {} not written", a.file, r.method, cp::to_string(r.status),
                            r.message, a.csv));
  if (a.json || a.csv == "-" || a.gcode == "-") return;  // standard output holds the command
  std::cout << fmt::format(
      "{}: {} over {:.4f} s of motion, {} samples at {} Hz -> {}\n"
      "  status {}{}{}\n"
      "  max tracking error {:.6g} mm (uncompensated {:.6g} mm), max contour error {:.6g} mm\n"
      "  peak command accel {:.6g} mm/s^2{}, lead-in {:.4f} s, tail {:.4f} s\n"
      "  compute {:.4f} s, {:.1f}x real time\n",
      a.file, r.method, r.motion_time_s, r.t_s.empty() ? r.samples : r.t_s.size(), r.sample_rate_hz, a.csv, cp::to_string(r.status),
      r.message.empty() ? "" : ": ", r.message, r.max_tracking_error_mm,
      r.uncompensated_max_tracking_error_mm, r.max_contour_error_mm, r.peak_command_accel_mm_s2,
      std::isfinite(r.machine_accel_limit_mm_s2)
          ? fmt::format(" (the machine's {} {:g})", r.machine_accel_limit_key, r.machine_accel_limit_mm_s2)
          : std::string(),
      r.lead_in_s, r.tail_s, r.compute_time_s, r.real_time_factor);
}

}  // namespace

void register_compensate(CLI::App& app) {
  auto a = std::make_shared<CompensateArgs>();
  CLI::App* sub = app.add_subcommand(
      "compensate", "Feedforward compensation of the belt model: the motor-side command as CSV");
  sub->add_option("file", a->file, "G-code file")->required();
  add_machine_options(*sub, a->machine);
  sub->add_option("--method", a->method,
                  "invert (exact model inverse) | fbf (filtered B-splines) | lpfbf (limited-preview "
                  "FBF, windowed) | rfbf (robust FBF: the model and +-10 %, +-20 % frequency) | "
                  "collocation (Hermite-Simpson with IPOPT, base acceleration bound enforced)");
  sub->add_option("--natural-frequency-hz", a->f_hz, "model natural frequency of X and Y [Hz]");
  sub->add_option("--damping-ratio", a->zeta, "model damping ratio of X and Y (default 0.1)");
  sub->add_option("--natural-frequency-y-hz", a->f_hz_y, "model natural frequency of Y if different [Hz]");
  sub->add_option("--damping-ratio-y", a->zeta_y, "model damping ratio of Y if different");
  sub->add_option("--mode", a->modes, "model mode F,Z[,G] (repeatable) instead of the belt flags");
  sub->add_option("--plant-natural-frequency-hz", a->plant_f_hz,
                  "plant simulated to check the command [Hz] (default: the model)");
  sub->add_option("--plant-damping-ratio", a->plant_zeta, "plant damping ratio (default: the model)");
  sub->add_option("--knot-spacing-s", a->knot_spacing_s, "fbf: B-spline knot spacing [s] (default: auto)");
  sub->add_option("--degree", a->degree, "fbf: B-spline degree (default 3)");
  sub->add_option("--window-s", a->window_s, "lpfbf, collocation: window length [s] (default: auto)");
  sub->add_option("--overlap-s", a->overlap_s,
                  "lpfbf, collocation: window overlap [s] (default: lpfbf half the window, collocation "
                  "max(0.25 s, 3 settling times))");
  sub->add_option("--max-base-accel-mm-s2", a->max_base_accel_mm_s2,
                  "bound on |(x_b'', y_b'')| [mm/s^2]: collocation enforces it, the other methods report "
                  "whether they respect it");
  sub->add_option("--effort-weight-s2", a->effort_weight_s2,
                  "collocation: rho in the objective mean(|e|^2 + (rho x_b'')^2) [s^2] (default 1e-9)");
  sub->add_option("--max-iterations", a->max_iterations, "collocation: IPOPT iterations per window (default 500)");
  sub->add_option("--lead-in-s", a->lead_in_s, "command time before the first move [s] (default: auto)");
  sub->add_option("--sample-rate-hz", a->rate_hz, "command step [Hz] (default 1000)");
  sub->add_option("--csv", a->csv, "command CSV (written whole or not at all)")->required();
  sub->add_option("--gcode", a->gcode,
                  "also write the command as dense G-code (one G1 per sample, Z and E from the plan) for "
                  "firmware without shaping");
  sub->add_flag("--ignore-machine-limits", a->ignore_machine_limits,
                "do not judge the command against the machine's acceleration limit (printer.max_accel; "
                "Marlin: marlin.max_accel X/Y), which is the default without --max-base-accel-mm-s2");
  sub->add_flag("--json", a->json, "Print a JSON summary");
  sub->callback([a] { run_compensate(*a); });
}

}  // namespace amctl::cli
