// `amctl stepper simulate [FILE] --machine M --controller open|encoder-sequenced|speed-tracking|
//  pid|feedforward [--scenario reversing-strokes --speed-mm-s V] [--no-load] [--csv OUT]
//  [--json]`: stepper, drive, encoder, controller and command governor simulated together
// (docs/closedloop.md).
// `amctl stepper sweep --machine M [--csv OUT] [--svg CHART]`: the reversing-strokes scenario
// over 30..150 mm/s for every controller, as a table and a chart.
#include <iostream>
#include <memory>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/process/atomic_file.hpp"
#include "amctl/report/line_chart.hpp"
#include "amctl/report/stepper_sweep_chart.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct StepperArgs {
  MachineOptions machine;
  closedloop::SimulateRequest req;
  bool no_load = false;
  bool no_governor = false;
  bool json = false;
};

void run_simulate(const StepperArgs& a) {
  require_range_flag("--speed-mm-s", kSpeedRange, a.req.speed_mm_s);
  const machine::Machine m = resolve_machine(a.machine);
  closedloop::SimulateRequest req = a.req;
  req.load = !a.no_load;
  req.governor = !a.no_governor;
  const closedloop::SimulationResult r = closedloop::stepper_simulate(m, req);
  if (a.json) {
    std::cout << closedloop::to_json(r).dump(2) << "\n";
    return;
  }
  std::cout << fmt::format("amctl stepper simulate: {} controller {} ({:.3f} s simulated{})\n",
                           r.source, r.controller, r.duration_s,
                           r.speed_mm_s > 0 ? fmt::format(", {} mm/s, {}", r.speed_mm_s,
                                                          r.load ? "load" : "no load")
                                            : "");
  for (const closedloop::AxisResult& x : r.axes) {
    std::cout << fmt::format(
        "  {}: motor {} ({}), {:.1f} V, run current {:.2f} A RMS ({:.2f} A peak, up to {:.2f} A)\n",
        x.name, x.motor_name, x.motor_source, x.drive.supply_voltage_v,
        x.drive.current_amplitude_a / std::numbers::sqrt2, x.drive.current_amplitude_a,
        x.max_current_a);
  }
  for (const closedloop::AxisResult& x : r.axes) {
    std::cout << fmt::format(
        "  {}: max error {:.4f} mm at {:.3f} s, rms {:.4f} mm; path error max {:.4f} / rms "
        "{:.4f} mm; endpoint error max {:.4f} / rms {:.4f} mm; lost {} steps ({} full steps), "
        "max load angle {:.1f} deg, peak {:.0f} steps/s, current {:.2f} A peak / {:.2f} A mean\n",
        x.name, x.max_tracking_error_mm, x.max_error_time_s, x.rms_tracking_error_mm,
        x.max_path_error_mm, x.rms_path_error_mm, x.max_endpoint_error_mm,
        x.rms_endpoint_error_mm, x.lost_steps, x.lost_full_steps,
        x.max_load_angle_deg, x.peak_step_rate_hz, x.peak_current_a, x.mean_current_a);
    if (r.controller != "open" && req.governor) {
      std::cout << fmt::format(
          "  {}: governor held {} periods; degraded to open loop on {} of {} moves; "
          "acceleration lead dropped on {}{}\n",
          x.name, x.governor_limited_periods, x.degraded_moves, x.moves, x.accel_lead_dropped_moves,
          r.controller == "encoder-sequenced"
              ? fmt::format("; {} commands reached, {} left", x.commands_reached, x.commands_left)
              : "");
    }
  }
  for (const std::string& n : r.notes) std::cout << "  note: " << n << "\n";
  if (!a.req.csv_path.empty()) std::cout << "  traces written to " << a.req.csv_path << "\n";
}

struct SweepArgs {
  MachineOptions machine;
  std::string csv, svg;
  bool no_load = false;
  bool json = false;
};

void run_sweep(const SweepArgs& a) {
  // The outputs checked before the work: never the machine file, never one file twice.
  const OutputOptions csv_oo{"--csv", {a.machine.spec}, {}};
  const OutputOptions svg_oo{"--svg", {a.machine.spec}, {}};
  if (!a.csv.empty() && !a.svg.empty()) require_distinct_outputs(a.csv, "--csv", a.svg, "--svg");
  if (!a.csv.empty()) check_output(a.csv, csv_oo);
  if (!a.svg.empty()) check_output(a.svg, svg_oo);
  const machine::Machine m = resolve_machine(a.machine);
  const auto rows = closedloop::stepper_sweep(m, !a.no_load);
  const std::string csv = closedloop::sweep_csv(rows);
  // Both outputs are built before either is written: a bad chart leaves no file behind.
  const std::string svg = a.svg.empty() ? "" : report::to_svg(report::stepper_sweep_chart(rows, !a.no_load));
  if (a.json) {
    std::cout << closedloop::sweep_json(rows).dump(2) << "\n";
  } else if (a.csv.empty()) {
    std::cout << csv;
  }
  auto write = [](const std::string& path, const std::string& text, const OutputOptions& oo) {
    write_output(path, text, oo);
  };
  if (!a.csv.empty()) {
    write(a.csv, csv, csv_oo);
    if (!a.json) std::cout << fmt::format("{} rows written to {}\n", rows.size(), a.csv);
  }
  if (!a.svg.empty()) {
    write(a.svg, svg, svg_oo);
    if (!a.json) std::cout << fmt::format("chart written to {}\n", a.svg);
  }
}

}  // namespace

