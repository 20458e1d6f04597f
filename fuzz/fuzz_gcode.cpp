// libFuzzer target for the G-code reader: arbitrary bytes through the line reader, the
// parser, the interpreter and the planner, in strict and lenient mode. The only acceptable
// outcomes are a report or amctl::Error (bad input); anything else is a bug.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/plan/estimate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  for (bool strict : {true, false}) {
    for (auto fw : {amctl::machine::Firmware::klipper, amctl::machine::Firmware::marlin}) {
      amctl::machine::Machine m;
      m.firmware = fw;
      m.junction = fw == amctl::machine::Firmware::klipper
                       ? amctl::machine::JunctionPolicy::square_corner_velocity
                       : amctl::machine::JunctionPolicy::classic_jerk;
      amctl::plan::EstimateOptions opt;
      opt.strict = strict;
      try {
        auto r = amctl::plan::estimate_text(text, "fuzz", m, opt);
        if (!(r.total_time_s >= 0.0)) __builtin_trap();  // NaN or negative time is a bug
      } catch (const amctl::Error&) {
      }
    }
  }
  return 0;
}
