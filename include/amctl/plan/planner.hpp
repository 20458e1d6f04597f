#pragma once
// The look-ahead velocity planner.
//
// Reference behaviour is Klipper's toolhead (klippy/toolhead.py, read for its behaviour):
//  - each move's cruise speed is the requested speed capped by max_velocity, Z and
//    extruder limits;
//  - the speed at a junction is limited by the "approximated centripetal velocity" derived
//    from square_corner_velocity (junction deviation jd = scv^2 (sqrt2 - 1) / accel), by half
//    the move length (centripetal limit), by the extruder's instantaneous_corner_velocity and
//    by what the previous move can reach;
//  - a second, smoothed pass with the pseudo-acceleration accel (1 - minimum_cruise_ratio)
//    decides where moves cruise, so short zig-zags do not accelerate to full speed;
//  - the queue is flushed lazily once 0.15 s of moves are queued (1 s after a full flush),
//    fully at dwells, M400 and position resets.
// Marlin's junction deviation (with its small-segment limit) and classic jerk are the other
// junction policies; Marlin also plans over a finite block buffer (16 moves by default).
// Derivations and the map of the implementation (src/plan/): docs/planner.md.
#include <algorithm>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "amctl/gcode/events.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/file_limits.hpp"
#include "amctl/plan/planned_move.hpp"

namespace amctl::plan {

/// The first move a Klipper machine refuses ("Move out of range"): its end lies outside
/// [position_min, position_max] of a moving axis. Klipper stops the print there.
struct RangeError {
  std::uint64_t line = 0;
  char axis = 'x';           ///< 'x', 'y' or 'z'; 'r' for a delta's radius sqrt(x^2 + y^2)
  double position_mm = 0.0;  ///< the move's end on that axis (machine coordinates)
  double limit_mm = 0.0;     ///< the position_min or position_max it passes
  double at_s = 0.0;         ///< print time at which the move would start (the print stops)
  bool operator==(const RangeError&) const = default;
};

namespace detail {
class PlannerCore;  // src/plan/planner_core.hpp
}  // namespace detail

/// Receives the planner's output in time order.
class PlanSink {
 public:
  virtual ~PlanSink() = default;
  virtual void on_planned(const PlannedMove& move) = 0;
  /// A pause with the toolhead at rest (G4), starting at start_time_s.
  virtual void on_dwell(double start_time_s, double duration_s, std::uint64_t line) {
    (void)start_time_s; (void)duration_s; (void)line;
  }
  /// A heater command taking effect at print time `time_s` (after the moves before it).
  virtual void on_heater(double time_s, const gcode::HeaterCommand& cmd) { (void)time_s; (void)cmd; }
  virtual void on_progress(double time_s, const gcode::ProgressMarker& m) { (void)time_s; (void)m; }
  virtual void on_untimed(double time_s, std::string_view name, std::uint64_t line) {
    (void)time_s; (void)name; (void)line;
  }
  virtual void on_layer_change(double time_s, std::int32_t layer, std::uint64_t line) {
    (void)time_s; (void)layer; (void)line;
  }
  virtual void on_fan(double time_s, double fraction, std::uint64_t line) {
    (void)time_s; (void)fraction; (void)line;
  }
  /// The first move out of range on a Klipper machine with position_min/max, at the print
  /// time it would start (after the moves before it). At most once per run.
  virtual void on_range_error(const RangeError& e) { (void)e; }
  /// M593 taking effect at print time `time_s` (after the moves before it).
  virtual void on_input_shaping(double time_s, const gcode::InputShapingCommand& cmd) {
    (void)time_s; (void)cmd;
  }
  /// Klipper's SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE, in force for the step generator from
  /// `time_s`: the step generator's restart after a flush (the last move's end + the restart
  /// delay before the command), else the end of the moves before it.
  virtual void on_step_tuning(double time_s, const gcode::StepTuningCommand& cmd) {
    (void)time_s; (void)cmd;
  }
};

struct PlannerOptions {
  /// Overrides Machine::block_buffer_size when set (0 = unlimited look-ahead).
  std::optional<std::size_t> block_buffer_size;
  /// Upper bound on queued moves before a forced flush (Klipper's lazy flush, or the oldest
  /// block of an unlimited Marlin buffer), and on non-motion events waiting behind queued
  /// moves before a forced full stop; it keeps memory bounded on pathological input without
  /// changing results on real files.
  std::size_t max_queue = 1u << 16;
  /// Marlin's MINIMUM_PLANNER_SPEED [mm/s].
  double minimum_planner_speed_mm_s = 0.05;
  /// The file's own limits commands: kept as the firmware does, ignored, or capped at the
  /// machine's (file_limits.hpp).
  FileLimits file_limits = FileLimits::keep;
};

/// Count of moves whose request the machine refused or trimmed.
struct PlannerDiagnostics {
  std::uint64_t moves = 0;
  std::uint64_t zero_length_moves = 0;
  std::uint64_t speed_limited_moves = 0;   ///< requested speed above a limit
  std::uint64_t extrude_only_moves = 0;
  std::uint64_t forced_flushes = 0;        ///< max_queue reached (0 on real files; warned)
  std::uint64_t full_stops = 0;            ///< flushes to zero speed (dwell, M400, ...)
  std::uint64_t min_segment_time_slowdowns = 0;  ///< Marlin SLOWDOWN (M205 B) slowed the move
  /// Marlin soft endstops (machine soft_min/max_position): moves whose target was clamped.
  std::uint64_t clamped_moves = 0;
  std::vector<std::string> warnings;       ///< e.g. over-extrusion (Klipper would refuse)
  /// The file's limits commands and what the planner did with them (PlannerOptions::file_limits).
  FileLimitsReport file_limits;
};

class Planner final : public gcode::EventSink {
 public:
  Planner(const machine::Machine& machine, PlanSink& sink, PlannerOptions options = {});
  ~Planner() override;
  Planner(const Planner&) = delete;
  Planner& operator=(const Planner&) = delete;

