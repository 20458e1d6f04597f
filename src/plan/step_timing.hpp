#pragma once
// Internal to the planner: Klipper's step-generation restart delay (motion_queuing.py,
// kin_flush_delay; docs/steppers.md section 8). After a step-generation flush the step
// generator has run to the last move's end + this delay (the delay in force when the moves
// were queued), and the next move starts no earlier than that + the delay in force then. It is
// the largest scan window of any stepper: SDS_CHECK_TIME (1 ms), an input shaper's farthest
// impulse from its centre (kin_shaper.c, on the axes some stepper moves), half the smoothing
// time of an extruder with pressure advance on (kin_extruder.c).
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "amctl/gcode/events.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/machine/machine.hpp"

namespace amctl::plan::detail {

class StepTiming {
 public:
  /// Klipper's SDS_CHECK_TIME [s], the smallest delay.
  static constexpr double kSdsCheckTimeS = 0.001;

  explicit StepTiming(const machine::Machine& m);
  [[nodiscard]] double flush_delay_s() const;
  /// Applies a SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE. Throws amctl::Error at the command's
  /// line and column for a shaper Klipper refuses (a type it does not define, a damping ratio
  /// above the type's limit, more than 10 impulses, parameters without a shaper).
  void apply(const gcode::StepTuningCommand& c);

 private:
  std::array<double, 3> shaper_reach_s_{};  ///< per axis: farthest impulse from the centre
  std::array<bool, 3> axis_stepped_{};      ///< some stepper moves with the axis
  std::vector<std::pair<std::string, double>> half_smooth_s_;  ///< by extruder stepper
};

/// What SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE start from on a Klipper machine (nothing on
/// another firmware): [input_shaper] (a printer.cfg's section, or a shaper configured in TOML)
/// and the extruder steppers of the printer.cfg with their pressure advance.
[[nodiscard]] std::optional<gcode::InterpreterOptions::StepTuning> step_tuning_of(
    const machine::Machine& m);

/// The farthest impulse of a Klipper shaper from its amplitude-weighted centre [s]
/// (kin_shaper.c gen_steps_pre/post_active); 0 at frequency 0.
[[nodiscard]] double shaper_reach_s(const gcode::AxisShaperSetting& s);

}  // namespace amctl::plan::detail
