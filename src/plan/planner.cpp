// Planner (the public facade) and PlannerCore's per-move work: a request becomes a queued
// move under the firmware's limits, its junction limit is set by the machine's policy, and
// the strategy (Klipper look-ahead or Marlin block buffer) decides when moves leave.
#include "amctl/plan/planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "junction.hpp"
#include "planner_core.hpp"

namespace amctl::plan {
namespace detail {
namespace {
constexpr double kExtrudeOnlyAccel = 99999999.9;  // Klipper: extrude-only moves are not accel-limited here
}  // namespace

[[gnu::always_inline]] inline void PlannerCore::klipper_move_limits(const gcode::MoveRequest& r,
                                                                    const std::array<double, 4>& d, Move& m,
                                                                    double& velocity, double& accel) {
  const PlannedMove& o = m.out;
  const double move_d = o.distance_mm;
  auto limit_speed = [&](double speed, double a) {
    velocity = std::min(velocity, speed);
    accel = std::min(accel, a);
  };
  // Kinematic Z limit (cartesian and corexy alike): the axis limit scaled to the move.
  if (m.kinematic && d[2] != 0.0) {
    const double z_ratio = move_d / std::fabs(d[2]);
    limit_speed(z_velocity_mm_s_ * z_ratio, z_accel_mm_s2_ * z_ratio);
  }
  // Delta, deltesian, polar, rotary delta: their own limits (one flag on the hot path).
  if (kin_limits_ && m.kinematic) [[unlikely]] special_move_limits(r, d, o, velocity, accel);
  // Extruder: extrude-only and retraction moves get the extruder's own limits.
  if (d[3] != 0.0) {
    const auto& ex = machine_.extruder;
    const double axis_r = o.axes_r[3];
    if ((d[0] == 0.0 && d[1] == 0.0) || axis_r < 0.0) {
      if (std::fabs(d[3]) > ex.max_extrude_only_distance_mm && diag_.warnings.size() < 20) {
        diag_.warnings.push_back(fmt::format(
            "line {}: extrude-only move of {:.3f} mm exceeds max_extrude_only_distance {:.3f} mm "
            "(Klipper would stop with an error)", r.line, std::fabs(d[3]), ex.max_extrude_only_distance_mm));
      }
      const double inv = 1.0 / std::fabs(axis_r);
      limit_speed(extrude_only_velocity_mm_s_ * inv, extrude_only_accel_mm_s2_ * inv);
    } else if (axis_r > max_extrude_ratio_ && d[3] > ex.nozzle_diameter_mm * max_extrude_ratio_ &&
               warned_overextrusion_++ < 5) {
      diag_.warnings.push_back(fmt::format(
          "line {}: extrusion cross-section {:.3f} mm^2 exceeds max_extrude_cross_section "
          "{:.3f} mm^2 (Klipper would stop with an error)", r.line, axis_r * filament_area_mm2_,
          max_cross_section_mm2_));
    }
  }
}

void PlannerCore::special_move_limits(const gcode::MoveRequest& r, const std::array<double, 4>& d,
                                      const PlannedMove& o, double& velocity, double& accel) {
  kinematics::MoveGeometry g;
  g.start = o.start_mm;
  g.end = r.end_mm;
  g.d = d;
  g.distance_mm = o.distance_mm;
  g.toolhead_velocity_mm_s = lim_.max_velocity_mm_s;
  g.toolhead_accel_mm_s2 = lim_.accel_mm_s2;
  kinematics_->limit_move(g, velocity, accel);
}

inline double PlannerCore::marlin_move_limits(const std::array<double, 4>& d, Move& m, double& velocity,
                                              double& accel) {
  const PlannedMove& o = m.out;
  // Minimum feedrates, then SLOWDOWN (it reads the feedrate before the axis limits, as
  // Marlin's _populate_block does), then per-axis feedrate and acceleration limits.
  const double min_v = d[3] != 0.0 ? lim_.min_feedrate_mm_s : lim_.min_travel_feedrate_mm_s;
  velocity = std::max(velocity, min_v);
  double slowed_v = std::numeric_limits<double>::infinity();
  if (slowdown_ && lim_.min_segment_time_s > 0.0) {
    slowed_v = buffer_.min_segment_time_speed(o.distance_mm, velocity, lim_.min_segment_time_s);
  }
  for (std::size_t i = 0; i < 4; ++i) {
    const double u = std::fabs(o.axes_r[i]);
    if (u == 0.0) continue;
    velocity = std::min(velocity, lim_.max_feedrate_mm_s[i] / u);
    accel = std::min(accel, lim_.max_axis_accel_mm_s2[i] / u);
  }
  return slowed_v;
}

const gcode::MoveRequest& PlannerCore::apply_range(const gcode::MoveRequest& r,
                                                   gcode::MoveRequest& /*scratch*/) {
  if (klipper_) {
    if (no_extruder_ && r.end_mm[3] != r.start_mm[3]) {
      // toolhead.py: without [extruder] the toolhead's extruder is a dummy whose check_move
      // refuses any move with an E component; the print stops there.
      throw Error(SourceLocation{"", r.line, 0},
                  fmt::format("move extrudes (E {:.5f} to {:.5f}) on a printer without [extruder]; "
                              "Klipper stops the print here with \"Extrude when no extruder "
                              "present: {:.3f} {:.3f} {:.3f} [{:.3f}]\", expected a move without E "
                              "or a printer.cfg with an [extruder] section",
                              r.start_mm[3], r.end_mm[3], r.end_mm[0], r.end_mm[1], r.end_mm[2],
                              r.end_mm[3]));
    }
    // klippy/kinematics/cartesian.py check_move: an axis that moves must end inside
    // [position_min, position_max], else "Move out of range" and the print stops.
    if (range_reported_) return r;
    if (special_kin_) {
      special_range(r);
      return r;
    }
    for (std::size_t i = 0; i < 3; ++i) {
      if (!range_min_mm_[i] || r.end_mm[i] == r.start_mm[i]) continue;
      const double p = r.end_mm[i];
      if (p < *range_min_mm_[i] || p > *range_max_mm_[i]) {
        RangeError e;
        e.line = r.line;
        e.axis = "xyz"[i];
        e.position_mm = p;
        e.limit_mm = p < *range_min_mm_[i] ? *range_min_mm_[i] : *range_max_mm_[i];
        range_reported_ = true;
        post(PendingEvent::make_range_error(e));  // fires when the moves before it have run
        return r;
      }
    }
    return r;
  }
  // Marlin: the interpreter clamps targets into the soft endstops (apply_motion_limits,
  // InterpreterOptions::soft_min_mm) and marks the moves it clamped.
  if (r.clamped) ++diag_.clamped_moves;
  return r;
}

void PlannerCore::special_range(const gcode::MoveRequest& r) {
  kinematics::MoveGeometry g;
  g.start = r.start_mm;
  g.end = r.end_mm;
  if (const auto v = kinematics_->check_range(g)) {
    RangeError e;
    e.line = r.line;
    e.axis = v->axis;
    e.position_mm = v->position_mm;
    e.limit_mm = v->limit_mm;
    range_reported_ = true;
    post(PendingEvent::make_range_error(e));  // fires when the moves before it have run
  }
}

void PlannerCore::on_move(const gcode::MoveRequest& request) {
  if (!(request.speed_mm_s > 0.0) || !std::isfinite(request.speed_mm_s)) {
    throw Error(SourceLocation{"", request.line, 0},
                fmt::format("move speed must be > 0 mm/s, got {}", request.speed_mm_s));
  }
  // Machines without limits (every preset) skip the check: the hot path stays as it was.
  const gcode::MoveRequest& r = range_active_ ? apply_range(request, range_scratch_) : request;
  // Built in place at the back of the queue (no copy of the large Move); dropped again if
  // it turns out to be zero-length.
  Move& m = queue_.emplace_back();  // a recycled slot: every field is assigned below
  PlannedMove& o = m.out;
  // Fields that are only set on some paths start from their defaults. The start time, the
  // three speeds and the three durations are all written by the timeline before the move
  // leaves the planner, and safe_v by the classic-jerk junction before anything reads it.
  o.extrude_only = false;
  m.max_start_v2 = 0.0;
  m.max_mcr_start_v2 = 0.0;
  m.junction_deviation = 0.0;
  m.kinematic = true;
  m.reach_from_v2 = m.mcr_reach_from_v2 = -1.0;  // no S-curve reach memo from an old move
  m.planned_start_v2 = -1.0;                       // not yet planned (Marlin buffer)
  o.start_mm = r.start_mm;
  o.line = r.line;
  o.layer = r.layer;
  o.feature = r.feature;
  o.profile = machine_.profile;
  o.jerk_mm_s3 = ramps_.jerk_limited() ? machine_.max_jerk_mm_s3 : 0.0;
  std::array<double, 4> d{};
  for (std::size_t i = 0; i < 4; ++i) d[i] = r.end_mm[i] - r.start_mm[i];
  double move_d = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  const bool klipper = klipper_;
  double velocity = r.speed_mm_s;
  double accel = 0.0;
  if (move_d < 1e-9) {
    // Extrude-only move (retract, unretract, prime).
    move_d = std::fabs(d[3]);
    if (move_d == 0.0) {
      ++diag_.zero_length_moves;
      queue_.pop_back();
      return;
    }
    o.extrude_only = true;
    m.kinematic = false;
    o.axes_r = {0.0, 0.0, 0.0, d[3] / move_d};
    accel = klipper ? kExtrudeOnlyAccel : lim_.retract_accel_mm_s2;
    ++diag_.extrude_only_moves;
  } else {
    for (std::size_t i = 0; i < 4; ++i) o.axes_r[i] = d[i] / move_d;
    if (klipper) {
      velocity = std::min(velocity, lim_.max_velocity_mm_s);
      accel = lim_.accel_mm_s2;
    } else {
      accel = d[3] != 0.0 ? lim_.accel_mm_s2 : lim_.travel_accel_mm_s2;
    }
  }
  o.distance_mm = move_d;
  if (klipper) {
    klipper_move_limits(r, d, m, velocity, accel);
    if (velocity < r.speed_mm_s) ++diag_.speed_limited_moves;
  } else {
    const double slowed_v = marlin_move_limits(d, m, velocity, accel);
    if (velocity < r.speed_mm_s) ++diag_.speed_limited_moves;
    if (slowed_v < velocity) {
      // Counted apart: not a request above a machine limit, but the buffer refilling.
      ++diag_.min_segment_time_slowdowns;
      velocity = slowed_v;
    }
  }

  m.max_cruise_v2 = velocity * velocity;
  m.min_move_t = move_d / velocity;
  o.accel_mm_s2 = accel;
  m.delta_v2 = 2.0 * move_d * accel;
  if (klipper) {
    m.mcr_delta_v2 = std::min(2.0 * move_d * mcr_accel_mm_s2_, m.delta_v2);
    m.mcr_accel = std::min(mcr_accel_mm_s2_, accel);
    m.junction_deviation = junction_deviation_mm_;
  } else {
    m.mcr_delta_v2 = m.delta_v2;
    m.mcr_accel = accel;
  }
  m.nominal_v = velocity;
  if (classic_jerk_) {
    for (std::size_t i = 0; i < 4; ++i) m.axis_v[i] = velocity * o.axes_r[i];
  }
  m.seq = next_seq_++;
  ++diag_.moves;
  set_junction_limit(m);
  if (klipper) {
    if (lookahead_.after_queued(queue_, opt_.max_queue)) {
      note_forced_flush(m.out.line, "moves queued without a flush");
      lookahead_.flush(queue_, true);
    }
  } else if (buffer_.after_queued(queue_, opt_.max_queue)) {
    // "Unlimited" look-ahead still runs in bounded memory: the oldest block starts once
    // max_queue blocks are queued (a look-ahead of 65 535 moves changes no real print).
    note_forced_flush(m.out.line, "blocks queued in an unlimited buffer");
    buffer_.start_oldest(queue_);
  }
}

[[gnu::always_inline]] inline void PlannerCore::set_junction_limit(Move& m) {
  if (queue_.size() > 1) {
    const Move& prev = queue_[queue_.size() - 2];
    switch (machine_.junction) {
      case machine::JunctionPolicy::square_corner_velocity:
        junction_square_corner_velocity(m, prev, ramps_, machine_.extruder.instantaneous_corner_velocity_mm_s);
        break;
      case machine::JunctionPolicy::junction_deviation:
        junction_marlin_deviation(m, prev, lim_.junction_deviation_mm, lim_.max_axis_accel_mm_s2,
                                  opt_.minimum_planner_speed_mm_s);
        break;
      case machine::JunctionPolicy::classic_jerk: junction_classic_jerk(m, prev, lim_.jerk_mm_s); break;
    }
  } else if (classic_jerk_) {
    // From rest Marlin may jump straight to the "safe speed" that the jerk allows.
    junction_classic_jerk(m, Move{}, lim_.jerk_mm_s);
  }
}

void PlannerCore::full_stop() {
  if (!queue_.empty()) {
    ++diag_.full_stops;
    if (klipper_) {
      lookahead_.flush(queue_, false);
    } else {
      buffer_.drain(queue_);
    }
  }
  lookahead_.after_full_stop();
  buffer_.after_full_stop();
  timeline_.release_all_events();
}

void PlannerCore::note_forced_flush(std::uint64_t line, const char* what) {
  if (diag_.forced_flushes++ == 0 && diag_.warnings.size() < 20) {
    diag_.warnings.push_back(fmt::format(
        "line {}: {} {}: planned early to keep memory bounded; the time here may differ "
        "slightly from the firmware's (further cases are counted, not listed)",
        line, opt_.max_queue, what));
  }
}

void PlannerCore::post(PendingEvent&& e) {
  if (!queue_.empty() && timeline_.events().size() >= opt_.max_queue) {
    // Tens of thousands of fan/heater/progress/layer commands behind one queued move: no
    // real file does this, and holding them all would make memory grow with the file. Stop
    // the motion (as an M400 would), which fires them, and count it.
    note_forced_flush(e.line, "commands waiting behind one move (stopped as M400 would)");
    full_stop();
  }
  if (queue_.empty()) {
    timeline_.fire_now(e);
    return;
  }
  timeline_.events().push(std::move(e), queue_.back().seq);
}

void PlannerCore::on_dwell(double duration_s, std::uint64_t line) {
  full_stop();
  if (diag_.moves != rest_moves_) {  // the first dwell since a move: where the rest began
    rest_moves_ = diag_.moves;
    rest_from_s_ = timeline_.print_time_s();
  }
  timeline_.dwell(duration_s, line);
}

double PlannerCore::last_move_end_s() const {
  // Tracked by on_dwell, so plain moves pay nothing for this.
  return diag_.moves == rest_moves_ ? rest_from_s_ : timeline_.print_time_s();
}

void PlannerCore::wait_step_restart(double before, double after, std::uint64_t line) {
  // motion_queuing.py: after flush_all_steps the step generator has run to the last move's
  // end + kin_flush_delay (the one in force when the moves were queued), and
  // toolhead._calc_print_time restarts no earlier than that + kin_flush_delay (the one in
  // force now). The wait is at rest, counted with the dwells.
  if (!klipper_ || diag_.moves == 0) return;
  const double wait_s = last_move_end_s() + before + after - timeline_.print_time_s();
  if (wait_s > 0.0) on_dwell(wait_s, line);
}

void PlannerCore::step_flush(std::uint64_t line) {
  full_stop();
  const double d = step_timing_.flush_delay_s();
  wait_step_restart(d, d, line);
}

void PlannerCore::on_step_tuning(const gcode::StepTuningCommand& cmd) {
  if (!klipper_) return;
  if (!cmd.flush) {
    // extruder.py: a new ADVANCE alone (same smoothing) is a look-ahead callback: it applies
    // from the end of the moves queued before it, with no stop.
    step_timing_.apply(cmd);
    post(PendingEvent::make_step_tuning(cmd));
    return;
  }
  // input_shaper.py / extruder.py: flush_step_generation, then the new values, whose scan
  // windows set the restart delay (check_step_generation_scan_windows).
  full_stop();
  const double before = step_timing_.flush_delay_s();
  step_timing_.apply(cmd);
  const double after = step_timing_.flush_delay_s();
  const double from_s = diag_.moves == 0 ? timeline_.print_time_s() : last_move_end_s() + before;
  timeline_.fire_at(PendingEvent::make_step_tuning(cmd), from_s);
  wait_step_restart(before, after, cmd.line);
}

void PlannerCore::on_axis_range(int axis, double min_mm, double max_mm) {
  if (!klipper_ || axis < 0 || axis > 2) return;
  range_min_mm_[static_cast<std::size_t>(axis)] = min_mm;
  range_max_mm_[static_cast<std::size_t>(axis)] = max_mm;
  range_active_ = true;
}

void PlannerCore::on_heater(const gcode::HeaterCommand& cmd) {
  // A waiting heater command stops motion first (Klipper flushes look-ahead, then waits).
  if (cmd.wait) full_stop();
  post(PendingEvent::make_heater(cmd));
}

}  // namespace detail

Planner::Planner(const machine::Machine& machine, PlanSink& sink, PlannerOptions options)
    : core_(std::make_unique<detail::PlannerCore>(machine, sink, options)) {}
Planner::~Planner() = default;

void Planner::on_move(const gcode::MoveRequest& move) { core_->on_move(move); }
void Planner::on_dwell(double duration_s, std::uint64_t line) { core_->on_dwell(duration_s, line); }
void Planner::on_wait_moves(std::uint64_t /*line*/) { core_->full_stop(); }
void Planner::on_step_flush(std::uint64_t line) { core_->step_flush(line); }
void Planner::on_step_tuning(const gcode::StepTuningCommand& cmd) { core_->on_step_tuning(cmd); }
void Planner::on_set_position(const std::array<double, 4>& /*pos_mm*/, std::uint64_t /*line*/) {
  core_->full_stop();
}
void Planner::on_limits(const gcode::LimitsCommand& cmd) { core_->on_limits(cmd); }
void Planner::on_axis_range(int axis, double min_mm, double max_mm, std::uint64_t /*line*/) {
  core_->on_axis_range(axis, min_mm, max_mm);
}
void Planner::on_heater(const gcode::HeaterCommand& cmd) { core_->on_heater(cmd); }
void Planner::on_fan(double fraction, std::uint64_t line) {
  core_->post(detail::PendingEvent::make_fan(fraction, line));
}
void Planner::on_input_shaping(const gcode::InputShapingCommand& cmd) {
  core_->post(detail::PendingEvent::make_input_shaping(cmd));
}
void Planner::on_progress(const gcode::ProgressMarker& m) {
  core_->post(detail::PendingEvent::make_progress(m));
}
void Planner::on_layer_change(std::int32_t layer, std::uint64_t line) {
  core_->post(detail::PendingEvent::make_layer(layer, line));
}
void Planner::on_untimed(std::string_view name, std::uint64_t line) {
  core_->full_stop();
  core_->post(detail::PendingEvent::make_untimed(name, line));
}
void Planner::finish() { core_->full_stop(); }

double Planner::print_time_s() const { return core_->print_time_s(); }
const PlannerDiagnostics& Planner::diagnostics() const { return core_->diagnostics(); }
const Planner::Limits& Planner::limits() const { return core_->limits(); }

}  // namespace amctl::plan
