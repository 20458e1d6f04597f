// Closed-loop stepper simulation (amctl::closedloop): motor, chopper drive, belt, AS5311,
// controller and command governor for both motors of the voron24 preset (CoreXY), step-level
// physics at 50 us substeps, 10 kHz control, on slicer-like G-code planned by amctl's own
// planner (bench/synthetic.hpp's perimeter rings: a minute of it, and a whole two-hour print,
// 425 000 moves). Counter realtime_factor = simulated seconds per CPU second (one core): the
// issue asks >= 500 for a whole two-hour print (docs/closedloop.md, section 6).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <string>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/machine/loader.hpp"
#include "synthetic.hpp"

namespace {

// The G-code of `moves` perimeter moves, written once to a temporary file.
const std::string& gcode_file(std::size_t moves) {
  static std::map<std::size_t, std::string> files;
  auto it = files.find(moves);
  if (it != files.end()) return it->second;
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("amctl_closedloop_bench_" + std::to_string(moves) + ".gcode")).string();
  std::FILE* f = std::fopen(path.c_str(), "wb");
  const std::string g = amctl::bench::synthetic_gcode(moves);
  std::fwrite(g.data(), 1, g.size(), f);
  std::fclose(f);
  return files.emplace(moves, path).first->second;
}

void run(benchmark::State& state, amctl::closedloop::ControllerKind kind, std::size_t moves) {
  const std::string& path = gcode_file(moves);
  const amctl::machine::Machine m = amctl::machine::load_machine("voron24");
  amctl::closedloop::SimulationOptions o;
  o.controller = kind;
  o.gains.max_accel_mm_s2 = m.max_accel_mm_s2;
  double simulated = 0.0, cpu = 0.0;
  std::uint64_t lost = 0;
  for (auto _ : state) {
    const std::clock_t c0 = std::clock();
    const auto r = amctl::closedloop::simulate_file(path, m, o);
    cpu += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    simulated += r.duration_s;
    lost += r.axes[0].lost_steps + r.axes[1].lost_steps;
    benchmark::DoNotOptimize(r.axes[0].rms_tracking_error_mm);
  }
  state.counters["realtime_factor"] = simulated / cpu;  // CPU time: the VM is shared
  state.counters["simulated_s"] = simulated / static_cast<double>(state.iterations());
  state.counters["lost_steps"] = static_cast<double>(lost);
}

constexpr std::size_t kMinute = 3600, kTwoHours = 425000;

void BM_ClosedLoopOpenMinute(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::open, kMinute);
}
BENCHMARK(BM_ClosedLoopOpenMinute)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ClosedLoopPidMinute(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::pid, kMinute);
}
BENCHMARK(BM_ClosedLoopPidMinute)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_ClosedLoopFeedforwardMinute(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::feedforward, kMinute);
}
BENCHMARK(BM_ClosedLoopFeedforwardMinute)->Unit(benchmark::kMillisecond)->Iterations(3);

// The whole two-hour print, once each.
void BM_ClosedLoopOpenTwoHourPrint(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::open, kTwoHours);
}
BENCHMARK(BM_ClosedLoopOpenTwoHourPrint)->Unit(benchmark::kSecond)->Iterations(1);

void BM_ClosedLoopFeedforwardTwoHourPrint(benchmark::State& state) {
  run(state, amctl::closedloop::ControllerKind::feedforward, kTwoHours);
}
BENCHMARK(BM_ClosedLoopFeedforwardTwoHourPrint)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
