// `amctl report FILE --machine M [-o report.html] [--natural-frequency-hz F --damping-ratio Z]
//  [--json]`: one self-contained HTML page about a print (report::write_report, docs/report.md).
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/report/html_report.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct ReportArgs {
  std::string file;
  MachineOptions machine;
  std::string output = "report.html";
  std::optional<double> f_hz, zeta;
  std::string accel;
  std::string accel_axis = "x";
  std::string thermal;
  double rate_hz = 1000.0;
  bool json = false;
  bool lenient = false;
  bool no_shaper = false;
  std::string file_limits = "keep";
};

void run_report(const ReportArgs& a) {
  const machine::Machine m = resolve_machine(a.machine);
  report::ReportOptions o;
  o.strict = !a.lenient;
  require_range_flag("--sample-rate-hz", kSampleRateRange, a.rate_hz);
  o.file_limits = file_limits_policy(a.file_limits);
  o.sample_rate_hz = a.rate_hz;
  if (a.zeta && !a.f_hz) throw Error("--damping-ratio needs --natural-frequency-hz");
  if (a.f_hz) require_range_flag("--natural-frequency-hz", kFrequencyRange, *a.f_hz);
  if (a.zeta && !(*a.zeta >= 0.0 && *a.zeta < 1.0)) {
    throw Error(fmt::format("--damping-ratio: must be in [0, 1), got {}", *a.zeta));
  }
  if (a.f_hz) o.belt = report::BeltModelOptions{*a.f_hz, a.zeta.value_or(0.1)};
  o.machine_shaper = !a.no_shaper;
  o.accel_path = a.accel;
  o.thermal = a.thermal;
  if (a.accel_axis != "x" && a.accel_axis != "y") {
    throw Error(fmt::format("--accel-axis: must be x or y, got '{}'", a.accel_axis));
  }
  o.accel_axis = a.accel_axis[0];
  const report::ReportResult r = report::write_report(a.file, m, a.output, o);
  if (a.json) {
    std::cout << report::to_json(r).dump(2) << "\n";
    return;
  }
  std::cout << fmt::format("{}: report written to {} ({} bytes, {} moves, {} layers)\n", a.file,
                           r.output, r.bytes, r.moves, r.layers);
}

}  // namespace

void register_report(CLI::App& app) {
  auto a = std::make_shared<ReportArgs>();
  CLI::App* sub = app.add_subcommand(
      "report", "Write one self-contained HTML page about a print: time, speed, layers, toolpath");
  sub->add_option("file", a->file, "G-code file ('-' reads standard input)")->required();
  add_machine_options(*sub, a->machine);
  add_file_limits_option(*sub, a->file_limits);
  sub->add_option("-o,--output", a->output, "HTML file (written whole or not at all; default report.html)");
  sub->add_option("--natural-frequency-hz", a->f_hz,
                  "belt natural frequency of X and Y [Hz]: simulate and colour the toolpath by contour error");
  sub->add_option("--damping-ratio", a->zeta, "belt damping ratio of X and Y (default 0.1)");
  sub->add_option("--sample-rate-hz", a->rate_hz, "simulation rate [Hz] (default 1000)");
  sub->add_flag("--no-shaper", a->no_shaper,
                "simulate without the machine's input shaper ([input_shaper], M593), which is applied "
                "by default");
  sub->add_option("--accel", a->accel,
                  "accelerometer record (Klipper raw or PSD CSV): adds the PSD, Klipper's shaper fit "
                  "and the shaper curves (docs/resonance.md)");
  sub->add_option("--accel-axis", a->accel_axis, "the axis the record excited: x or y (default x)");
  sub->add_option("--thermal", a->thermal,
                  "hotend or bed: add the heater loop (autotune, PID, MPC: temperature, set point, "
                  "effort; docs/thermal.md)")
      ->check(CLI::IsMember({"hotend", "bed"}));
  sub->add_flag("--json", a->json, "Print a JSON summary (file, output, bytes, moves, layers)");
  sub->add_flag("--lenient", a->lenient, "Skip malformed lines (counted) instead of stopping");
  sub->callback([a] { run_report(*a); });
}

}  // namespace amctl::cli
