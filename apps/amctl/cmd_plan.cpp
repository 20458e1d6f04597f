// `amctl plan FILE [-o moves.csv] [--json] [--t-begin/--t-end S] [--layer-begin/--layer-end N]`:
// the planned moves as CSV: PlanSource -> SelectStage (a range, when asked) -> MovesCsvSink.
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <vector>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/json.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/select_stage.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/plan/moves_csv.hpp"
#include "amctl/plan/report_json.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct PlanArgs {
  std::string file;
  MachineOptions machine;
  std::string output;
  bool json = false;
  bool lenient = false;
  std::optional<double> t_begin, t_end;
  std::optional<int> layer_begin, layer_end;
  std::string file_limits = "keep";
};

void run_plan(const PlanArgs& a) {
  if (a.json && (a.output.empty() || a.output == "-")) {
    throw Error("--json: prints a summary on standard output, expected the CSV file with -o/--output");
  }
  // A range bound is a time of the print, finite; an end before the beginning selects nothing.
  if (a.t_begin && !std::isfinite(*a.t_begin)) throw Error(fmt::format("--t-begin: must be a finite time [s], got {}", *a.t_begin));
  if (a.t_end && !std::isfinite(*a.t_end)) throw Error(fmt::format("--t-end: must be a finite time [s], got {}", *a.t_end));
  if (a.t_begin && a.t_end && *a.t_end < *a.t_begin) {
    throw Error(fmt::format("--t-end: must not be before --t-begin ({} s), got {}", *a.t_begin, *a.t_end));
  }
  if (a.layer_begin && a.layer_end && *a.layer_end < *a.layer_begin) {
    throw Error(fmt::format("--layer-end: must not be before --layer-begin ({}), got {}", *a.layer_begin, *a.layer_end));
  }
  const machine::Machine m = resolve_machine(a.machine);
  plan::SelectOptions sel;
  if (a.t_begin) sel.t_begin_s = *a.t_begin;
  if (a.t_end) sel.t_end_s = *a.t_end;
  if (a.layer_begin) sel.layer_begin = *a.layer_begin;
  if (a.layer_end) sel.layer_end = *a.layer_end;
  plan::SelectStage select(sel);
  std::vector<plan::Stage*> stages;
  if (a.t_begin || a.t_end || a.layer_begin || a.layer_end) stages.push_back(&select);
  plan::SourceOptions so;
  so.strict = !a.lenient;
  const std::string output = a.output.empty() ? "-" : a.output;
  plan::MovesFile csv(output, OutputOptions{"-o/--output", {a.file}, {}});
  so.planner.file_limits = file_limits_policy(a.file_limits);
  plan::PlanSource source(a.file, m, so);
  plan::Sink* sinks[] = {&csv};
  plan::run_pipeline(source, stages, sinks);
  csv.commit();
  if (output == "-") return;
  const std::uint64_t rows = csv.rows();
  const double total_s = source.summary().end_time_s;
  if (a.json) {
    Json features = Json::array();
    for (const auto& name : source.summary().feature_names) features.push_back(name);
    std::cout << Json{{"file", a.file}, {"machine", m.name}, {"output", a.output},
                      {"moves", rows}, {"total_time_s", total_s},
                      {"feature_names", features},
                      {"file_limits", plan::to_json(source.summary().diagnostics.file_limits)}}
                     .dump(2)
              << "\n";
    return;
  }
  std::cout << fmt::format("{}: {} moves written to {} (the whole print takes {:.3f} s)\n", a.file,
                           rows, a.output, total_s);
  for (const std::string& l : plan::describe_file_limits(source.summary().diagnostics.file_limits)) {
    std::cout << "  file limits: " << l << "\n";
  }
}

}  // namespace

void register_plan(CLI::App& app) {
  auto a = std::make_shared<PlanArgs>();
  CLI::App* sub = app.add_subcommand(
      "plan", "Write every planned move (times, speeds, phases) as CSV or .npy, one row per move");
  sub->add_option("file", a->file, "G-code file ('-' reads standard input)")->required();
  add_machine_options(*sub, a->machine);
  add_file_limits_option(*sub, a->file_limits);
  sub->add_option("-o,--output", a->output,
                  "CSV file, or a name ending in .npy for numpy's binary format (the same columns "
                  "as fields); written whole or not at all; default: CSV on standard output");
  sub->add_flag("--json", a->json, "Print a JSON summary (needs -o)");
  sub->add_option("--t-begin", a->t_begin, "only moves that end at or after this print time [s]");
  sub->add_option("--t-end", a->t_end, "only moves that start at or before this print time [s]");
  sub->add_option("--layer-begin", a->layer_begin, "only moves from this layer on");
  sub->add_option("--layer-end", a->layer_end, "only moves up to this layer");
  sub->add_flag("--lenient", a->lenient, "Skip malformed lines (counted) instead of stopping");
  sub->callback([a] { run_plan(*a); });
}

}  // namespace amctl::cli
