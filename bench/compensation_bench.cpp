// Feedforward compensation (docs/compensation.md, "Figures"): the exact inverse and FBF on the
// seed 000 base case, and FBF on a 5 s window of a real sliced file (layer 2 of the box boss,
// PrusaSlicer 2.5, Voron V0 config, 40 Hz / zeta 0.1 belts). Each run includes the check
// simulation of the command and the uncompensated simulation.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "amctl/compensation/compensate.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"

namespace {

namespace cp = amctl::compensation;

std::vector<amctl::plan::PlannedMove> plan_file(const std::string& file, const std::string& cfg,
                                                const std::vector<std::string>& overrides) {
  const amctl::machine::Machine m = amctl::machine::load_machine(cfg, overrides);
  amctl::plan::PlanSource source(file, m);
  amctl::plan::CollectSink collect;
  std::vector<amctl::plan::Sink*> sinks{&collect};
  amctl::plan::run_pipeline(source, sinks);
  return collect.moves;
}

void run(benchmark::State& state, const std::vector<amctl::plan::PlannedMove>& moves,
         const cp::CompensationOptions& o) {
  cp::CompensationResult r;
  for (auto _ : state) {
    r = cp::compensate(moves, o);
    // (DoNotOptimize on the double itself, "+r" on this GCC, wrote garbage back into it.)
    benchmark::DoNotOptimize(r.x_cmd_mm.data());
  }
  state.counters["motion_s"] = r.motion_time_s;
  state.counters["max_err_um"] = 1e3 * r.max_tracking_error_mm;
  state.counters["uncomp_err_um"] = 1e3 * r.uncompensated_max_tracking_error_mm;
  state.counters["rt_factor"] = benchmark::Counter(r.motion_time_s * static_cast<double>(state.iterations()),
                                                   benchmark::Counter::kIsRate);
  state.counters["samples"] = static_cast<double>(r.t_s.size());
  state.SetLabel(std::string(amctl::compensation::to_string(r.status)));
}

cp::CompensationOptions options(cp::Method m, double w_rad_s, double z) {
  cp::CompensationOptions o;
  o.method = m;
  o.model_x = o.model_y = o.plant_x = o.plant_y = amctl::dynamics::AxisModel::belt_rad_s(w_rad_s, z);
  return o;
}

const std::string kSource = AMCTL_BENCH_SOURCE_DIR;

void BM_CompensateSeedFbf(benchmark::State& state) {
  static const auto moves = plan_file(kSource + "/examples/30_belt_corner.gcode",
                                      kSource + "/examples/30_belt_corner_printer.cfg", {});
  run(state, moves, options(cp::Method::fbf, 100.0, 0.5));
}
BENCHMARK(BM_CompensateSeedFbf)->Unit(benchmark::kMillisecond);

void BM_CompensateSeedInvertScurve(benchmark::State& state) {
  static const auto moves = plan_file(kSource + "/examples/30_belt_corner.gcode",
                                      kSource + "/examples/30_belt_corner_printer.cfg",
                                      {"printer.profile=scurve7"});
  run(state, moves, options(cp::Method::invert, 100.0, 0.5));
}
BENCHMARK(BM_CompensateSeedInvertScurve)->Unit(benchmark::kMillisecond);

void BM_CompensateRealWindowFbf(benchmark::State& state) {
  static const auto moves = [] {
    const auto all = plan_file(kSource + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
                               kSource + "/configs/klipper-voron-v0.cfg", {});
    std::vector<amctl::plan::PlannedMove> w;
    for (const auto& m : all) {
      if (m.layer != 2) continue;
      if (!w.empty() && m.end_time_s() - w.front().start_time_s > 5.0) break;
      w.push_back(m);
    }
    return w;
  }();
  const double w = 2.0 * 3.141592653589793 * 40.0;
  run(state, moves, options(cp::Method::fbf, w, 0.1));
}
BENCHMARK(BM_CompensateRealWindowFbf)->Unit(benchmark::kMillisecond);

// LPFBF over the whole bundled print (809 s of motion, 810 000 samples at 1 kHz), streamed
// from the G-code: parsing, planning, the windows, the check simulation, the metrics and the
// CSV written (to the build tree) all included. Peak RSS: bench/lpfbf_whole_print.sh.
void BM_CompensateWholePrintLpfbf(benchmark::State& state) {
  const amctl::machine::Machine m =
      amctl::machine::load_machine(kSource + "/configs/klipper-voron-v0.cfg", {});
  cp::CompensationOptions o = options(cp::Method::lpfbf, 2.0 * 3.141592653589793 * 40.0, 0.1);
  o.window_s = state.range(0) / 1000.0;
  o.overlap_s = state.range(1) / 1000.0;
  cp::CompensationResult r;
  for (auto _ : state)
    r = cp::compensate_file_streaming(kSource + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
                                      m, o, "lpfbf_whole_print_bench.csv");
  state.counters["motion_s"] = r.motion_time_s;
  state.counters["max_err_um"] = 1e3 * r.max_tracking_error_mm;
  state.counters["uncomp_err_um"] = 1e3 * r.uncompensated_max_tracking_error_mm;
  state.counters["rt_factor"] = benchmark::Counter(r.motion_time_s * static_cast<double>(state.iterations()),
                                                   benchmark::Counter::kIsRate);
  state.counters["samples"] = static_cast<double>(r.samples);
  state.counters["held_moves"] = static_cast<double>(r.max_held_moves);
  state.SetLabel(std::string(amctl::compensation::to_string(r.status)));
}
BENCHMARK(BM_CompensateWholePrintLpfbf)->Args({636, 318})->Args({400, 100})->Args({250, 100})
    ->Unit(benchmark::kMillisecond)->Iterations(2);


// Collocation on the seed base case with the 10 000 mm/s^2 base bound (issue 10: < 1 s).
void BM_CompensateSeedCollocationBounded(benchmark::State& state) {
  static const auto moves = plan_file(kSource + "/examples/30_belt_corner.gcode",
                                      kSource + "/examples/30_belt_corner_printer.cfg", {});
  cp::CompensationOptions o = options(cp::Method::collocation, 100.0, 0.5);
  o.max_base_accel_mm_s2 = 10000.0;
  run(state, moves, o);
}
BENCHMARK(BM_CompensateSeedCollocationBounded)->Unit(benchmark::kMillisecond);

// Collocation's cost against the path's length (issue 10: linear from 1e3 to 1e5 samples):
// a zigzag of 10 mm moves on the seed machine (a = 5000 mm/s^2, 100 mm/s, full stops), the
// seed's belt, the 10 000 mm/s^2 bound, 1 kHz, the default windows (1 s, 0.25 s overlap).
// The argument is the number of samples; BigO reports the fitted exponent.
void BM_CollocationCost(benchmark::State& state) {
  const double target_s = static_cast<double>(state.range(0)) / 1000.0;
  std::string g = "G90\nG1 X0 Y0 F6000\n";
  // One 10 mm move takes 0.12 s at 100 mm/s and 5000 mm/s^2 from rest to rest; the lead-in
  // (0.08 s) and tail (0.1 s) complete the grid.
  const int n_moves = std::max(1, static_cast<int>(std::lround((target_s - 0.18) / 0.12)));
  for (int i = 0; i < n_moves; ++i)
    g += (i % 2 == 0) ? "G91\nG1 X10 Y0\n" : "G1 X0 Y10\n";
  const amctl::machine::Machine m = amctl::machine::load_machine(kSource + "/examples/30_belt_corner_printer.cfg", {});
  amctl::plan::PlanSource source(std::string_view(g), "zigzag.gcode", m);
  amctl::plan::CollectSink collect;
  std::vector<amctl::plan::Sink*> sinks{&collect};
  amctl::plan::run_pipeline(source, sinks);
  cp::CompensationOptions o = options(cp::Method::collocation, 100.0, 0.5);
  o.max_base_accel_mm_s2 = 10000.0;
  run(state, collect.moves, o);
  state.SetComplexityN(state.range(0));
}
BENCHMARK(BM_CollocationCost)->Arg(1000)->Arg(3000)->Arg(10000)->Arg(30000)->Arg(100000)
    ->Unit(benchmark::kSecond)->Iterations(1)->Complexity(benchmark::oN);

}  // namespace