void register_stepper(CLI::App& app) {
  CLI::App* st = app.add_subcommand("stepper", "Stepper physics, step loss and closed-loop control");
  st->require_subcommand(1);
  auto a = std::make_shared<StepperArgs>();
  CLI::App* sim = st->add_subcommand(
      "simulate", "Simulate motors, drives, AS5311 encoders and a controller on a file or scenario");
  sim->add_option("file", a->req.file, "G-code file (or use --scenario)");
  add_machine_options(*sim, a->machine);
  sim->add_option("--controller", a->req.controller,
                  "open, encoder-sequenced (the closed-loop stepper paper's law as published), "
                  "speed-tracking (that law against the time-based reference), pid, feedforward "
                  "(model feed-forward with current scaling); default open. Old names, accepted until the "
                  "next release: seed003 = speed-tracking, best = feedforward");
  sim->add_option("--scenario", a->req.scenario,
                  "reversing-strokes: the closed-loop stepper paper's X and Y strokes 0 -> -30 -> 0 mm "
                  "(old name, accepted until the next release: seed003)");
  sim->add_option("--speed-mm-s", a->req.speed_mm_s, "scenario speed [mm/s] (default 90)");
  sim->add_option("--drag-n", a->req.drag_force_n, "scenario load: drag force opposing motion [N]");
  sim->add_option("--end-load-n-per-mm", a->req.end_load_n_per_mm, "scenario load: stiffness of the cable pulled taut beyond -25 mm [N/mm]");
  sim->add_option("--bump-n", a->req.bump_force_n, "scenario load: drag of the curled edge scraped near -29 mm [N]");
  sim->add_option("--drag-n-s-per-m", a->req.drag_n_s_per_m, "scenario load: drag growing with speed [N s/m]");
  sim->add_option("--backlash-mm", a->req.backlash_mm, "scenario: lost motion at each reversal [mm] (default: the machine's, else 0.05)");
  sim->add_option("--run-current-a", a->req.run_current_a, "scenario: motor current, RMS as Klipper's run_current [A] (default: the machine's, else 0.8)");
  sim->add_option("--max-current-a", a->req.max_current_a, "scenario: peak phase current feedforward may boost to [A] (default and limit: the motor's rated current)");
  sim->add_flag("--no-load", a->no_load, "scenario without its drag load");
  sim->add_option("--csv", a->req.csv_path, "trace CSV (time, reference, position, error, command, encoder, load angle per axis)");
  sim->add_flag("--json", a->json, "print the result as JSON");
  sim->add_option("--kp", a->req.kp, "position gain of pid/feedforward [-]");
  sim->add_option("--ki", a->req.ki_per_s, "integral gain of pid/feedforward [1/s]");
  sim->add_option("--kd", a->req.kd_s, "derivative gain of pid/feedforward [s]");
  sim->add_option("--model-mass-scale", a->req.model_mass_scale, "feedforward: factor on the carriage mass its model believes (robustness; default 1)");
  sim->add_option("--model-stiffness-scale", a->req.model_stiffness_scale, "feedforward: factor on the belt stiffness its model believes (robustness; default 1)");
  sim->add_option("--drag-gain", a->req.drag_gain_per_s, "feedforward: adaptation gain of the learned drag [1/s] (default 20; 0 = off)");
  sim->add_option("--load-angle-deg", a->req.load_angle_deg, "feedforward: load angle the current is sized for [deg] (default 40; 0 = run current only)");
  sim->add_option("--alpha", a->req.alpha_per_s, "encoder-sequenced / speed-tracking: the paper's alpha [1/s] (default 0.6)");
  sim->add_option("--speed-change-mm-s", a->req.speed_change_mm_s, "encoder-sequenced / speed-tracking: the paper's D*, the largest change of the commanded speed per step event [mm/s] (default sqrt(2 max_accel s), s one microstep)");
  sim->add_option("--encoder-rate-hz", a->req.encoder_rate_hz, "encoder frame rate = control rate [Hz] (default 10000; a whole number of 20 us substeps, at most 50000)");
  sim->add_option("--encoder-resolution-um", a->req.encoder_resolution_um, "encoder count [um] (default the AS5311's 0.488; at most half a microstep)");
  sim->add_flag("--no-governor", a->no_governor, "let the controller's commands reach the motor unchecked (studies of the raw laws)");
  sim->add_option("--corrupt-probability", a->req.corrupt_probability, "probability that an encoder frame is corrupted on the wire");
  sim->callback([a] { run_simulate(*a); });

  auto s = std::make_shared<SweepArgs>();
  CLI::App* sw = st->add_subcommand("sweep", "The reversing-strokes scenario at 30..150 mm/s for every controller, as CSV");
  add_machine_options(*sw, s->machine);
  sw->add_option("--csv", s->csv, "write the table here (default: standard output)");
  sw->add_flag("--no-load", s->no_load, "without the scenario's drag load");
  sw->add_flag("--json", s->json, "print the rows as JSON (a list of {controller, speed_mm_s, x, y})");
  sw->add_option("--svg", s->svg, "also draw the maximum error against speed per controller, X and Y, as an SVG chart");
  sw->callback([s] { run_sweep(*s); });
}

}  // namespace amctl::cli