  // gcode::EventSink
  void on_move(const gcode::MoveRequest& move) override;
  void on_dwell(double duration_s, std::uint64_t line) override;
  void on_wait_moves(std::uint64_t line) override;
  void on_step_flush(std::uint64_t line) override;
  void on_set_position(const std::array<double, 4>& pos_mm, std::uint64_t line) override;
  void on_limits(const gcode::LimitsCommand& cmd) override;
  void on_axis_range(int axis, double min_mm, double max_mm, std::uint64_t line) override;
  void on_heater(const gcode::HeaterCommand& cmd) override;
  void on_fan(double fraction, std::uint64_t line) override;
  void on_input_shaping(const gcode::InputShapingCommand& cmd) override;
  void on_step_tuning(const gcode::StepTuningCommand& cmd) override;
  void on_progress(const gcode::ProgressMarker& m) override;
  void on_layer_change(std::int32_t layer, std::uint64_t line) override;
  void on_untimed(std::string_view name, std::uint64_t line) override;

  /// Plans and emits every queued move, ending at rest. Call once at end of input.
  void finish();

  /// Print time reached by the moves emitted so far [s].
  [[nodiscard]] double print_time_s() const;
  [[nodiscard]] const PlannerDiagnostics& diagnostics() const;

  /// Current limits (after G-code changes) — useful for reports and tests.
  struct Limits {
    double max_velocity_mm_s;
    double accel_mm_s2;             ///< Klipper toolhead accel / Marlin print accel
    double travel_accel_mm_s2;      ///< Marlin
    double retract_accel_mm_s2;     ///< Marlin
    double square_corner_velocity_mm_s;
    double minimum_cruise_ratio;
    std::optional<double> accel_to_decel_mm_s2;  ///< old Klipper setting, when given
    std::array<double, 4> max_feedrate_mm_s;
    std::array<double, 4> max_axis_accel_mm_s2;
    std::array<double, 4> jerk_mm_s;
    double junction_deviation_mm;
    double min_feedrate_mm_s;
    double min_travel_feedrate_mm_s;
    double min_segment_time_s;      ///< Marlin M205 B (SLOWDOWN)
  };
  [[nodiscard]] const Limits& limits() const;

 private:
  std::unique_ptr<detail::PlannerCore> core_;  // queue, strategies, limits: src/plan/
};

}  // namespace amctl::plan
