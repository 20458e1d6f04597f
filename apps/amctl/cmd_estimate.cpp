// `amctl estimate`: the main job. G-code in, firmware-grade print time out.
#include <chrono>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>
#include <iomanip>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/input.hpp"
#include "amctl/core/output.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/report_json.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

std::string hms(double s) {
  if (!std::isfinite(s)) return "-";
  if (std::fabs(s) >= 1e12) return fmt::format("{:.4g} s", s);  // beyond any print: no h/m split
  const auto total = static_cast<long long>(std::llround(s));
  const long long h = total / 3600, m = (total % 3600) / 60, sec = total % 60;
  if (h > 0) return fmt::format("{}h {:02}m {:02}s", h, m, sec);
  if (m > 0) return fmt::format("{}m {:02}s", m, sec);
  return fmt::format("{:.2f}s", s);
}

struct EstimateArgs {
  std::vector<std::string> files;  ///< as given (files, directories, "-")
  std::string file;                ///< the one file of a single-file run
  MachineOptions machine;
  bool json = false;
  bool lenient = false;
  bool all_layers = false;
  bool brief = false;
  std::string m73_out;
  double m73_interval_s = 60.0;
  std::string mode = "planner";  ///< or "empirical" (seed 004 estimator, cmd_process.cpp)
  std::string params;            ///< empirical parameters (JSON)
  bool compare_profiles = false; ///< trapezoid, bezier5 and scurve7 side by side
  std::string file_limits = "keep";  ///< keep | ignore | cap
};

