// `amctl plan FILE [-o moves.csv] [--json]`: every planned move as CSV (plan::MovesCsvSink),
// with the estimate computed in the same pass.
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/json.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/moves_csv.hpp"
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
};

void run_plan(const PlanArgs& a) {
  if (a.json && a.output.empty()) {
    throw Error("plan --json prints a summary: give the CSV file with -o/--output");
  }
  const machine::Machine m = resolve_machine(a.machine);
  plan::SourceOptions so;
  so.strict = !a.lenient;
  plan::PlanSource source(a.file, m, so);
  plan::EstimateSink estimate(m);
  std::uint64_t rows = 0;
  if (a.output.empty()) {
    plan::MovesCsvSink csv(std::cout);
    plan::Sink* sinks[] = {&csv, &estimate};
    plan::run_pipeline(source, sinks);
    return;
  }
  plan::MovesCsvFile csv(a.output);
  plan::Sink* sinks[] = {&csv, &estimate};
  plan::run_pipeline(source, sinks);
  csv.commit();
  rows = csv.rows();
  const plan::EstimateReport& r = estimate.report();
  if (a.json) {
    Json features = Json::array();
    for (const auto& name : source.summary().feature_names) features.push_back(name);
    std::cout << Json{{"file", a.file}, {"machine", m.name}, {"output", a.output},
                      {"moves", rows}, {"total_time_s", r.total_time_s},
                      {"feature_names", features}}
                     .dump(2)
              << "\n";
    return;
  }
  std::cout << fmt::format("{}: {} moves, {:.3f} s of print time -> {}\n", a.file, rows,
                           r.total_time_s, a.output);
}

}  // namespace

void register_plan(CLI::App& app) {
  auto a = std::make_shared<PlanArgs>();
  CLI::App* sub = app.add_subcommand(
      "plan", "Write every planned move (times, speeds, phases) as CSV, one row per move");
  sub->add_option("file", a->file, "G-code file ('-' reads standard input)")->required();
  add_machine_options(*sub, a->machine);
  sub->add_option("-o,--output", a->output,
                  "CSV file (written whole or not at all); default: standard output");
  sub->add_flag("--json", a->json, "Print a JSON summary (needs -o)");
  sub->add_flag("--lenient", a->lenient, "Skip malformed lines (counted) instead of stopping");
  sub->callback([a] { run_plan(*a); });
}

}  // namespace amctl::cli
