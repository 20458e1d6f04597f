#pragma once
// Test helper: plan G-code text on a machine and collect every step, the channels, the plan
// and the generator's statistics (steps_test.cpp, kinematics_steps_test.cpp).
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/machine/machine.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers::test {

struct StepRun {
  std::vector<kinematics::Motor> motors;
  std::vector<Step> steps;
  std::vector<plan::PlannedMove> moves;
  std::vector<StepperStats> stats;
  /// The steps of motor c, in time order.
  [[nodiscard]] std::vector<Step> of(std::uint32_t c) const {
    std::vector<Step> out;
    for (const Step& s : steps) if (s.stepper == c) out.push_back(s);
    return out;
  }
};

inline StepRun run(const std::string& gcode, const machine::Machine& m) {
  StepRun r;
  r.motors = machine::motors(m);
  plan::PlanSource source(std::string_view(gcode), "test", m);
  StepSink sink(r.motors, [&](std::span<const Step> s) { r.steps.insert(r.steps.end(), s.begin(), s.end()); });
  plan::CollectSink collect;
  plan::Sink* sinks[] = {&sink, &collect};
  plan::run_pipeline(source, sinks);
  r.moves = collect.moves;
  r.stats = sink.generator().stats();
  return r;
}

}  // namespace amctl::steppers::test