void print_human(const plan::EstimateReport& r, const machine::Machine& m, double compute_s,
                 bool all_layers) {
  auto& o = std::cout;
  o << fmt::format("amctl estimate: {}\n", r.file);
  o << fmt::format("  machine          {} ({}, {}, junction: {})\n", m.name,
                   machine::to_string(m.firmware), kinematics::name_of(m.kinematics),
                   machine::to_string(m.junction));
  o << fmt::format("  print time       {:>12}  ({:.1f} s: motion {:.1f} s + dwells {:.1f} s)\n",
                   hms(r.total_time_s), r.total_time_s, r.motion_time_s, r.dwell_time_s);
  if (r.slicer_estimate_s) {
    const double d = (*r.slicer_estimate_s - r.total_time_s) / r.total_time_s * 100.0;
    o << fmt::format("  slicer's own     {:>12}  ({}; {:+.1f} % against amctl)\n",
                     hms(*r.slicer_estimate_s), r.slicer_name.empty() ? "slicer" : r.slicer_name, d);
  }
  o << fmt::format("  extruding        {:>12}  over {:.1f} m of path\n", hms(r.extrude_time_s),
                   r.extrude_path_mm / 1000.0);
  o << fmt::format("  travel           {:>12}  over {:.1f} m\n", hms(r.travel_time_s), r.travel_mm / 1000.0);
  o << fmt::format("  retract/prime    {:>12}\n", hms(r.extrude_only_time_s));
  o << fmt::format("  filament         {:.2f} m, {:.2f} cm^3\n", r.filament_mm / 1000.0,
                   r.filament_volume_mm3 / 1000.0);
  o << fmt::format("  moves            {} from {} lines; top speed {:.0f} mm/s; {} full stops\n",
                   r.moves, r.lines, r.max_speed_mm_s, r.diagnostics.full_stops);
  if (!r.heater_waits.empty()) {
    o << "  heater waits (not in the print time):\n";
    for (const auto& e : r.heater_waits) {
      o << fmt::format("    at {:>10}  {}  (line {})\n", hms(e.at_s), e.what, e.line);
    }
  }
  if (r.range_error) o << "  warning: " << plan::describe_range_error(*r.range_error) << "\n";
  const std::vector<std::string> limits = plan::describe_file_limits(r.diagnostics.file_limits);
  for (std::size_t i = 0; i < limits.size(); ++i) {
    o << (i == 0 ? "  file limits      " : "                   ") << limits[i] << "\n";
  }
  if (!r.excluded_objects.empty()) {
    std::string names;
    for (const auto& x : r.excluded_objects) names += (names.empty() ? "" : ", ") + x.name;
    o << fmt::format("  excluded objects: {} ({} moves not made{})\n", names, r.excluded_moves,
                     r.exclusion_time_saved_s
                         ? fmt::format(", {:.1f} s saved", *r.exclusion_time_saved_s)
                         : std::string());
  }
  if (r.diagnostics.clamped_moves > 0) {
    o << fmt::format("  clamped moves    {} (Marlin soft endstops)\n", r.diagnostics.clamped_moves);
  }
  if (!r.pauses.empty()) {
    o << "  pauses (not in the print time):\n";
    for (std::size_t i = 0; i < r.pauses.size() && i < 10; ++i) {
      o << fmt::format("    at {:>10}  {}  (line {})\n", hms(r.pauses[i].at_s), r.pauses[i].what,
                       r.pauses[i].line);
    }
    if (r.pauses.size() > 10) o << fmt::format("    ... {} more\n", r.pauses.size() - 10);
  }
  if (!r.untimed.empty()) {
    o << "  untimed commands (real duration unknown, not in the print time):\n";
    for (std::size_t i = 0; i < r.untimed.size() && i < 10; ++i) {
      o << fmt::format("    at {:>10}  {}  (line {})\n", hms(r.untimed[i].at_s), r.untimed[i].what,
                       r.untimed[i].line);
    }
  }
  if (!r.features.empty()) {
    o << "  by feature:\n";
    for (const auto& f : r.features) {
      o << fmt::format("    {:<28} {:>12} {:5.1f} %  {:8.2f} m filament\n", f.name, hms(f.time_s),
                       r.total_time_s > 0 ? 100.0 * f.time_s / r.total_time_s : 0.0,
                       f.filament_mm / 1000.0);
    }
  }
  if (!r.layers.empty()) {
    double lo = 1e300, hi = 0;
    std::size_t ilo = 0, ihi = 0;
    for (std::size_t i = 0; i < r.layers.size(); ++i) {
      if (r.layers[i].time_s < lo) { lo = r.layers[i].time_s; ilo = i; }
      if (r.layers[i].time_s > hi) { hi = r.layers[i].time_s; ihi = i; }
    }
    o << fmt::format("  layers           {}: fastest #{} {:.1f} s, slowest #{} {:.1f} s, mean {:.1f} s\n",
                     r.layers.size(), r.layers[ilo].layer, lo, r.layers[ihi].layer, hi,
                     r.total_time_s / static_cast<double>(r.layers.size()));
    if (all_layers) {
      for (const auto& l : r.layers) {
        o << fmt::format("    layer {:4}  z {:7.3f} mm  starts {:>10}  takes {:8.2f} s  (line {})\n",
                         l.layer, l.z_mm, hms(l.start_s), l.time_s, l.first_line);
      }
    }
  }
  for (const auto& m : r.macros) {
    if (m.skipped == 0) {
      o << fmt::format("  macro            {} (line {}, {}x): expanded, its moves are timed\n", m.name,
                       m.first_line, m.calls);
    } else {
      o << fmt::format("  macro            {} (line {}, {}x): {} expanded, {} skipped (line {}: {})\n",
                       m.name, m.first_line, m.calls, m.expanded, m.skipped, m.first_skipped_line,
                       m.skip_reason);
    }
  }
  for (const auto& u : r.unknown_commands) {
    o << fmt::format("  unknown command  {} (line {}, {}x): {}\n", u.name, u.first_line, u.count,
                     plan::explain_unknown_command(u.name));
  }
  for (const auto& w : r.diagnostics.warnings) o << "  warning: " << w << "\n";
  o << fmt::format("  computed in {:.3f} s ({:.1f} M moves/s)\n", compute_s,
                   compute_s > 0 ? static_cast<double>(r.moves) / compute_s / 1e6 : 0.0);
}

void run_compare_profiles(const EstimateArgs& a) {
  const machine::Machine m = resolve_machine(a.machine);
  const std::vector<plan::ProfileRun> runs = plan::compare_profiles(a.file, m, !a.lenient);
  if (a.json) {
    std::cout << plan::to_json(runs, a.file, m).dump(2) << "\n";
    return;
  }
  const double base = runs.front().total_time_s;
  auto& o = std::cout;
  o << fmt::format("amctl estimate --compare-profiles: {}\n", a.file);
  o << fmt::format("  machine {} ({}), max_jerk {:g} mm/s^3\n", m.name, machine::to_string(m.firmware),
                   m.max_jerk_mm_s3);
  o << fmt::format("  {:<10} {:>12} {:>12} {:>9} {:>18} {:>18}\n", "profile", "print time", "seconds",
                   "vs trap", "peak accel mm/s^2", "peak jerk mm/s^3");
  for (const auto& r : runs) {
    o << fmt::format("  {:<10} {:>12} {:>12.3f} {:>8.3f}x {:>18.0f} {:>18}\n",
                     machine::to_string(r.profile), hms(r.total_time_s), r.total_time_s,
                     base > 0 ? r.total_time_s / base : 0.0, r.peak_accel_mm_s2,
                     std::isfinite(r.peak_jerk_mm_s3) ? fmt::format("{:.4g}", r.peak_jerk_mm_s3)
                                                      : std::string("step (unbounded)"));
  }
  o << "  (peaks over the toolhead's ramps; extrude-only moves left out)\n";
}

