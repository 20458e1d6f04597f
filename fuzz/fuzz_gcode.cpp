// libFuzzer target for the G-code reader: arbitrary bytes through the line reader, the
// parser, the interpreter and the planner, in strict and lenient mode. The only acceptable
// outcomes are a report or amctl::Error (bad input); anything else is a bug.
//
// Work budget: one G2/G3 line may legitimately expand into millions of segments (a 6 m arc at
// 1 mm per segment), so a 20 kB input could ask for 1e9 planned moves. That is real work, not
// a hang, but it hides actual hangs behind -timeout; the harness stops an input after
// kMaxMoves planned moves (every move up to there has been checked like any other).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/plan/estimate.hpp"

namespace {
constexpr std::uint64_t kMaxMoves = 200000;
struct BudgetExhausted {};
}  // namespace

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
      std::uint64_t moves = 0;
      opt.on_move = [&moves](const amctl::plan::PlannedMove& mv) {
        // Every planned move must have finite, non-negative phases.
        if (!(mv.accel_t_s >= 0.0 && mv.cruise_t_s >= 0.0 && mv.decel_t_s >= 0.0 &&
              std::isfinite(mv.duration_s()))) {
          __builtin_trap();
        }
        if (++moves > kMaxMoves) throw BudgetExhausted{};
      };
      try {
        auto r = amctl::plan::estimate_text(text, "fuzz", m, opt);
        if (!(r.total_time_s >= 0.0)) __builtin_trap();  // NaN or negative time is a bug
      } catch (const amctl::Error&) {
      } catch (const BudgetExhausted&) {
      }
    }
  }
  return 0;
}
