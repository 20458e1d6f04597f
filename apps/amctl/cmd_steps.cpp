// `amctl steps FILE --machine M --csv OUT.csv [--step-filter none|klipper] [--json]`: the exact
// step times of every stepper
// (docs/steppers.md): PlanSource -> steppers::StepSink -> steps CSV.
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
  const steppers::StepsReport r = steppers::generate_steps_file(a.file, m, a.csv, filter);
  if (a.json) {
    std::cout << steppers::to_json(r).dump(2) << "\n";
    return;
  }
  std::cout << fmt::format("amctl steps: {} ({} moves, {:.3f} s, machine {}, {})\n", r.file,
                           r.moves, r.print_time_s, r.machine_name, r.kinematics);
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
    std::cout << "\n";
  }
  if (!r.csv_path.empty()) {
    std::cout << fmt::format("  {} steps written to {}\n", r.total_steps(), r.csv_path);
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
                  "CSV file stepper,time_s,direction, one row per step (written whole or not at all)");
  sub->add_option("--step-filter", a->filter,
                  "none (amctl's exact steps, default) or klipper (drop a step and the step back "
                  "within 750 us, as Klipper's stepcompress does before the MCU)");
  sub->add_flag("--json", a->json, "Print steps per stepper and the peak step rates as JSON");
  sub->callback([a] { run_steps(*a); });
}

}  // namespace amctl::cli
