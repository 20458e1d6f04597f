// `amctl steps FILE --machine M --csv OUT.csv [--step-filter none|klipper] [--json]`: the exact
// step times of every stepper
// (docs/steppers.md): PlanSource -> steppers::StepSink -> steps CSV.
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "amctl/steppers/steps.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct StepsArgs {
  std::string file;
  MachineOptions machine;
  std::string csv;
  std::string filter = "none";
  bool json = false;
};

void run_steps(const StepsArgs& a) {
  const machine::Machine m = resolve_machine(a.machine);
  const steppers::StepFilter filter = steppers::step_filter_from_string(a.filter, "--step-filter");
  const steppers::StepsReport r = steppers::generate_steps_file(
      a.file, m, a.csv, filter, [&](std::uint64_t bytes, double time_s) {
        std::cerr << fmt::format(
            "amctl steps: warning: the steps CSV '{}' passed {:.1f} GB at print time {:.1f} s "
            "and grows with the print (about {:.0f} bytes a step); stop with Ctrl-C to keep "
            "nothing, or run without --csv for the figures alone\n",
            a.csv, static_cast<double>(bytes) / 1e9, time_s,
            steppers::kStepsCsvRowBytesBesidesName + 10.0);
      });
  if (a.json) {
    std::cout << steppers::to_json(r).dump(2) << "\n";
    return;
  }
  std::cout << fmt::format("amctl steps: {} ({} moves, {:.3f} s, machine {}, {})\n", r.file,
                           r.moves, r.print_time_s, r.machine_name, r.kinematics);
  // What shaped the steps, only when something did (docs/steppers.md section 8).
  const machine::InputShaper& is = r.input_shaper;
  if (is.active() || r.pressure_advance_s > 0.0) {
    std::string line = "  steps of the shaped motion:";
    const auto axis = [&](const char* name, const std::string& type, double f, double zeta) {
      if (f > 0.0) line += fmt::format(" {} {} {:g} Hz (damping ratio {:g}),", name, type, f, zeta);
    };
    axis("X", is.shaper_type_x, is.shaper_freq_x_hz, is.damping_ratio_x);
    axis("Y", is.shaper_type_y, is.shaper_freq_y_hz, is.damping_ratio_y);
    axis("Z", is.shaper_type_z, is.shaper_freq_z_hz, is.damping_ratio_z);
    if (r.pressure_advance_s > 0.0) {
      line += fmt::format(" extruder with pressure advance {:g} s (smooth time {:g} s),",
                          r.pressure_advance_s, r.pressure_advance_smooth_time_s);
    }
    line.back() = '\n';
    std::cout << line;
  }
  for (std::size_t i = 0; i < r.motors.size(); ++i) {
    const steppers::StepperStats& s = r.stats[i];
    std::cout << fmt::format("  {:<12} {:>12} steps  step {:.6g} {}", r.motors[i].name, s.steps,
                             r.motors[i].step_distance.value,
                             kinematics::to_string(r.motors[i].step_distance.unit));
    if (r.step_filter == steppers::StepFilter::klipper) {
      std::cout << fmt::format("  ({} pairs filtered)", r.filtered_pairs[i]);
    }
    if (s.steps >= 2) {
      std::cout << fmt::format("  peak {:.0f} steps/s at {:.6f} s", s.peak_step_rate_steps_s(),
                               s.peak_time_s);
    }
    if (i < r.rates.size() && std::isfinite(r.rates[i].filtered_min_interval_s)) {
      const steppers::StepRateFigures& f = r.rates[i];
      std::cout << fmt::format(", {:.0f} without step-and-back pairs, sustained {:.0f} over {:g} ms",
                               f.filtered_peak_step_rate_steps_s(),
                               f.sustained_step_rate_steps_s, r.sustained_window_s * 1e3);
    }
    std::cout << "\n";
  }
  if (!r.csv_path.empty()) {
    std::cout << fmt::format("  {} steps written to {} ({:.1f} MB)\n", r.total_steps(),
                             r.csv_path, static_cast<double>(r.csv_bytes) / 1e6);
  } else {
    double bytes = 25.0;  // the header
    for (std::size_t i = 0; i < r.motors.size(); ++i) {
      bytes += static_cast<double>(r.stats[i].steps) *
               (static_cast<double>(r.motors[i].name.size()) +
                steppers::kStepsCsvRowBytesBesidesName);
    }
    std::cout << fmt::format("  a --csv of these steps would take about {:.0f} MB\n", bytes / 1e6);
  }
}

}  // namespace

void register_steps(CLI::App& app) {
  auto a = std::make_shared<StepsArgs>();
  CLI::App* sub = app.add_subcommand(
      "steps", "Exact step times of every stepper (Klipper's half-step convention) as CSV");
  sub->add_option("file", a->file, "G-code file ('-' reads standard input)")->required();
  add_machine_options(*sub, a->machine);
  sub->add_option("--csv", a->csv,
                  "steps file: CSV stepper,time_s,direction, one row per step, about 30 bytes a "
                  "step; a name ending in .npy writes numpy's binary format instead (fields "
                  "stepper, time_s, direction; numpy.load reads it); written whole or not at all; "
                  "run without it first to see the size");
  sub->add_option("--step-filter", a->filter,
                  "none (amctl's exact steps, default) or klipper (drop a step and the step back "
                  "within 750 us, as Klipper's stepcompress does before the MCU)");
  sub->add_flag("--json", a->json, "Print steps per stepper and the peak, filtered peak and sustained step rates as JSON");
  sub->callback([a] { run_steps(*a); });
}

}  // namespace amctl::cli
