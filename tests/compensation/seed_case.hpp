#pragma once
// The seed 000 base case for the compensation tests: the corner path planned on the seed's
// machine (examples/30_seed000_*), and plans of G-code text on the same machine.
#include <string>
#include <string_view>
#include <vector>

#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::compensation::seed_case {

inline const std::string kSeedGcode = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner.gcode";
inline const std::string kSeedPrinter = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner_printer.cfg";

inline std::vector<plan::PlannedMove> collect(plan::PlanSource& source) {
  plan::CollectSink sink;
  std::vector<plan::Sink*> sinks{&sink};
  plan::run_pipeline(source, sinks);
  return sink.moves;
}

/// The seed's corner (10 mm along X, then Y, 100 mm/s, 5000 mm/s^2, full stop).
inline std::vector<plan::PlannedMove> seed_plan() {
  const machine::Machine m = machine::load_machine(kSeedPrinter, {});
  plan::PlanSource source(kSeedGcode, m);
  return collect(source);
}

/// G-code text planned on the seed's machine.
inline std::vector<plan::PlannedMove> plan_text(const std::string& gcode_text) {
  const machine::Machine m = machine::load_machine(kSeedPrinter, {});
  plan::PlanSource source(std::string_view(gcode_text), "test.gcode", m);
  return collect(source);
}

}  // namespace amctl::compensation::seed_case