void run_estimate(const EstimateArgs& a) {
  if (a.compare_profiles) {
    run_compare_profiles(a);
    return;
  }
  const machine::Machine m = resolve_machine(a.machine);
  plan::EstimateOptions opt;
  opt.strict = !a.lenient;
  opt.planner.file_limits = file_limits_policy(a.file_limits);
  if (!a.m73_out.empty()) {
    require_positive_flag("--m73-interval", a.m73_interval_s);
    opt.checkpoint_interval_s = a.m73_interval_s;
  }
  // --write-m73 reads the file twice: one rewindable input (standard input and a FIFO are
  // read once, the second pass reads the reader's own copy; a plate named inside a 3MF is
  // opened again from the archive), and the output checked first.
  std::optional<plan::RewindableGcode> input;
  if (!a.m73_out.empty()) {
    if (a.m73_out == "-" && (a.json || a.brief)) {
      throw Error("--write-m73: standard output would hold the G-code and the report, expected a file");
    }
    input.emplace(plan::GcodeInput(a.file));
    OutputOptions oo{"--write-m73", {a.file}, {}};
    const plan::GcodeInput in = *input;
    if (in.file() != nullptr && in.file()->identity()) oo.input_ids.push_back(*in.file()->identity());
    check_output(a.m73_out, oo);
  }
  const auto t0 = std::chrono::steady_clock::now();
  const plan::EstimateReport r =
      input ? plan::estimate_file(*input, m, opt) : plan::estimate_file(a.file, m, opt);
  const double compute_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (r.ended_without_newline) {
    std::cerr << fmt::format("amctl: warning: {}:{}: the file does not end with a newline; it may be truncated\n",
                             r.file, r.lines);
  }
  if (r.moves == 0) {
    std::cerr << fmt::format("amctl: warning: {}: no moves (an empty file, or only comments and "
                             "settings): nothing to time\n",
                             r.file);
  }
  if (r.skipped_lines > 0) {
    std::cerr << fmt::format("amctl: warning: {}: {} malformed lines skipped (--lenient)\n", r.file, r.skipped_lines);
  }
  std::size_t m73 = 0;
  if (!a.m73_out.empty()) m73 = plan::write_m73(*input, a.m73_out, r);
  if (a.m73_out == "-") return;  // standard output holds the G-code
  if (a.brief) {
    std::cout << fmt::format("{:<18} {:>10}  ({:.1f} s)", m.name, hms(r.total_time_s), r.total_time_s);
    if (r.slicer_estimate_s) {
      std::cout << fmt::format("  slicer {:+.1f} %",
                               (*r.slicer_estimate_s - r.total_time_s) / r.total_time_s * 100.0);
    }
    const plan::FileLimitsReport& fl = r.diagnostics.file_limits;
    if (fl.commands > 0) {
      std::string what;
      for (const auto& c : fl.by_command) {
        if (c.firmware_acts) what += fmt::format("{}{} {}", what.empty() ? "" : ", ", c.lines, c.command);
      }
      const char* verb = fl.policy == plan::FileLimits::keep     ? "kept"
                         : fl.policy == plan::FileLimits::ignore ? "ignored"
                                                                 : "capped";
      std::cout << fmt::format("  file limits {} ({})", verb, what);
    }
    std::cout << "\n";
  } else if (a.json) {
    auto j = plan::to_json(r, m, compute_s);
    if (!a.m73_out.empty()) j["m73_written"] = {{"file", a.m73_out}, {"lines", m73}};
    std::cout << std::setw(2) << j << "\n";  // streamed: no second copy as one string
  } else {
    print_human(r, m, compute_s, a.all_layers);
    if (!a.m73_out.empty()) std::cout << fmt::format("  wrote {} with {} M73 lines\n", a.m73_out, m73);
  }
}

