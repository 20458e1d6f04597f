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

namespace {

/// Layers of circular perimeters of short chords joined by travels (as in plan_bench.cpp).
std::vector<amctl::plan::PlanBatch> planned_batches(std::size_t moves) {
  std::string g = "M83\nG1 F3000\n";
  std::size_t n = 0;
  for (int layer = 0; n < moves; ++layer) {
    g += fmt::format(";LAYER_CHANGE\n;Z:{:.2f}\nG1 Z{:.2f} F600\n;TYPE:Perimeter\n", 0.2 * (layer + 1),
                     0.2 * (layer + 1));
    for (int ring = 0; ring < 10 && n < moves; ++ring) {
      const double r = 5.0 + 2.0 * ring;
      g += fmt::format("G1 X{:.3f} Y100.000 F9000\nG1 F2700\n", 100.0 + r);
      for (int k = 1; k <= 120 && n < moves; ++k, ++n) {
        const double a = 2.0 * std::numbers::pi * k / 120.0;
        g += fmt::format("G1 X{:.3f} Y{:.3f} E{:.5f}\n", 100.0 + r * std::cos(a),
                         100.0 + r * std::sin(a), 0.0335 * r * 2.0 * std::numbers::pi / 120.0);
      }
    }
  }
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
