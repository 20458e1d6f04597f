// Step generation (amctl::steppers): steps per second on a real print, the plan made once
// outside the timed loop. The aim is >= 20 M steps/s on one core. docs/steppers.md,
// "Figures".
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/steppers/step_filter.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/steppers/step_rate.hpp"
#include "amctl/steppers/steps.hpp"

namespace {

struct Planned {
  amctl::machine::Machine machine;
  std::vector<amctl::plan::PlanBatch> batches;
};

Planned plan_file(const std::string& gcode, const std::string& cfg) {
  Planned p{amctl::machine::load_machine(std::string(AMCTL_SOURCE_DIR) + "/" + cfg, {}), {}};
  amctl::plan::PlanSource source(std::string(AMCTL_SOURCE_DIR) + "/" + gcode, p.machine);
  amctl::plan::PlanBatch b;
  while (source.next(b)) p.batches.push_back(b);
  return p;
}

// Generation only: the callback counts the steps of each move.
void run_steps(benchmark::State& state, const Planned& p) {
  const auto channels = amctl::machine::motors(p.machine);
  std::uint64_t steps = 0;
  for (auto _ : state) {
    std::uint64_t n = 0;
    double last = 0.0;
    amctl::steppers::StepSink sink(channels, [&](std::span<const amctl::steppers::Step> s) {
      n += s.size();
      last = s.back().time_s;
    });
    for (const auto& b : p.batches) sink.consume(b);
    benchmark::DoNotOptimize(last);
    steps = n;
  }
  state.counters["steps"] = static_cast<double>(steps);
  state.SetItemsProcessed(static_cast<std::int64_t>(steps) * state.iterations());
}

void BM_StepsBoxbossCoreXY(benchmark::State& state) {
  static const Planned p = plan_file("examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
                                     "configs/klipper-voron-v0.cfg");
  run_steps(state, p);
}
BENCHMARK(BM_StepsBoxbossCoreXY)->Unit(benchmark::kMillisecond);

// The same with Klipper's step+dir+step filter behind the generator (--step-filter klipper):
// items are the steps generated, so the rate compares with BM_StepsBoxbossCoreXY directly.
void BM_StepsBoxbossCoreXYKlipperFilter(benchmark::State& state) {
  static const Planned p = plan_file("examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
                                     "configs/klipper-voron-v0.cfg");
  const auto channels = amctl::machine::motors(p.machine);
  std::uint64_t steps = 0, kept = 0;
  for (auto _ : state) {
    std::uint64_t n = 0;
    amctl::steppers::StepDirFilter filter(channels.size());
    std::vector<amctl::steppers::Step> out;
    amctl::steppers::StepSink sink(channels, [&](std::span<const amctl::steppers::Step> s) {
      n += s.size();
      out.clear();
      filter.push(s, out);
    });
    for (const auto& b : p.batches) sink.consume(b);
    out.clear();
    filter.finish(out);
    benchmark::DoNotOptimize(out.data());
    steps = n;
    kept = 0;
    for (const auto& st : filter.stats()) kept += st.steps;
  }
  state.counters["steps"] = static_cast<double>(steps);
  state.counters["kept"] = static_cast<double>(kept);
  state.SetItemsProcessed(static_cast<std::int64_t>(steps) * state.iterations());
}
BENCHMARK(BM_StepsBoxbossCoreXYKlipperFilter)->Unit(benchmark::kMillisecond);

// The same with the step-rate figures of `amctl steps` (StepRateMeter: the filtered peak and
// the sustained rate) behind the generator: their cost against BM_StepsBoxbossCoreXY.
void BM_StepsBoxbossCoreXYRates(benchmark::State& state) {
  static const Planned p = plan_file("examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
                                     "configs/klipper-voron-v0.cfg");
  const auto channels = amctl::machine::motors(p.machine);
  std::uint64_t steps = 0;
  for (auto _ : state) {
    std::uint64_t n = 0;
    amctl::steppers::StepRateMeter meter(channels.size());
    amctl::steppers::StepSink sink(channels, [&](std::span<const amctl::steppers::Step> s) {
      n += s.size();
      meter.push(s);
    });
    for (const auto& b : p.batches) sink.consume(b);
    meter.finish();
    benchmark::DoNotOptimize(meter.figures().data());
    steps = n;
  }
  state.counters["steps"] = static_cast<double>(steps);
  state.SetItemsProcessed(static_cast<std::int64_t>(steps) * state.iterations());
}
BENCHMARK(BM_StepsBoxbossCoreXYRates)->Unit(benchmark::kMillisecond);

void BM_StepsBoxbossScurve7(benchmark::State& state) {
  static const Planned p = [] {
    Planned q{amctl::machine::load_machine(
                  std::string(AMCTL_SOURCE_DIR) + "/configs/klipper-voron-v0.cfg",
                  {"printer.profile=scurve7", "printer.max_jerk=200000"}),
              {}};
    amctl::plan::PlanSource source(
        std::string(AMCTL_SOURCE_DIR) + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
        q.machine);
    amctl::plan::PlanBatch b;
    while (source.next(b)) q.batches.push_back(b);
    return q;
  }();
  run_steps(state, p);
}
BENCHMARK(BM_StepsBoxbossScurve7)->Unit(benchmark::kMillisecond);

// A delta's towers are non-linear (a Newton solve per step on the carriage height, then the
// time solve): tests/reference/klipper/syn_delta.gcode, 336 718 steps.
void BM_StepsDeltaSynthetic(benchmark::State& state) {
  static const Planned p = plan_file("tests/reference/klipper/syn_delta.gcode",
                                     "tests/reference/klipper/delta.cfg");
  run_steps(state, p);
}
BENCHMARK(BM_StepsDeltaSynthetic)->Unit(benchmark::kMillisecond);

}  // namespace
