// Hot path of the input-shaped simulation (`amctl simulate --shaper ...`).
//   BM_ShapedSimulationTwoHourPrint/<shaper>  a synthetic 2-hour print (segments of 0.3..20 mm turning by
//                                   random angles, 150 mm/s, 5000 mm/s^2) simulated at 1 kHz
//                                   through a 40 Hz belt on X and Y with the shaper on both
//                                   axes at 40 Hz, moves pushed one by one with the contour,
//                                   residual and smoothing metrics (what simulate runs for the
//                                   shaped half of its report). Issue 9 target: < 3 s.
//   BM_UnshapedSimulationTwoHourPrint         the same print without a shaper through the same code
//                                   (one simulator at delay 0), for the cost per simulator.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "amctl/plan/velocity_profile.hpp"
#include "amctl/simulation/shaped_simulation.hpp"
#include "amctl/trajectory/build.hpp"

#include "synthetic.hpp"

namespace {

using namespace amctl;

// Deterministic synthetic print (seeded), 7200 s of motion.
const std::vector<plan::PlannedMove>& shaped_bench_print() {
  static const std::vector<plan::PlannedMove> moves = bench::synthetic_two_hour_print(20261122, {150, 150, 0.2, 0});
  return moves;
}

void run(benchmark::State& state, const std::optional<shaping::Shaper>& shaper) {
  const auto& moves = shaped_bench_print();
  const dynamics::AxisModel m = dynamics::AxisModel::belt(40.0, 0.1);
  dynamics::SimulationOptions o;
  o.sample_rate_hz = 1000.0;
  dynamics::MetricsOptions mo;
  mo.keep_per_move = false;
  for (auto _ : state) {
    simulation::ShapedStreamingSimulation s(m, m, o, mo, shaper, shaper);
    for (const auto& mv : moves) s.push(mv);
    const auto r = s.finish();
    benchmark::DoNotOptimize(r.max_contour_error_mm);
    state.counters["samples"] = static_cast<double>(s.stats().samples);
    state.counters["simulators"] = static_cast<double>(s.simulators());
    state.counters["window_moves"] = static_cast<double>(s.max_window_moves());
    state.counters["print_s"] = s.stats().motion_end_time_s;
    state.counters["smoothing_max_mm"] = s.smoothing().max_mm;
  }
  state.counters["moves"] = static_cast<double>(moves.size());
}

void BM_ShapedSimulationTwoHourPrint(benchmark::State& state, const char* type) {
  const auto shaper = shaping::make_shaper(type, 40.0, 0.1);
  run(state, shaper);
}
BENCHMARK_CAPTURE(BM_ShapedSimulationTwoHourPrint, zv, "zv")->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_ShapedSimulationTwoHourPrint, mzv, "mzv")->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_ShapedSimulationTwoHourPrint, ei, "ei")->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_ShapedSimulationTwoHourPrint, 3hump_ei, "3hump_ei")->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_UnshapedSimulationTwoHourPrint(benchmark::State& state) {
  run(state, std::nullopt);
}
BENCHMARK(BM_UnshapedSimulationTwoHourPrint)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
