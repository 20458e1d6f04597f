// Closed-loop stepper simulation (amctl::closedloop): motor, chopper drive, belt, AS5311,
// controller and command governor for both motors of the voron24 preset (CoreXY), step-level
// physics at 50 us substeps, 10 kHz control, on the synthetic two-hour print (its first minute,
// and the whole print). Counter realtime_factor = simulated seconds per CPU second (one core):
// the issue asks >= 500 for a whole two-hour print (docs/closedloop.md, section 6).
#include <benchmark/benchmark.h>

#include <ctime>
#include <vector>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/machine/loader.hpp"
#include "synthetic.hpp"

namespace {

const std::vector<amctl::plan::PlannedMove>& whole_print() {
  static const std::vector<amctl::plan::PlannedMove> all =
      amctl::bench::synthetic_two_hour_print(7, {150.0, 150.0, 0.0, 0.0});
  return all;
}

std::vector<amctl::plan::PlannedMove> first_seconds(double seconds) {
  std::vector<amctl::plan::PlannedMove> out;
  for (const auto& m : whole_print()) {
    if (m.start_time_s >= seconds) break;
    out.push_back(m);
  }
  return out;
}

void run(benchmark::State& state, amctl::closedloop::ControllerKind kind,
         const std::vector<amctl::plan::PlannedMove>& moves) {
  const amctl::machine::Machine m = amctl::machine::load_machine("voron24");
  amctl::closedloop::SimulationOptions o;
  o.controller = kind;
  o.gains.max_accel_mm_s2 = m.max_accel_mm_s2;
  double simulated = 0.0, cpu = 0.0;
  std::uint64_t lost = 0;
  for (auto _ : state) {
    const std::clock_t c0 = std::clock();
    const auto r = amctl::closedloop::simulate_moves(moves, m, o);
    cpu += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    simulated += r.duration_s;
    lost += r.axes[0].lost_steps + r.axes[1].lost_steps;
    benchmark::DoNotOptimize(r.axes[0].rms_tracking_error_mm);
  }
  state.counters["realtime_factor"] = simulated / cpu;  // CPU time: the VM is shared
  state.counters["simulated_s"] = simulated / static_cast<double>(state.iterations());
  state.counters["lost_steps"] = static_cast<double>(lost);
}

void BM_ClosedLoopOpenSynthetic60s(benchmark::State& state) {
  static const auto moves = first_seconds(60.0);
  run(state, amctl::closedloop::ControllerKind::open, moves);
}
BENCHMARK(BM_ClosedLoopOpenSynthetic60s)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ClosedLoopFeedforwardSynthetic60s(benchmark::State& state) {
  static const auto moves = first_seconds(60.0);
  run(state, amctl::closedloop::ControllerKind::feedforward, moves);
}
BENCHMARK(BM_ClosedLoopFeedforwardSynthetic60s)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ClosedLoopPidSynthetic60s(benchmark::State& state) {
  static const auto moves = first_seconds(60.0);
  run(state, amctl::closedloop::ControllerKind::pid, moves);
}
BENCHMARK(BM_ClosedLoopPidSynthetic60s)->Unit(benchmark::kMillisecond)->Iterations(3);

// The whole two-hour print, once (about 15-30 s of CPU).
void BM_ClosedLoopOpenTwoHourPrint(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::open, whole_print());
}
BENCHMARK(BM_ClosedLoopOpenTwoHourPrint)->Unit(benchmark::kSecond)->Iterations(1);

void BM_ClosedLoopFeedforwardTwoHourPrint(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::feedforward, whole_print());
}
BENCHMARK(BM_ClosedLoopFeedforwardTwoHourPrint)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
