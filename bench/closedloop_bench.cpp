// Closed-loop stepper simulation (amctl::closedloop): motor, chopper drive, belt, AS5311 and
// controller for X and Y, every 20 us substep, on slices of the synthetic two-hour print.
// Counter realtime_factor = simulated seconds per CPU second (one core); the issue asks >= 100
// for a two-hour print (docs/closedloop.md, "Figures").
#include <benchmark/benchmark.h>

#include <ctime>
#include <vector>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/machine/loader.hpp"
#include "synthetic.hpp"

namespace {

std::vector<amctl::plan::PlannedMove> first_seconds(double seconds) {
  const auto all = amctl::bench::synthetic_two_hour_print(7, {150.0, 150.0, 0.0, 0.0});
  std::vector<amctl::plan::PlannedMove> out;
  for (const auto& m : all) {
    if (m.start_time_s >= seconds) break;
    out.push_back(m);
  }
  return out;
}

void run(benchmark::State& state, amctl::closedloop::ControllerKind kind) {
  static const std::vector<amctl::plan::PlannedMove> moves = first_seconds(60.0);
  const amctl::machine::Machine m = amctl::machine::load_machine("voron24");
  amctl::closedloop::SimulationOptions o;
  o.controller = kind;
  o.gains.max_accel_mm_s2 = 5000.0;
  double simulated = 0.0, cpu = 0.0;
  for (auto _ : state) {
    const std::clock_t c0 = std::clock();
    const auto r = amctl::closedloop::simulate_moves(moves, m, o);
    cpu += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    simulated += r.duration_s;
    benchmark::DoNotOptimize(r.axes[0].rms_tracking_error_mm);
  }
  state.counters["realtime_factor"] = simulated / cpu;  // CPU time: the VM is shared
  state.counters["simulated_s"] = simulated / static_cast<double>(state.iterations());
}

void BM_ClosedLoopOpenSynthetic60s(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::open);
}
BENCHMARK(BM_ClosedLoopOpenSynthetic60s)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ClosedLoopBestSynthetic60s(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::feedforward);
}
BENCHMARK(BM_ClosedLoopBestSynthetic60s)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
