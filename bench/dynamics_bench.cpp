// Hot paths of trajectory evaluation and dynamics simulation.
//   BM_ModeStep              one 2-state mode update (the inner kernel)
//   BM_SimulateTwoHourPrint  a synthetic 2-hour print (zig-zag infill and perimeters of short
//                            segments, Klipper-like junction speeds) simulated at 1 kHz through
//                            the seed 000 belt model on X and Y; counters give axis-state
//                            updates per second and the wall time of the whole print.
//   BM_SimulateWithMetrics   the same with contour-error metrics on every sample.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "amctl/dynamics/metrics.hpp"
#include "amctl/dynamics/propagator.hpp"
#include "amctl/dynamics/simulate.hpp"
#include "amctl/plan/velocity_profile.hpp"
#include "amctl/trajectory/build.hpp"
#include "amctl/trajectory/trajectory.hpp"

#include "synthetic.hpp"

namespace {

using namespace amctl;

const std::vector<plan::PlannedMove>& two_hour_print() {
  static const std::vector<plan::PlannedMove> moves = bench::synthetic_two_hour_print(12345, {100, 100, 0.2, 0});
  return moves;
}

void BM_ModeStep(benchmark::State& state) {
  const dynamics::Mode mode{40.0, 0.1, 1.0};
  const dynamics::ModePropagator p = dynamics::mode_propagator(mode, 0.001, 1);
  double e = 0.0, q = 0.0, u = 1000.0;
  for (auto _ : state) {
    const double ne = p.phi[0][0] * e + p.phi[0][1] * q + p.psi[0][0] * u;
    const double nq = p.phi[1][0] * e + p.phi[1][1] * q + p.psi[1][0] * u;
    e = ne;
    q = nq;
    u = -u;
    benchmark::DoNotOptimize(e);
  }
  state.counters["updates_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ModeStep);

void BM_SimulateTwoHourPrint(benchmark::State& state) {
  const auto& moves = two_hour_print();
  const dynamics::AxisModel m = dynamics::AxisModel::belt(40.0, 0.1);
  dynamics::SimulationOptions o;
  o.sample_rate_hz = 1000.0;
  std::size_t updates = 0;
  for (auto _ : state) {
    double worst = 0.0;
    const auto st = dynamics::simulate(moves, m, m, o, [&](const dynamics::SimSample& s) {
      worst = std::max(worst, std::abs(s.sim_mm[0] - s.cmd_mm[0]));
    });
    updates += st.axis_state_updates;
    benchmark::DoNotOptimize(worst);
    state.counters["samples"] = static_cast<double>(st.samples);
    state.counters["print_s"] = st.motion_end_time_s;
  }
  state.counters["moves"] = static_cast<double>(moves.size());
  state.counters["axis_updates_per_s"] = benchmark::Counter(static_cast<double>(updates), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulateTwoHourPrint)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_SimulateWithMetrics(benchmark::State& state) {
  const auto& moves = two_hour_print();
  const dynamics::AxisModel m = dynamics::AxisModel::belt(40.0, 0.1);
  dynamics::SimulationOptions o;
  o.sample_rate_hz = 1000.0;
  for (auto _ : state) {
    dynamics::QualityMeter meter(moves, {});
    (void)dynamics::simulate(moves, m, m, o, [&](const dynamics::SimSample& s) { meter.add(s); },
                             [&](std::size_t i, double t, const std::array<double, 2>& v) { meter.on_move_end(i, t, v); });
    const auto r = meter.finish();
    benchmark::DoNotOptimize(r.max_contour_error_mm);
  }
}
BENCHMARK(BM_SimulateWithMetrics)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_CursorEvaluate(benchmark::State& state) {
  const auto& moves = two_hour_print();
  const std::span<const plan::PlannedMove> first(moves.data(), std::min<std::size_t>(moves.size(), 20000));
  const double end = first.back().end_time_s();
  std::size_t n = 0;
  for (auto _ : state) {
    trajectory::Cursor c(first);
    double acc = 0.0;
    for (double t = 0.0; t < end; t += 1e-3) {
      acc += c.evaluate(t).pos_mm[0];
      ++n;
    }
    benchmark::DoNotOptimize(acc);
  }
  state.counters["evals_per_s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CursorEvaluate)->Unit(benchmark::kMillisecond);

}  // namespace

namespace {

// The bounded-memory path `amctl simulate` uses: moves pushed one by one, metrics folded.
void BM_StreamingTwoHourPrintWithMetrics(benchmark::State& state) {
  const auto& moves = two_hour_print();
  const dynamics::AxisModel m = dynamics::AxisModel::belt(40.0, 0.1);
  dynamics::SimulationOptions o;
  o.sample_rate_hz = 1000.0;
  dynamics::MetricsOptions mo;
  mo.keep_per_move = false;
  for (auto _ : state) {
    dynamics::StreamingSimulation s(m, m, o, mo);
    for (const auto& mv : moves) s.push(mv);
    const auto r = s.finish();
    benchmark::DoNotOptimize(r.max_contour_error_mm);
    state.counters["window_moves"] = static_cast<double>(s.max_window_moves());
  }
}
BENCHMARK(BM_StreamingTwoHourPrintWithMetrics)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
