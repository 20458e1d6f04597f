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
  if (special_kin_ && m.kinematic) [[unlikely]] special_move_limits(r, d, o, velocity, accel);
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
  auto limit_speed = [&](double speed, double a) {
    velocity = std::min(velocity, speed);
    accel = std::min(accel, a);
  };
  if (delta_) {
    // Linear delta: a move touching the outer zones (either end beyond the radius where a
    // tower moves 3x (6x) faster than the effector) runs at 1/2 (1/4) of the configured
    // limits. A deltesian measures |x| only and only for moves with X motion.
    const double sy = deltesian_ ? 0.0 : o.start_mm[1], ey = deltesian_ ? 0.0 : r.end_mm[1];
    const double ex = r.end_mm[0];
    const double extreme_xy2 = std::max(o.start_mm[0] * o.start_mm[0] + sy * sy, ex * ex + ey * ey);
    const bool applies = !deltesian_ || (d[0] != 0.0 && delta_slow_xy2_ > 0.0 && delta_very_slow_xy2_ > 0.0);
    if (applies && extreme_xy2 > delta_slow_xy2_) {
      const double f = extreme_xy2 > delta_very_slow_xy2_ ? 0.25 : 0.5;
      limit_speed(delta_velocity_mm_s_ * f, delta_accel_mm_s2_ * f);
    }
    return;
  }
  if (rotary_) {
    if (d[2] != 0.0) limit_speed(rotary_z_velocity_mm_s_, accel);
    return;
  }
  if (polar_ && (d[0] != 0.0 || d[1] != 0.0) && polar_v_rad_max_ > 0.0) {
    // polar.py: the segment's closest approach to the centre d; the bed turns at up to v / d.
    const double ax = o.start_mm[0], ay = o.start_mm[1], bx = r.end_mm[0], by = r.end_mm[1];
    const double ux = bx - ax, uy = by - ay;
    const double along = -(ux * ax + uy * ay);  // (b - a) . (0 - a)
    const double len2 = ux * ux + uy * uy;
    double dist = 0.0;
    if (along <= 0.0) dist = std::sqrt(ax * ax + ay * ay);
    else if (along >= len2) dist = std::sqrt(bx * bx + by * by);
    else dist = std::fabs(ux * ay - uy * ax) / std::sqrt(len2);
    if (dist == 0.0) return;  // through the centre: Klipper leaves it unlimited
    const double v_angular = velocity / dist;
    if (polar_v_rad_max_ < v_angular) {
      const double scale = polar_v_rad_max_ / v_angular;
      limit_speed(delta_velocity_mm_s_ * scale, delta_accel_mm_s2_ * scale);
    }
  }
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
    // klippy/kinematics/cartesian.py check_move: an axis that moves must end inside
    // [position_min, position_max], else "Move out of range" and the print stops.
    if (range_reported_) return r;
    if (deltesian_) {
      deltesian_range(r);
      return r;
    }
    if (rotary_) {
      rotary_range(r);
      return r;
    }
    if (polar_ && polar_range(r)) return r;
    if (delta_) {
      delta_range(r);
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

namespace {

// delta.py and rotary_delta.py check_move: a kinematic move must end inside the build volume:
// z in [min_z, max_z] and the radius within max_xy2, tapered above limit_z (G: DeltaGeometry
// or RotaryDeltaGeometry). A move to the home position (homing) is allowed.
template <class G>
std::optional<RangeError> tower_volume_error(const G& g, const gcode::MoveRequest& r) {
  const double dx = r.end_mm[0] - r.start_mm[0], dy = r.end_mm[1] - r.start_mm[1],
               dz = r.end_mm[2] - r.start_mm[2];
  if (std::sqrt(dx * dx + dy * dy + dz * dz) < 1e-9) return std::nullopt;
  const double x = r.end_mm[0], y = r.end_mm[1], z = r.end_mm[2];
  const double xy2 = x * x + y * y;
  const double limit_xy2 = g.limit_xy2_at(z);
  if (xy2 <= limit_xy2 && z <= g.max_z_mm && z >= g.min_z_mm) return std::nullopt;
  if (x == g.home_position_mm[0] && y == g.home_position_mm[1] && z >= g.min_z_mm &&
      z <= g.home_position_mm[2]) {
    return std::nullopt;
  }
  RangeError e;
  e.line = r.line;
  if (z > g.max_z_mm || z < g.min_z_mm) {
    e.axis = 'z';
    e.position_mm = z;
    e.limit_mm = z > g.max_z_mm ? g.max_z_mm : g.min_z_mm;
  } else {
    e.axis = 'r';
    e.position_mm = std::sqrt(xy2);
    e.limit_mm = std::sqrt(std::max(0.0, limit_xy2));
  }
  return e;
}

}  // namespace

void PlannerCore::delta_range(const gcode::MoveRequest& r) {
  if (const auto e = tower_volume_error(delta_geometry_, r)) {
    range_reported_ = true;
    post(PendingEvent::make_range_error(*e));
  }
}

bool PlannerCore::polar_range(const gcode::MoveRequest& r) {
  // polar.py check_move: every kinematic move must end within the arm's reach (Z is checked
  // like cartesian's, by the caller).
  const double dx = r.end_mm[0] - r.start_mm[0], dy = r.end_mm[1] - r.start_mm[1],
               dz = r.end_mm[2] - r.start_mm[2];
  if (std::sqrt(dx * dx + dy * dy + dz * dz) < 1e-9) return false;
  const double xy2 = r.end_mm[0] * r.end_mm[0] + r.end_mm[1] * r.end_mm[1];
  if (xy2 <= polar_max_r2_mm2_) return false;
  RangeError e;
  e.line = r.line;
  e.axis = 'r';
  e.position_mm = std::sqrt(xy2);
  e.limit_mm = std::sqrt(polar_max_r2_mm2_);
  range_reported_ = true;
  post(PendingEvent::make_range_error(e));
  return true;
}

void PlannerCore::rotary_range(const gcode::MoveRequest& r) {
  // rotary_delta.py check_move: as delta.py's, the radius tapered to max_z - z above limit_z.
  if (const auto e = tower_volume_error(rotary_geometry_, r)) {
    range_reported_ = true;
    post(PendingEvent::make_range_error(*e));
  }
}

void PlannerCore::deltesian_range(const gcode::MoveRequest& r) {
  // deltesian.py check_move: every moving axis must end inside its limits; above the top of
  // the volume the Z limit is the carriages' reach at that X; a move to (0, home_z) without Y
  // motion is homing and allowed.
  const machine::DeltesianGeometry& g = deltesian_geometry_;
  const double x = r.end_mm[0], z = r.end_mm[2];
  const bool homing = x == 0.0 && z == g.home_z_mm && r.end_mm[1] == r.start_mm[1];
  if (homing) return;
  auto limits = g.limits_mm;
  if (z > limits[2][1]) limits[2][1] = g.pillars_z_max(x);
  for (std::size_t i = 0; i < 3; ++i) {
    if (r.end_mm[i] == r.start_mm[i]) continue;
    const double p = r.end_mm[i];
    if (p < limits[i][0] || p > limits[i][1]) {
      RangeError e;
      e.line = r.line;
      e.axis = "xyz"[i];
      e.position_mm = p;
      e.limit_mm = p < limits[i][0] ? limits[i][0] : limits[i][1];
      range_reported_ = true;
      post(PendingEvent::make_range_error(e));
      return;
    }
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

void PlannerCore::step_flush(std::uint64_t line) {
  full_stop();
  // motion_queuing.py: after flush_all_steps the step generator has run to the last move's
  // end + kin_flush_delay, and toolhead._calc_print_time restarts no earlier than that +
  // kin_flush_delay again; kin_flush_delay is SDS_CHECK_TIME (1 ms) without pressure advance
  // or input shaping (their scan windows would lengthen it; not modelled). The wait is at
  // rest, counted with the dwells.
  // The end of the last move is the print time unless dwells came after it (tracked by
  // on_dwell, so plain moves pay nothing for this).
  if (!klipper_ || diag_.moves == 0) return;
  const double last_move_end_s = diag_.moves == rest_moves_ ? rest_from_s_ : timeline_.print_time_s();
  const double wait_s = last_move_end_s + 2.0 * kKlipperSdsCheckTime_s - timeline_.print_time_s();
  if (wait_s > 0.0) on_dwell(wait_s, line);
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
