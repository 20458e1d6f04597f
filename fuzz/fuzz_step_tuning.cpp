// libFuzzer target for Klipper's SET_INPUT_SHAPER and SET_PRESSURE_ADVANCE in the G-code
// (gcode/step_tuning.cpp, the shapers the planner builds for them in plan/step_timing.cpp),
// on a printer with an input shaper and two extruder steppers: the input is G-code, planned
// in full.
//
// Acceptable outcomes: a report or amctl::Error. The print time must be finite and >= 0
// (a shaper of 1e-300 Hz once gave 4e299 s), and the planner stops an input after a budget
// of moves (a G2/G3 line may expand into millions: real work that would hide hangs).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "fuzz_support.hpp"

using amctl::fuzz::require;

namespace {

constexpr std::uint64_t kMaxMoves = 50000;
struct BudgetExhausted {};

const amctl::machine::Machine& machine() {
  static const amctl::machine::Machine m = amctl::machine::parse_klipper_cfg(
      "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
      "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 200\n"
      "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 200\n"
      "[stepper_z]\nrotation_distance: 8\nmicrosteps: 16\nposition_max: 200\n"
      "[extruder]\nrotation_distance: 33.5\nmicrosteps: 16\nnozzle_diameter: 0.4\n"
      "filament_diameter: 1.75\npressure_advance: 0.04\n"
      "[extruder_stepper belted]\nextruder: extruder\nrotation_distance: 22\nmicrosteps: 16\n"
      "[input_shaper]\nshaper_freq_x: 40\nshaper_freq_y: 38\nshaper_type_y: ei\n",
      "fuzz.cfg");
  return m;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  for (bool strict : {true, false}) {
    amctl::plan::EstimateOptions opt;
    opt.strict = strict;
    std::uint64_t moves = 0;
    opt.on_move = [&moves](const amctl::plan::PlannedMove& mv) {
      if (!(mv.accel_t_s >= 0.0 && mv.cruise_t_s >= 0.0 && mv.decel_t_s >= 0.0 && std::isfinite(mv.duration_s()))) {
        __builtin_trap();
      }
      if (++moves > kMaxMoves) throw BudgetExhausted{};
    };
    try {
      const auto r = amctl::plan::estimate_text(text, "fuzz.gcode", machine(), opt);
      require(std::isfinite(r.total_time_s) && r.total_time_s >= 0.0);
    } catch (const amctl::Error&) {
    } catch (const BudgetExhausted&) {
    }
  }
  return 0;
}
