#pragma once
// Internal to the planner: the state behind amctl::plan::Planner (which only forwards to
// it, so that the public header does not expose the queue). It turns requests into queued
// moves (firmware limits, junction policy) and hands them to one of the two strategies:
// Klipper's lazy-flush look-ahead or Marlin's block buffer. Source map: docs/planner.md.
#include <array>
#include <cstddef>
#include <cstdint>

#include "amctl/gcode/events.hpp"
#include <memory>

#include "amctl/kinematics/kinematics.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planner.hpp"
#include "klipper_lookahead.hpp"
#include "marlin_buffer.hpp"
#include "move_queue.hpp"
#include "pending_events.hpp"
#include "step_timing.hpp"
#include "ramp_shape.hpp"
#include "timeline.hpp"

namespace amctl::plan::detail {

/// Adds a limits command to the report (file_limits.cpp); `acts`: the modelled firmware acts
/// on it; `reprap`: M203 is in mm/min (RepRapFirmware).
void tally_file_limits(const gcode::LimitsCommand& c, bool acts, bool reprap, FileLimitsReport& report);
/// FileLimits::cap: lowers every speed, acceleration, jerk and junction limit of `lim` above
/// the machine's to the machine's (minimum_cruise_ratio: raises it to the machine's). True
/// when a value changed.
bool cap_limits(Planner::Limits& lim, const Planner::Limits& machine);

class PlannerCore {
 public:
  PlannerCore(const machine::Machine& machine, PlanSink& sink, PlannerOptions options);

  void on_move(const gcode::MoveRequest& move);
  void on_dwell(double duration_s, std::uint64_t line);
  void on_limits(const gcode::LimitsCommand& cmd);
  /// An IDEX carriage change: moves on `axis` must end in [min_mm, max_mm] from now on
  /// (Klipper's kinematics update_limits; ignored on other firmwares).
  void on_axis_range(int axis, double min_mm, double max_mm);
  /// Klipper's flush_step_generation: a full stop and the step generator's restart gap.
  void step_flush(std::uint64_t line);
  /// Klipper's SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE (step_timing.hpp).
  void on_step_tuning(const gcode::StepTuningCommand& cmd);
  void on_heater(const gcode::HeaterCommand& cmd);
  /// Queues a non-motion event behind the moves queued so far.
  void post(PendingEvent&& e);
  /// Plans and emits every queued move, ending at rest, and fires every waiting event.
  void full_stop();

  [[nodiscard]] double print_time_s() const { return timeline_.print_time_s(); }
  [[nodiscard]] const PlannerDiagnostics& diagnostics() const { return diag_; }
  [[nodiscard]] const Planner::Limits& limits() const { return lim_; }

 private:
  /// Limits of the move m (queued, geometry set) under Klipper's check_move rules;
  /// velocity and accel come in as requested and leave capped.
  void klipper_move_limits(const gcode::MoveRequest& r, const std::array<double, 4>& d,
                           Move& m, double& velocity, double& accel);
  /// The same under Marlin/RRF rules (minimum feedrates, per-axis limits); returns the speed
  /// SLOWDOWN allows (M205 B), +inf when it does not apply.
  double marlin_move_limits(const std::array<double, 4>& d, Move& m, double& velocity, double& accel);
  void set_junction_limit(Move& m);
  void note_forced_flush(std::uint64_t line, const char* what);
  void apply_limits(const gcode::LimitsCommand& cmd);
  /// Recomputes the cached values that depend on lim_ (after a limits command).
  void update_derived_limits();

  PlannerOptions opt_;
  Planner::Limits lim_{};
  PlannerDiagnostics diag_;
  RampShape ramps_;
  Timeline timeline_;
  MoveQueue queue_;
  KlipperLookahead lookahead_;
  MarlinBuffer buffer_;
  // Constants of the machine used on every move (set once in the constructor).
  bool klipper_ = true;
  bool classic_jerk_ = false;
  bool slowdown_ = false;  // Marlin: SLOWDOWN applies (min_segment_time may become > 0)
  double z_velocity_mm_s_ = 0, z_accel_mm_s2_ = 0;
  // The kinematics' own checks (Klipper check_move beyond the Z limit and the axis ranges:
  // delta, deltesian, polar, rotary delta): one flag on the hot path.
  bool special_kin_ = false;
  bool kin_limits_ = false;  // the kinematics' limit_move runs (special, or its own speed limits)
  bool no_extruder_ = false;  // Klipper printer.cfg without [extruder]: a move that extrudes stops
  /// The special kinematics' range check and speed limits (off the hot path).
  void special_range(const gcode::MoveRequest& r);
  void special_move_limits(const gcode::MoveRequest& r, const std::array<double, 4>& d,
                           const PlannedMove& o, double& velocity, double& accel);
  double filament_area_mm2_ = 0, extrude_only_velocity_mm_s_ = 0, extrude_only_accel_mm_s2_ = 0;
  double max_cross_section_mm2_ = 0, max_extrude_ratio_ = 0;
  // Derived from lim_, refreshed by update_derived_limits().
  double mcr_accel_mm_s2_ = 0, junction_deviation_mm_ = 0;
  // Range limits of X, Y, Z: Klipper position_min/max (checked, first error reported) or
  // Marlin soft endstops (clamped). Unset: none.
  std::array<std::optional<double>, 3> range_min_mm_{}, range_max_mm_{};
  bool range_reported_ = false;
  bool range_active_ = false;
  // Where the toolhead came to rest for the first dwell after the move numbered rest_moves_
  // (diag_.moves then): step_flush's "end of the last move".
  std::uint64_t rest_moves_ = 0;
  double rest_from_s_ = 0.0;
  /// Klipper's step-generation restart delay and what sets it.
  StepTiming step_timing_;
  /// The end of the last move (the print time unless dwells came after it).
  [[nodiscard]] double last_move_end_s() const;
  /// The rest step_flush waits for: the generator's restart `before` after the last move's end
  /// and `after` more (the delays before and after a change).
  void wait_step_restart(double before, double after, std::uint64_t line);          // any limit set (and the firmware uses it)
  gcode::MoveRequest range_scratch_;   // a clamped copy of the current move (Marlin)
  /// Klipper: posts the first out-of-range move. Marlin: clamps into `scratch` and returns it.
  const gcode::MoveRequest& apply_range(const gcode::MoveRequest& r, gcode::MoveRequest& scratch);
  std::uint64_t warned_overextrusion_ = 0;
  std::uint64_t next_seq_ = 1;
  // Last: large and read little per move (a few scalars), so the hot state above stays
  // compact whatever the machine description holds.
  machine::Machine machine_;
  /// The machine's own limits (lim_ before any G-code changed it): the ceiling of
  /// FileLimits::cap.
  Planner::Limits machine_lim_{};
  std::unique_ptr<const kinematics::Kinematics> kinematics_;
};

}  // namespace amctl::plan::detail