/// Several files (or a directory, or a 3MF of several plates): one row each, the fleet's
/// table; a file that fails is a row with its error, and the exit code is then 2.
void run_estimate_many(const EstimateArgs& a, const std::vector<std::string>& files) {
  auto one_file_only = [](const char* flag) {
    throw Error(SourceLocation{flag, 0, 0},
                "found several G-code files, expected one with this flag (run them one by one)");
  };
  if (!a.m73_out.empty()) one_file_only("--write-m73");
  if (a.compare_profiles) one_file_only("--compare-profiles");
  if (a.mode != "planner") one_file_only("--mode");
  if (a.all_layers) one_file_only("--layers");
  const machine::Machine m = resolve_machine(a.machine);
  plan::EstimateOptions opt;
  opt.strict = !a.lenient;
  opt.planner.file_limits = file_limits_policy(a.file_limits);
  const std::vector<plan::EstimateRow> rows = plan::estimate_files(files, m, opt);
  std::size_t failed = 0;
  for (const auto& r : rows) failed += r.report ? 0 : 1;
  if (a.json) {
    std::cout << std::setw(2) << plan::to_json(rows, m) << "\n";
  } else {
    std::size_t name_w = 4;
    for (const auto& r : rows) name_w = std::max(name_w, r.file.size());
    auto& o = std::cout;
    o << fmt::format("amctl estimate: {} files on {} ({}, {})\n", rows.size(), m.name,
                     machine::to_string(m.firmware), kinematics::name_of(m.kinematics));
    o << fmt::format("  {:<{}}  {:>12}  {:>10}  {:>9}  {}\n", "file", name_w, "print time", "seconds",
                     "moves", "slicer's own");
    double total = 0.0;
    for (const auto& r : rows) {
      if (!r.report) {
        o << fmt::format("  {:<{}}  error: {}\n", r.file, name_w, r.error);
        continue;
      }
      const plan::EstimateReport& e = *r.report;
      total += e.total_time_s;
      std::string slicer;
      if (e.slicer_estimate_s && e.total_time_s > 0) {
        slicer = fmt::format("{:+.1f} %", (*e.slicer_estimate_s - e.total_time_s) / e.total_time_s * 100.0);
      }
      o << fmt::format("  {:<{}}  {:>12}  {:>10.1f}  {:>9}  {}\n", r.file, name_w,
                       r.no_moves() ? "no moves" : hms(e.total_time_s), e.total_time_s, e.moves, slicer);
    }
    o << fmt::format("  {:<{}}  {:>12}  {:>10.1f}\n", "total", name_w, hms(total), total);
  }
  if (failed > 0) {
    throw Error(fmt::format("{} of {} files failed (their rows say why)", failed, rows.size()));
  }
}

}  // namespace

void register_estimate(CLI::App& app) {
  auto args = std::make_shared<EstimateArgs>();
  CLI::App* sub = app.add_subcommand(
      "estimate", "Plan every move as the firmware does and report the print time");
  sub->add_option("file", args->files,
                  "G-code file: text, binary G-code (.bgcode), a sliced 3MF (.gcode.3mf) or .gz, "
                  "told by content ('-' reads standard input). Several files, a directory or a "
                  "3MF of several plates: one row each")
      ->required();
  add_machine_options(*sub, args->machine);
  add_file_limits_option(*sub, args->file_limits);
  sub->add_flag("--json", args->json, "Print one JSON object on stdout");
  sub->add_flag("--lenient", args->lenient, "Skip malformed lines (counted) instead of stopping");
  sub->add_flag("--layers", args->all_layers, "List every layer's start and duration");
  sub->add_flag("--brief", args->brief, "One line: machine, print time, slicer's difference");
  sub->add_option("--write-m73", args->m73_out,
                  "Write the file back with M73 progress/remaining-time lines to this path");
  sub->add_option("--m73-interval", args->m73_interval_s, "Seconds of print time between M73 lines")
      ->default_val(60.0);
  sub->add_option("--mode", args->mode,
                  "planner (default) or empirical: the average-speed model of the UTFPR process-planning "
                  "study (FDM 2000 speeds unless --params)")
      ->check(CLI::IsMember({"planner", "empirical"}));
  sub->add_flag("--compare-profiles", args->compare_profiles,
                "Plan the file with trapezoid, bezier5 and scurve7 (jerk: printer.max_jerk) and print "
                "print time, peak acceleration and peak jerk side by side");
  sub->add_option("--params", args->params,
                  "Empirical parameters (JSON from `calibrate-time --mode empirical --save`); "
                  "default: the study's Stratasys FDM 2000 speeds, uncalibrated for your printer");
  sub->callback([args] {
    const std::vector<std::string> files = formats::expand_gcode_inputs(args->files);
    std::error_code ec;
    const bool several = files.size() != 1 || args->files.size() != 1 ||
                         std::filesystem::is_directory(args->files.front(), ec);
    if (several) {
      run_estimate_many(*args, files);
      return;
    }
    args->file = files.front();
    if (args->mode == "empirical") {
      run_empirical_estimate(args->file, args->params, args->json);
      return;
    }
    run_estimate(*args);
  });
}

}  // namespace amctl::cli
