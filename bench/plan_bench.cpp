// Throughput of the main job: parse + interpret + plan + report, in moves per second.
// Issue target: >= 5 M moves/s on one core, and faster than `gzip -1` on the same file
// (compare with: scripts/bench_estimate.sh).
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/stream.hpp"
#include "synthetic.hpp"

namespace {

using amctl::bench::synthetic_gcode;

// The timed loop of the estimate benchmarks: the whole job on text g, moves per second (and
// bytes per second when `bytes`).
void run_estimate(benchmark::State& state, const std::string& g, const amctl::machine::Machine& m,
                  bool bytes) {
  std::uint64_t moves = 0;
  for (auto _ : state) {
    auto r = amctl::plan::estimate_text(g, "bench", m);
    moves = r.moves;
    benchmark::DoNotOptimize(r.total_time_s);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(moves) * state.iterations());
  if (bytes) state.SetBytesProcessed(static_cast<std::int64_t>(g.size()) * state.iterations());
}

void BM_EstimateKlipper(benchmark::State& state) {
  const std::string g = synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  amctl::machine::Machine m;  // Klipper, square_corner_velocity junctions
  run_estimate(state, g, m, true);
}
BENCHMARK(BM_EstimateKlipper)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

/// The same job on a printer.cfg with [gcode_macro] sections the file never calls: every
/// command that is not a plain move is offered to the macro expander (one name lookup), plain
/// moves keep the fast path. Must stay within noise of BM_EstimateKlipper (docs/macros.md).
void BM_EstimateKlipperWithMacros(benchmark::State& state) {
  const std::string g = synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  amctl::machine::Machine m;
  for (const char* name : {"PRINT_START", "PRINT_END", "M109", "_PURGE_LINE"}) {
    amctl::ConfigSection s;
    s.name = std::string("gcode_macro ") + name;
    s.options["gcode"] = amctl::ConfigValue{"G4 P{params.P|default(0)}", {}, {1}};
    m.klipper_config.push_back(s);
  }
  run_estimate(state, g, m, true);
}
BENCHMARK(BM_EstimateKlipperWithMacros)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

void BM_EstimateMarlinJunctionDeviation(benchmark::State& state) {
  const std::string g = synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  amctl::machine::Machine m;
  m.firmware = amctl::machine::Firmware::marlin;
  m.junction = amctl::machine::JunctionPolicy::junction_deviation;
  run_estimate(state, g, m, false);
}
BENCHMARK(BM_EstimateMarlinJunctionDeviation)->Arg(1 << 18)->Unit(benchmark::kMillisecond);

/// The same Klipper job with jerk-limited (scurve7) ramps: the look-ahead solves the S-curve's
/// reachable speeds (Cardano / quadratic) and cruise peaks (Newton) instead of v^2 arithmetic.
void BM_EstimateKlipperSCurve(benchmark::State& state) {
  const std::string g = synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  amctl::machine::Machine m;
  m.profile = amctl::machine::VelocityProfile::scurve7;
  m.max_jerk_mm_s3 = 1.0e6;
  run_estimate(state, g, m, true);
}
BENCHMARK(BM_EstimateKlipperSCurve)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

/// Parsing and interpreting alone (no planning).
void BM_InterpretOnly(benchmark::State& state) {
  const std::string g = synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  struct Count : amctl::gcode::EventSink {
    std::uint64_t n = 0;
    void on_move(const amctl::gcode::MoveRequest&) override { ++n; }
  };
  std::uint64_t moves = 0;
  for (auto _ : state) {
    Count c;
    amctl::gcode::Interpreter in({}, "bench");
    amctl::gcode::LineReader reader(g, "bench");
    in.run(reader, c);
    moves = c.n;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(moves) * state.iterations());
  state.SetBytesProcessed(static_cast<std::int64_t>(g.size()) * state.iterations());
}
BENCHMARK(BM_InterpretOnly)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

/// The plan stream alone: batches pulled from a PlanSource, nothing consumed. The difference
/// to BM_EstimateKlipper is the estimate sink; to BM_InterpretOnly, the planner and batching.
void BM_PlanSourcePull(benchmark::State& state) {
  const std::string g = synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  amctl::machine::Machine m;
  std::uint64_t moves = 0;
  for (auto _ : state) {
    amctl::plan::PlanSource source(g, "bench", m);
    amctl::plan::PlanBatch batch;
    moves = 0;
    while (source.next(batch)) moves += batch.moves.size();
    benchmark::DoNotOptimize(moves);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(moves) * state.iterations());
}
BENCHMARK(BM_PlanSourcePull)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

}  // namespace
