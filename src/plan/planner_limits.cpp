// The planner's limits: the machine description checked and turned into the initial limits,
// and the G-code commands that change them (M201/M203/M204/M205/M566, SET_VELOCITY_LIMIT)
// with each firmware's semantics.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/machine/loader.hpp"
#include "planner_core.hpp"

namespace amctl::plan::detail {
namespace {

using machine::Firmware;

/// The options, once the machine is checked by the one validation of the machine module (every
/// bound of the key table and the cross-key rules, the same that loading a TOML or printer.cfg
/// applies): a Machine built in code is held to the same rules as one read from a file. The
/// first member initialised does it, before any other member reads the machine (machine_
/// itself sits last in PlannerCore, off the hot fields).
PlannerOptions validated_options(const machine::Machine& m, const PlannerOptions& options) {
  machine::validate(m);
  return options;
}

std::size_t buffer_size_of(const machine::Machine& m, const PlannerOptions& opt) {
  return opt.block_buffer_size.value_or(static_cast<std::size_t>(m.block_buffer_size));
}

}  // namespace

PlannerCore::PlannerCore(const machine::Machine& m, PlanSink& sink, PlannerOptions options)
    : opt_(validated_options(m, options)),
      ramps_(m.profile == machine::VelocityProfile::scurve7),
      timeline_(sink, ramps_.jerk_limited()),
      lookahead_(ramps_, timeline_),
      buffer_(ramps_, timeline_, buffer_size_of(m, options)),
      step_timing_(m),
      machine_(m) {
  classic_jerk_ = m.junction == machine::JunctionPolicy::classic_jerk;
  const bool klipper = m.firmware == Firmware::klipper;
  slowdown_ = m.firmware == Firmware::marlin;  // SLOWDOWN is Marlin's (M205 B)
  lim_.max_velocity_mm_s = m.max_velocity_mm_s;
  lim_.accel_mm_s2 = klipper ? m.max_accel_mm_s2 : m.print_accel_mm_s2;
  lim_.travel_accel_mm_s2 = klipper ? m.max_accel_mm_s2 : m.travel_accel_mm_s2;
  lim_.retract_accel_mm_s2 = klipper ? m.max_accel_mm_s2 : m.retract_accel_mm_s2;
  lim_.square_corner_velocity_mm_s = m.square_corner_velocity_mm_s;
  lim_.minimum_cruise_ratio = m.minimum_cruise_ratio;
  lim_.max_feedrate_mm_s = m.max_feedrate_mm_s;
  lim_.max_axis_accel_mm_s2 = m.max_axis_accel_mm_s2;
  lim_.jerk_mm_s = m.jerk_mm_s;
  lim_.junction_deviation_mm = m.junction_deviation_mm;
  lim_.min_feedrate_mm_s = m.min_feedrate_mm_s;
  lim_.min_travel_feedrate_mm_s = m.min_travel_feedrate_mm_s;
  lim_.min_segment_time_s = m.min_segment_time_s;

  // Per-move constants of the machine, computed once with the same expressions on_move()
  // used to evaluate for every move (so the doubles are the same).
  klipper_ = klipper;
  // The kinematics' check_move (Klipper): Z limits and axis ranges applied inline, the rest
  // (delta, deltesian, polar, rotary delta) by the kinematics itself.
  kinematics_ = machine::make_kinematics(m);
  const kinematics::MoveRules rules = kinematics_->move_rules();
  if (klipper) {
    range_min_mm_ = rules.range_min_mm;
    range_max_mm_ = rules.range_max_mm;
  } else if (m.firmware == Firmware::marlin) {
    range_min_mm_ = m.soft_min_position_mm;
    range_max_mm_ = m.soft_max_position_mm;
  }
  for (std::size_t i = 0; i < 3; ++i) {
    range_active_ = range_active_ || range_min_mm_[i].has_value() || range_max_mm_[i].has_value();
  }
  z_velocity_mm_s_ = m.max_z_velocity_mm_s > 0 ? m.max_z_velocity_mm_s : m.max_velocity_mm_s;
  z_accel_mm_s2_ = m.max_z_accel_mm_s2 > 0 ? m.max_z_accel_mm_s2 : m.max_accel_mm_s2;
  if (klipper) {
    // No Z limit where the kinematics has none (infinite limits are no-ops).
    z_velocity_mm_s_ = rules.z_velocity_mm_s.value_or(std::numeric_limits<double>::infinity());
    z_accel_mm_s2_ = rules.z_accel_mm_s2.value_or(std::numeric_limits<double>::infinity());
    special_kin_ = rules.special;
    kin_limits_ = rules.special || rules.limits_speed;
    range_active_ = range_active_ || rules.special;
    // No [extruder]: Klipper's toolhead has a dummy extruder whose check_move refuses a move
    // that extrudes (checked with the ranges, off the hot path).
    no_extruder_ = !m.extruder.present;
    range_active_ = range_active_ || no_extruder_;
  }
  const auto& ex = m.extruder;
  filament_area_mm2_ = std::numbers::pi * 0.25 * ex.filament_diameter_mm * ex.filament_diameter_mm;
  const double def_ratio = 4.0 * ex.nozzle_diameter_mm * ex.nozzle_diameter_mm / filament_area_mm2_;
  extrude_only_velocity_mm_s_ = ex.max_extrude_only_velocity_mm_s.value_or(m.max_velocity_mm_s * def_ratio);
  extrude_only_accel_mm_s2_ = ex.max_extrude_only_accel_mm_s2.value_or(m.max_accel_mm_s2 * def_ratio);
  max_cross_section_mm2_ = ex.max_extrude_cross_section_mm2.value_or(4.0 * ex.nozzle_diameter_mm * ex.nozzle_diameter_mm);
  max_extrude_ratio_ = max_cross_section_mm2_ / filament_area_mm2_;
  update_derived_limits();
  machine_lim_ = lim_;
  diag_.file_limits.policy = opt_.file_limits;
}

void PlannerCore::update_derived_limits() {
  // Klipper's smoothed pass: accel_to_decel when given, else accel (1 - minimum_cruise_ratio).
  mcr_accel_mm_s2_ = lim_.accel_to_decel_mm_s2 ? std::min(*lim_.accel_to_decel_mm_s2, lim_.accel_mm_s2)
                                               : lim_.accel_mm_s2 * (1.0 - lim_.minimum_cruise_ratio);
  // Klipper's junction deviation from square_corner_velocity: jd = scv^2 (sqrt2 - 1) / accel.
  const double scv = lim_.square_corner_velocity_mm_s;
  junction_deviation_mm_ = scv * scv * (std::numbers::sqrt2 - 1.0) / lim_.accel_mm_s2;
}

void PlannerCore::on_limits(const gcode::LimitsCommand& c) {
  // Klipper acts on M204 and SET_VELOCITY_LIMIT only; Marlin and RepRapFirmware on the M-codes.
  const bool klipper = machine_.firmware == Firmware::klipper;
  const bool svl = c.source == gcode::LimitsCommand::Source::set_velocity_limit;
  const bool acts = klipper ? (svl || c.source == gcode::LimitsCommand::Source::m204) : !svl;
  tally_file_limits(c, acts, machine_.firmware == Firmware::reprap, diag_.file_limits);
  if (!acts) return;
  switch (opt_.file_limits) {
    case FileLimits::keep:
      apply_limits(c);
      break;
    case FileLimits::ignore:
      ++diag_.file_limits.ignored;
      return;
    case FileLimits::cap:
      apply_limits(c);
      if (cap_limits(lim_, machine_lim_)) ++diag_.file_limits.capped;
      break;
  }
  update_derived_limits();
}

void PlannerCore::apply_limits(const gcode::LimitsCommand& c) {
  using S = gcode::LimitsCommand::Source;
  const auto& p = c.params;
  const Firmware fw = machine_.firmware;
  if (c.source == S::set_velocity_limit) {
    // Klipper's own command; other firmwares do not know it, so it is ignored there.
    if (fw != Firmware::klipper) return;
    if (c.velocity) lim_.max_velocity_mm_s = *c.velocity;
    if (c.accel) lim_.accel_mm_s2 = *c.accel;
    if (c.square_corner_velocity) lim_.square_corner_velocity_mm_s = *c.square_corner_velocity;
    if (c.minimum_cruise_ratio) {
      lim_.minimum_cruise_ratio = *c.minimum_cruise_ratio;
      lim_.accel_to_decel_mm_s2.reset();
    }
    if (c.accel_to_decel) lim_.accel_to_decel_mm_s2 = *c.accel_to_decel;
    return;
  }
  if (fw == Firmware::klipper) {
    // Klipper implements only M204: accel from S, else min(P, T) (both required).
    if (c.source == S::m204) {
      double a = 0.0;
      if (p.has('S')) a = p.get('S');
      else if (p.has('P') && p.has('T')) a = std::min(p.get('P'), p.get('T'));
      if (a > 0.0) lim_.accel_mm_s2 = a;
    }
    return;
  }
  // Marlin / RepRapFirmware semantics. RRF's M203 and M566 are in mm/min.
  const double feed_scale = fw == Firmware::reprap ? 1.0 / 60.0 : 1.0;
  constexpr const char* kAxes = "XYZE";
  switch (c.source) {
    case S::m201:
      for (std::size_t a = 0; a < 4; ++a) {
        if (p.has(kAxes[a]) && p.get(kAxes[a]) > 0) lim_.max_axis_accel_mm_s2[a] = p.get(kAxes[a]);
      }
      break;
    case S::m203:
      for (std::size_t a = 0; a < 4; ++a) {
        if (p.has(kAxes[a]) && p.get(kAxes[a]) > 0) lim_.max_feedrate_mm_s[a] = p.get(kAxes[a]) * feed_scale;
      }
      break;
    case S::m204:
      if (p.has('S') && p.get('S') > 0) lim_.accel_mm_s2 = lim_.travel_accel_mm_s2 = p.get('S');
      if (p.has('P') && p.get('P') > 0) lim_.accel_mm_s2 = p.get('P');
      if (p.has('R') && p.get('R') > 0) lim_.retract_accel_mm_s2 = p.get('R');
      if (p.has('T') && p.get('T') > 0) lim_.travel_accel_mm_s2 = p.get('T');
      break;
    case S::m205:
      for (std::size_t a = 0; a < 4; ++a) {
        if (p.has(kAxes[a])) lim_.jerk_mm_s[a] = p.get(kAxes[a]);
      }
      if (p.has('J') && p.get('J') > 0) lim_.junction_deviation_mm = p.get('J');
      if (p.has('S')) lim_.min_feedrate_mm_s = p.get('S');
      if (p.has('T')) lim_.min_travel_feedrate_mm_s = p.get('T');
      // Marlin's M205 B: minimum segment time in microseconds (SLOWDOWN, see MarlinBuffer).
      if (fw == Firmware::marlin && p.has('B') && p.get('B') >= 0) lim_.min_segment_time_s = p.get('B') * 1e-6;
      break;
    case S::m566:
      for (std::size_t a = 0; a < 4; ++a) {
        if (p.has(kAxes[a])) lim_.jerk_mm_s[a] = p.get(kAxes[a]) / 60.0;
      }
      break;
    case S::set_velocity_limit:
      break;
  }
}

}  // namespace amctl::plan::detail
