// Hot paths of input shaping.
//   BM_MakeShaper           one shaper from its type (mzv: a 3x3 or 5x5 least-squares solve)
//   BM_MaxAccel             Klipper's max-accel bisection (about 60 smoothing evaluations)
//   BM_ShapedTwoHourPrint   a synthetic 2-hour print (10 mm segments at 150 mm/s, 5000 mm/s^2,
//                           5 mm/s at the corners) shaped with MZV on X and Y and evaluated
//                           exactly at 1 kHz; counters give samples per second and the wall
//                           time of the whole print.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <vector>

#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"
#include "amctl/trajectory/build.hpp"

namespace {

using namespace amctl;

const std::vector<plan::PlannedMove>& two_hour_print() {
  static const std::vector<plan::PlannedMove> moves = [] {
    // A square spiral of 10 mm segments: straight runs of 8 segments, then a right angle.
    std::vector<trajectory::MoveSpec> specs;
    std::array<double, 4> at{100, 100, 0.2, 0};
    const double dx[4] = {1, 0, -1, 0};
    const double dy[4] = {0, 1, 0, -1};
    int heading = 0;
    for (std::size_t i = 0; i < 103000; ++i) {
      at[0] += 10.0 * dx[heading];
      at[1] += 10.0 * dy[heading];
      at[3] += 0.3;
      const bool corner = i % 8 == 7;
      specs.push_back({at, 150.0, corner ? 5.0 : 150.0, i + 1, 0, 0});
      if (corner) heading = (heading + 1) % 4;
    }
    specs.back().end_v_mm_s = 0.0;
    return trajectory::chain_moves({100, 100, 0.2, 0}, specs, 5000.0,
                                   plan::VelocityProfile::trapezoid);
  }();
  return moves;
}

void BM_MakeShaper(benchmark::State& state) {
  const char* type = state.range(0) == 0 ? "mzv" : "mzv(n=5, t=1.0)";
  for (auto _ : state) benchmark::DoNotOptimize(shaping::make_shaper(type, 48.7, 0.1));
}
BENCHMARK(BM_MakeShaper)->Arg(0)->Arg(1);

void BM_MaxAccel(benchmark::State& state) {
  const shaping::Shaper s = shaping::make_shaper("3hump_ei", 48.7, 0.1);
  for (auto _ : state) benchmark::DoNotOptimize(shaping::max_accel_mm_s2(s, 5.0));
}
BENCHMARK(BM_MaxAccel);

void BM_ShapedTwoHourPrint(benchmark::State& state) {
  const auto& moves = two_hour_print();
  shaping::AxisShapers shapers;
  shapers.xyz[0] = shaping::make_shaper("mzv", 48.7, 0.1);
  shapers.xyz[1] = shaping::make_shaper("mzv", 41.3, 0.1);
  const double t_end = moves.back().end_time_s();
  const auto samples = static_cast<std::size_t>(t_end * 1000.0);
  for (auto _ : state) {
    shaping::ShapedCursor c(moves, shapers);
    double sum = 0.0;
    for (std::size_t k = 0; k < samples; ++k) sum += c.evaluate(static_cast<double>(k) * 1e-3).pos_mm[0];
    benchmark::DoNotOptimize(sum);
  }
  state.counters["samples_per_s"] = benchmark::Counter(
      static_cast<double>(samples) * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["print_s"] = t_end;
}
BENCHMARK(BM_ShapedTwoHourPrint)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace
