// The report's own sinks, per planned move: the speed level of detail and the toolpath
// decimation (the estimate and the plan are measured in plan_bench.cpp). Whole pages:
// docs/report.md, "Figures".
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/plan/stream.hpp"
#include "amctl/report/speed_lod.hpp"
#include "amctl/report/toolpath.hpp"

#include "synthetic.hpp"

namespace {

/// The plan of bench::synthetic_gcode, batch by batch.
std::vector<amctl::plan::PlanBatch> planned_batches(std::size_t moves) {
  const std::string g = amctl::bench::synthetic_gcode(moves);
  amctl::machine::Machine m;
  amctl::plan::PlanSource source(std::string_view(g), "bench", m);
  std::vector<amctl::plan::PlanBatch> out;
  amctl::plan::PlanBatch b;
  while (source.next(b)) out.push_back(b);
  return out;
}

template <class MakeSink>
void run_sink(benchmark::State& state, MakeSink make) {
  const auto batches = planned_batches(static_cast<std::size_t>(state.range(0)));
  std::size_t moves = 0;
  for (const auto& b : batches) moves += b.moves.size();
  for (auto _ : state) {
    auto sink = make();
    for (const auto& b : batches) sink.consume(b);
    sink.finish(amctl::plan::StreamSummary{});
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(moves) * state.iterations());
}

void BM_ReportSpeedLod(benchmark::State& state) {
  run_sink(state, [] { return amctl::report::SpeedLodSink(); });
}
BENCHMARK(BM_ReportSpeedLod)->Arg(1 << 18)->Unit(benchmark::kMillisecond);

void BM_ReportToolpath(benchmark::State& state) {
  run_sink(state, [] { return amctl::report::ToolpathSink(); });
}
BENCHMARK(BM_ReportToolpath)->Arg(1 << 18)->Unit(benchmark::kMillisecond);

}  // namespace
