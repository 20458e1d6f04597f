#include "amctl/plan/planner.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/plan/velocity_profile.hpp"

namespace amctl::plan {
namespace {

using machine::Firmware;
using machine::JunctionPolicy;

constexpr double kLazyFlushTime_s = 0.150;  // Klipper LOOKAHEAD_FLUSH_TIME
constexpr double kFullFlushTime_s = 1.0;    // Klipper BUFFER_TIME_HIGH after a full flush
constexpr double kExtrudeOnlyAccel = 99999999.9;

}  // namespace

Planner::Planner(const machine::Machine& m, PlanSink& sink, PlannerOptions options)
    : machine_(m), sink_(sink), opt_(options) {
  require_positive("printer.max_velocity", m.max_velocity_mm_s);
  require_positive("printer.max_accel", m.max_accel_mm_s2);
  require_non_negative("printer.square_corner_velocity", m.square_corner_velocity_mm_s);
  if (!(m.minimum_cruise_ratio >= 0.0 && m.minimum_cruise_ratio < 1.0)) {
    throw Error(fmt::format("printer.minimum_cruise_ratio must be in [0, 1), got {}",
                            m.minimum_cruise_ratio));
  }
  require_non_negative("printer.max_z_velocity", m.max_z_velocity_mm_s);
  require_non_negative("printer.max_z_accel", m.max_z_accel_mm_s2);
  require_positive("extruder.nozzle_diameter", m.extruder.nozzle_diameter_mm);
  require_positive("extruder.filament_diameter", m.extruder.filament_diameter_mm);
  require_non_negative("extruder.instantaneous_corner_velocity",
                       m.extruder.instantaneous_corner_velocity_mm_s);
  for (std::size_t i = 0; i < 4; ++i) {
    require_positive("marlin.max_feedrate", m.max_feedrate_mm_s[i]);
    require_positive("marlin.max_accel", m.max_axis_accel_mm_s2[i]);
    require_non_negative("marlin.jerk", m.jerk_mm_s[i]);
  }
  require_positive("marlin.print_accel", m.print_accel_mm_s2);
  require_positive("marlin.travel_accel", m.travel_accel_mm_s2);
  require_positive("marlin.retract_accel", m.retract_accel_mm_s2);
  require_non_negative("marlin.junction_deviation", m.junction_deviation_mm);
  jerk_limited_ = m.profile == machine::VelocityProfile::scurve7;
  classic_jerk_ = m.junction == JunctionPolicy::classic_jerk;
  if (jerk_limited_) require_positive("printer.max_jerk", m.max_jerk_mm_s3);

  const bool klipper = m.firmware == Firmware::klipper;
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
  junction_flush_s_ = kFullFlushTime_s;
  if (m.block_buffer_size < 0) {
    throw Error(fmt::format("marlin.block_buffer_size must be >= 0, got {}", m.block_buffer_size));
  }
  buffer_size_ = opt_.block_buffer_size.value_or(static_cast<std::size_t>(m.block_buffer_size));

  // Per-move constants of the machine, computed once with the same expressions on_move()
  // used to evaluate for every move (so the doubles are the same).
  klipper_ = klipper;
  z_velocity_mm_s_ = m.max_z_velocity_mm_s > 0 ? m.max_z_velocity_mm_s : m.max_velocity_mm_s;
  z_accel_mm_s2_ = m.max_z_accel_mm_s2 > 0 ? m.max_z_accel_mm_s2 : m.max_accel_mm_s2;
  const auto& ex = m.extruder;
  filament_area_mm2_ = std::numbers::pi * 0.25 * ex.filament_diameter_mm * ex.filament_diameter_mm;
  const double def_ratio = 4.0 * ex.nozzle_diameter_mm * ex.nozzle_diameter_mm / filament_area_mm2_;
  extrude_only_velocity_mm_s_ = ex.max_extrude_only_velocity_mm_s.value_or(m.max_velocity_mm_s * def_ratio);
  extrude_only_accel_mm_s2_ = ex.max_extrude_only_accel_mm_s2.value_or(m.max_accel_mm_s2 * def_ratio);
  max_cross_section_mm2_ = ex.max_extrude_cross_section_mm2.value_or(4.0 * ex.nozzle_diameter_mm * ex.nozzle_diameter_mm);
  max_extrude_ratio_ = max_cross_section_mm2_ / filament_area_mm2_;
  update_derived_limits();
}

void Planner::update_derived_limits() {
  mcr_accel_mm_s2_ = mcr_pseudo_accel();
  junction_deviation_mm_ = klipper_junction_deviation();
}

double Planner::klipper_junction_deviation() const {
  const double scv = lim_.square_corner_velocity_mm_s;
  return scv * scv * (std::numbers::sqrt2 - 1.0) / lim_.accel_mm_s2;
}

inline double Planner::reach_v2(double from_v2, const Move& m) const {
  if (!jerk_limited_) return from_v2 + m.delta_v2;  // v^2 = v0^2 + 2 a D
  if (from_v2 == m.reach_from_v2) return m.reach_to_v2;
  const double v = max_reachable_speed_mm_s(VelocityProfile::scurve7, std::sqrt(from_v2),
                                            m.out.distance_mm, m.out.accel_mm_s2, m.out.jerk_mm_s3);
  m.reach_from_v2 = from_v2;
  m.reach_to_v2 = v * v;
  return v * v;
}

inline double Planner::reach_mcr_v2(double from_v2, const Move& m) const {
  if (!jerk_limited_) return from_v2 + m.mcr_delta_v2;
  if (from_v2 == m.mcr_reach_from_v2) return m.mcr_reach_to_v2;
  const double v = max_reachable_speed_mm_s(VelocityProfile::scurve7, std::sqrt(from_v2),
                                            m.out.distance_mm, m.mcr_accel, m.out.jerk_mm_s3);
  m.mcr_reach_from_v2 = from_v2;
  m.mcr_reach_to_v2 = v * v;
  return v * v;
}

inline double Planner::scurve_peak_v2(double start_v2, double end_v2, const Move& m,
                                      double accel, double cap_v2) const {
  // As min(peak, cap) for the trapezoid: a cap below an end speed flattens the move at the cap
  // (emit() then clips the end speeds to it).
  if (cap_v2 <= std::max(start_v2, end_v2)) return cap_v2;
  const double v = peak_speed_mm_s(VelocityProfile::scurve7, std::sqrt(start_v2), std::sqrt(end_v2),
                                   m.out.distance_mm, accel, m.out.jerk_mm_s3, std::sqrt(cap_v2));
  return v * v;
}

double Planner::mcr_pseudo_accel() const {
  if (lim_.accel_to_decel_mm_s2) return std::min(*lim_.accel_to_decel_mm_s2, lim_.accel_mm_s2);
  return lim_.accel_mm_s2 * (1.0 - lim_.minimum_cruise_ratio);
}

void Planner::on_limits(const gcode::LimitsCommand& c) {
  apply_limits(c);
  update_derived_limits();
}

void Planner::apply_limits(const gcode::LimitsCommand& c) {
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

void Planner::on_move(const gcode::MoveRequest& r) {
  if (!(r.speed_mm_s > 0.0) || !std::isfinite(r.speed_mm_s)) {
    throw Error(SourceLocation{"", r.line, 0},
                fmt::format("move speed must be > 0 mm/s, got {}", r.speed_mm_s));
  }
  // Built in place at the back of the queue (no copy of the large Move); dropped again if
  // it turns out to be zero-length.
  Move& m = queue_.emplace_back();  // a recycled slot: every field is assigned below
  PlannedMove& o = m.out;
  // Fields that are only set on some paths (or only by emit()) start from their defaults.
  o.start_time_s = 0.0;
  o.start_v_mm_s = o.cruise_v_mm_s = o.end_v_mm_s = 0.0;
  o.jerk_mm_s3 = 0.0;
  o.accel_t_s = o.cruise_t_s = o.decel_t_s = 0.0;
  o.extrude_only = false;
  m.max_start_v2 = 0.0;
  m.max_mcr_start_v2 = 0.0;
  m.junction_deviation = 0.0;
  m.kinematic = true;
  m.safe_v = 0.0;
  m.reach_from_v2 = m.mcr_reach_from_v2 = -1.0;  // no S-curve reach memo from an old move
  m.planned_start_v2 = -1.0;                       // not yet planned (Marlin buffer)
  o.start_mm = r.start_mm;
  o.line = r.line;
  o.layer = r.layer;
  o.feature = r.feature;
  o.profile = machine_.profile;
  o.jerk_mm_s3 = jerk_limited_ ? machine_.max_jerk_mm_s3 : 0.0;
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

  auto limit_speed = [&](double speed, double a) {
    velocity = std::min(velocity, speed);
    accel = std::min(accel, a);
  };

  if (klipper) {
    // Kinematic Z limit (cartesian and corexy alike): the axis limit scaled to the move.
    if (m.kinematic && d[2] != 0.0) {
      const double z_ratio = move_d / std::fabs(d[2]);
      limit_speed(z_velocity_mm_s_ * z_ratio, z_accel_mm_s2_ * z_ratio);
    }
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
  } else {
    // Marlin / RRF: minimum feedrates, per-axis feedrate and acceleration limits.
    const double min_v = d[3] != 0.0 ? lim_.min_feedrate_mm_s : lim_.min_travel_feedrate_mm_s;
    velocity = std::max(velocity, min_v);
    for (std::size_t i = 0; i < 4; ++i) {
      const double u = std::fabs(o.axes_r[i]);
      if (u == 0.0) continue;
      velocity = std::min(velocity, lim_.max_feedrate_mm_s[i] / u);
      accel = std::min(accel, lim_.max_axis_accel_mm_s2[i] / u);
    }
  }
  if (velocity < r.speed_mm_s) ++diag_.speed_limited_moves;

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
  add_queued_move();
}

[[gnu::always_inline]] inline void Planner::junction_klipper(Move& m, const Move& prev) const {
  if (!m.kinematic || !prev.kinematic) return;
  double max_start_v2 = std::min({m.max_cruise_v2, prev.max_cruise_v2, reach_v2(prev.max_start_v2, prev)});
  // Extruder: limit the instantaneous change of extrusion rate.
  const double diff_r = m.out.axes_r[3] - prev.out.axes_r[3];
  if (diff_r != 0.0) {
    const double v = machine_.extruder.instantaneous_corner_velocity_mm_s / std::fabs(diff_r);
    max_start_v2 = std::min(max_start_v2, v * v);
  }
  const auto& u = m.out.axes_r;
  const auto& pu = prev.out.axes_r;
  const double cos_theta = -(u[0] * pu[0] + u[1] * pu[1] + u[2] * pu[2]);
  const double sin_half = std::sqrt(std::max(0.5 * (1.0 - cos_theta), 0.0));
  const double cos_half = std::sqrt(std::max(0.5 * (1.0 + cos_theta), 0.0));
  const double one_minus_sin_half = 1.0 - sin_half;
  if (one_minus_sin_half > 0.0 && cos_half > 0.0) {
    // Circle tangent to both moves whose deviation from the corner is jd:
    //   R = jd sin(theta/2) / (1 - sin(theta/2)),  v^2 = a R.
    const double r_jd = sin_half / one_minus_sin_half;
    const double move_jd_v2 = r_jd * m.junction_deviation * m.out.accel_mm_s2;
    const double prev_jd_v2 = r_jd * prev.junction_deviation * prev.out.accel_mm_s2;
    // The circle may not extend past half of either move: v^2 = a (d/2) tan(theta/2).
    const double quarter_tan_half = 0.25 * sin_half / cos_half;
    const double move_cent_v2 = m.delta_v2 * quarter_tan_half;
    const double prev_cent_v2 = prev.delta_v2 * quarter_tan_half;
    max_start_v2 = std::min({max_start_v2, move_jd_v2, prev_jd_v2, move_cent_v2, prev_cent_v2});
  }
  m.max_start_v2 = max_start_v2;
  m.max_mcr_start_v2 = std::min(max_start_v2, reach_mcr_v2(prev.max_mcr_start_v2, prev));
}

void Planner::junction_marlin_jd(Move& m, const Move& prev) const {
  const auto& u = m.out.axes_r;
  const auto& pu = prev.out.axes_r;
  // Marlin normalises over X, Y, Z and E together.
  auto norm4 = [](const std::array<double, 4>& v) {
    return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
  };
  const double nu = norm4(u), npu = norm4(pu);
  if (nu == 0.0 || npu == 0.0) return;
  double cos_theta = 0.0;
  for (std::size_t i = 0; i < 4; ++i) cos_theta -= (u[i] / nu) * (pu[i] / npu);
  double v2 = 0.0;
  const double min_v = opt_.minimum_planner_speed_mm_s;
  if (cos_theta > 0.999999) {
    v2 = min_v * min_v;  // full reversal
  } else {
    cos_theta = std::max(cos_theta, -0.999999);
    std::array<double, 4> ju{};
    for (std::size_t i = 0; i < 4; ++i) ju[i] = u[i] / nu - pu[i] / npu;
    const double nj = norm4(ju);
    double a = m.out.accel_mm_s2;
    if (nj > 0.0) {
      for (std::size_t i = 0; i < 4; ++i) {
        const double c = std::fabs(ju[i] / nj);
        if (c > 0.0) a = std::min(a, lim_.max_axis_accel_mm_s2[i] / c);
      }
    }
    const double sin_half = std::sqrt(0.5 * (1.0 - cos_theta));
    v2 = a * lim_.junction_deviation_mm * sin_half / (1.0 - sin_half);
    // Short segments approximate a curve of radius d / theta: v^2 = a d / theta.
    if (m.out.distance_mm < 1.0) {
      const double theta = std::acos(-cos_theta);
      if (theta > 0.0) v2 = std::min(v2, m.out.distance_mm * a / theta);
    }
  }
  v2 = std::min({v2, m.max_cruise_v2, prev.max_cruise_v2});
  m.max_start_v2 = v2;
  m.max_mcr_start_v2 = v2;
}

void Planner::junction_classic_jerk(Move& m, const Move& prev) {
  // Marlin's classic jerk: each axis' speed may jump by at most jerk[axis] at a junction.
  const auto& jerk = lim_.jerk_mm_s;
  double safe = m.nominal_v;
  bool limited = false;
  for (std::size_t i = 0; i < 4; ++i) {
    const double j = std::fabs(m.axis_v[i]);
    if (j > jerk[i]) {
      if (limited) {
        const double mj = m.nominal_v * jerk[i];
        if (j * safe > mj) safe = mj / j;
      } else {
        limited = true;
        safe *= jerk[i] / j;
      }
    }
  }
  m.safe_v = safe;
  double vmax = 0.0;
  if (prev.nominal_v > 0.0) {
    double smaller = 1.0;
    if (m.nominal_v < prev.nominal_v) {
      vmax = m.nominal_v;
      smaller = vmax / prev.nominal_v;
    } else {
      vmax = prev.nominal_v;
    }
    double factor = 1.0;
    for (std::size_t i = 0; i < 4; ++i) {
      const double v_exit = prev.axis_v[i] * smaller * factor;
      const double v_entry = m.axis_v[i] * factor;
      double j;
      if (v_exit > v_entry) {
        j = (v_entry > 0 || v_exit < 0) ? (v_exit - v_entry) : std::max(v_exit, -v_entry);
      } else {
        j = (v_entry < 0 || v_exit > 0) ? (v_entry - v_exit) : std::max(-v_exit, v_entry);
      }
      if (j > jerk[i]) factor *= jerk[i] / j;
    }
    vmax *= factor;
    const double threshold = vmax * 0.99;
    if (prev.safe_v > threshold && safe > threshold) vmax = safe;
  } else {
    vmax = safe;
  }
  const double prev_cap = prev.nominal_v > 0.0 ? prev.max_cruise_v2 : m.max_cruise_v2;
  const double v2 = std::min({vmax * vmax, m.max_cruise_v2, prev_cap});
  m.max_start_v2 = v2;
  m.max_mcr_start_v2 = v2;
}

[[gnu::always_inline]] inline void Planner::add_queued_move() {
  const bool klipper = machine_.firmware == Firmware::klipper;
  Move& m = queue_.back();
  if (queue_.size() > 1) {
    Move& prev = queue_[queue_.size() - 2];
    switch (machine_.junction) {
      case JunctionPolicy::square_corner_velocity: junction_klipper(m, prev); break;
      case JunctionPolicy::junction_deviation: junction_marlin_jd(m, prev); break;
      case JunctionPolicy::classic_jerk: junction_classic_jerk(m, prev); break;
    }
  } else if (machine_.junction == JunctionPolicy::classic_jerk) {
    // From rest Marlin may jump straight to the "safe speed" that the jerk allows.
    junction_classic_jerk(m, Move{});
  }
  if (klipper) {
    if (queue_.size() == 1) return;
    junction_flush_s_ -= queue_.back().min_move_t;
    if (junction_flush_s_ <= 0.0) {
      flush(true);
    } else if (queue_.size() >= opt_.max_queue) {
      note_forced_flush(m.out.line, "moves queued without a flush");
      flush(true);
    }
  } else if (buffer_size_ > 1 && queue_.size() >= buffer_size_ - 1) {
    // Marlin's ring buffer of BLOCK_BUFFER_SIZE slots holds one less block, the executing
    // one included: the oldest block must start once that many are queued.
    flush_marlin_head();
  } else if (buffer_size_ <= 1 && queue_.size() >= opt_.max_queue) {
    // "Unlimited" look-ahead still runs in bounded memory: the oldest block starts once
    // max_queue blocks are queued (a look-ahead of 65 535 moves changes no real print).
    note_forced_flush(m.out.line, "blocks queued in an unlimited buffer");
    flush_marlin_head();
  }
}

void Planner::emit(Move& m, double start_v2, double cruise_v2, double end_v2) {
  PlannedMove& o = m.out;
  if (jerk_limited_) {
    // Jerk-limited ramps (velocity_profile.hpp): durations from the S-curve, the cruise takes
    // what the two ramps leave of the distance. The look-ahead chose the speeds with the
    // S-curve's own reach and peak, so the ramps must fit.
    const double j = o.jerk_mm_s3, a = o.accel_mm_s2, D = o.distance_mm;
    o.start_v_mm_s = std::sqrt(start_v2);
    o.cruise_v_mm_s = std::sqrt(cruise_v2);
    o.end_v_mm_s = std::sqrt(end_v2);
    o.accel_t_s = ramp_duration_s(VelocityProfile::scurve7, o.start_v_mm_s, o.cruise_v_mm_s, a, j);
    o.decel_t_s = ramp_duration_s(VelocityProfile::scurve7, o.cruise_v_mm_s, o.end_v_mm_s, a, j);
    const double ramps_d = 0.5 * (o.start_v_mm_s + o.cruise_v_mm_s) * o.accel_t_s +
                           0.5 * (o.cruise_v_mm_s + o.end_v_mm_s) * o.decel_t_s;
    AMCTL_CHECK(ramps_d <= D * (1.0 + 1e-9) + 1e-12,
                fmt::format("line {}: S-curve ramps {} -> {} -> {} mm/s need {} mm, move is {} mm",
                            o.line, o.start_v_mm_s, o.cruise_v_mm_s, o.end_v_mm_s, ramps_d, D));
    const double cruise_d = D - ramps_d;
    o.cruise_t_s = cruise_d > 0.0 && o.cruise_v_mm_s > 0.0 ? cruise_d / o.cruise_v_mm_s : 0.0;
    o.start_time_s = print_time_s_;
    print_time_s_ += o.accel_t_s + o.cruise_t_s + o.decel_t_s;
    sink_.on_planned(o);
    while (!pending_.empty() && pending_.front().after_seq <= m.seq) {
      fire(pending_.front());
      pending_.pop_front();
    }
    return;
  }
  const double a = o.accel_mm_s2;
  // 0.5 / a changes only with the limits: reuse the last quotient (the same double).
  if (a != emit_a_) {
    emit_a_ = a;
    emit_half_inv_a_ = 0.5 / a;
  }
  const double half_inv_a = emit_half_inv_a_;
  const double accel_d = (cruise_v2 - start_v2) * half_inv_a;
  const double decel_d = (cruise_v2 - end_v2) * half_inv_a;
  const double cruise_d = std::max(0.0, o.distance_mm - accel_d - decel_d);
  // Most moves start at the speed the previous one ended at, and a cruising move has all
  // three speeds equal: each square root is taken once (sqrt is exact, so nothing changes).
  const double start_v = start_v2 == emit_last_v2_ ? emit_last_v_ : std::sqrt(start_v2);
  const double cruise_v = cruise_v2 == start_v2 ? start_v : std::sqrt(cruise_v2);
  const double end_v = end_v2 == cruise_v2 ? cruise_v : std::sqrt(end_v2);
  emit_last_v2_ = end_v2;
  emit_last_v_ = end_v;
  o.start_v_mm_s = start_v;
  o.cruise_v_mm_s = cruise_v;
  o.end_v_mm_s = end_v;
  // Time is distance over mean speed (well conditioned when speeds are close).
  o.accel_t_s = accel_d > 0 ? accel_d / ((o.start_v_mm_s + o.cruise_v_mm_s) * 0.5) : 0.0;
  o.cruise_t_s = cruise_d > 0 ? cruise_d / o.cruise_v_mm_s : 0.0;
  o.decel_t_s = decel_d > 0 ? decel_d / ((o.end_v_mm_s + o.cruise_v_mm_s) * 0.5) : 0.0;
  o.start_time_s = print_time_s_;
  print_time_s_ += o.accel_t_s + o.cruise_t_s + o.decel_t_s;
  sink_.on_planned(o);
  while (!pending_.empty() && pending_.front().after_seq <= m.seq) {
    fire(pending_.front());
    pending_.pop_front();
  }
}

void Planner::flush(bool lazy) {
  junction_flush_s_ = kLazyFlushTime_s;
  const std::size_t n = queue_.size();
  if (n == 0) return;
  bool update_flush_count = lazy;
  std::size_t flush_count = n;
  scratch_.resize(n);
  // Backward pass: the fastest start speed each move may have, assuming the machine comes
  // to rest after the last queued move; the smoothed (mcr) pass picks the cruise peaks.
  double next_start_v2 = 0.0, next_mcr_start_v2 = 0.0, peak_cruise_v2 = 0.0;
  std::size_t pending = 0;
  for (std::size_t k = n; k-- > 0;) {
    const Move& mv = queue_[k];
    const double reachable_start_v2 = reach_v2(next_start_v2, mv);
    const double start_v2 = std::min(mv.max_start_v2, reachable_start_v2);
    const double reach_mcr_start_v2 = reach_mcr_v2(next_mcr_start_v2, mv);
    const double mcr_start_v2 = std::min(mv.max_mcr_start_v2, reach_mcr_start_v2);
    ++pending;
    JunctionInfo& ji = scratch_[k];
    ji.has_cruise = false;
    if (mcr_start_v2 < reach_mcr_start_v2) {
      // This move may accelerate: either it can both accelerate and decelerate, or it is a
      // full acceleration followed by a full deceleration.
      if (reach_mcr_v2(mcr_start_v2, mv) > next_mcr_start_v2 || pending > 1) {
        if (update_flush_count && peak_cruise_v2 != 0.0) {
          flush_count = k + pending;
          update_flush_count = false;
        }
        // Peak of the smoothed pass; the S-curve's is below the trapezoid's (3.1), its cap here.
        peak_cruise_v2 = jerk_limited_
                             ? scurve_peak_v2(mcr_start_v2, next_mcr_start_v2, mv, mv.mcr_accel,
                                              (mcr_start_v2 + next_mcr_start_v2) * 0.5 +
                                                  mv.out.distance_mm * mv.mcr_accel)
                             : (mcr_start_v2 + reach_mcr_start_v2) * 0.5;
      }
      ji.cruise_v2 = jerk_limited_
                         ? scurve_peak_v2(start_v2, next_start_v2, mv, mv.out.accel_mm_s2,
                                          std::min(mv.max_cruise_v2, peak_cruise_v2))
                         : std::min({(start_v2 + reachable_start_v2) * 0.5, mv.max_cruise_v2, peak_cruise_v2});
      ji.has_cruise = true;
      pending = 0;
    }
    ji.start_v2 = start_v2;
    ji.next_start_v2 = next_start_v2;
    next_start_v2 = start_v2;
    next_mcr_start_v2 = mcr_start_v2;
  }
  if (update_flush_count || flush_count == 0) return;
  // Forward pass: moves that cannot accelerate keep the cruise speed of the move before.
  double prev_cruise_v2 = scratch_[0].start_v2;
  for (std::size_t k = 0; k < flush_count; ++k) {
    const JunctionInfo& ji = scratch_[k];
    const double cruise_v2 = ji.has_cruise ? ji.cruise_v2 : std::min(prev_cruise_v2, ji.start_v2);
    emit(queue_[k], std::min(ji.start_v2, cruise_v2), cruise_v2, std::min(ji.next_start_v2, cruise_v2));
    prev_cruise_v2 = cruise_v2;
  }
  queue_.pop_front(flush_count);
}

void Planner::flush_marlin_head() {
  // Plan the whole buffer as if the machine stopped after its last block, then execute the
  // oldest block. Its exit speed becomes the fixed entry speed of the next block.
  // The backward pass keeps each block's result (planned_start_v2) and stops at the first
  // block whose start comes out as before: every older block has the same inputs as in the
  // previous pass (its own limit and that start), so it would repeat its previous result too.
  // This is Marlin's own shortcut (it stops at blocks already planned optimally), exact here.
  // The head is always recomputed: its entry limit was just replaced by the previous exit.
  const std::size_t n = queue_.size();
  double next_start_v2 = 0.0;  // ends as the planned start of block 1 (0 if none)
  for (std::size_t k = n; k-- > 1;) {
    Move& mv = queue_[k];
    const double start_v2 = std::min(mv.max_start_v2, reach_v2(next_start_v2, mv));
    if (start_v2 == mv.planned_start_v2) {
      next_start_v2 = queue_[1].planned_start_v2;
      break;
    }
    mv.planned_start_v2 = start_v2;
    next_start_v2 = start_v2;
  }
  Move& head = queue_.front();
  const double s2 = std::min(head.max_start_v2, reach_v2(next_start_v2, head));
  const double e2 = std::min(next_start_v2, reach_v2(s2, head));
  // Peak of the trapezoid (seed 000 eq. 3.1) or of the S-curve, capped by the nominal speed.
  const double cruise_v2 =
      jerk_limited_ ? std::max({scurve_peak_v2(s2, e2, head, head.out.accel_mm_s2, head.max_cruise_v2), s2, e2})
                    : std::max({std::min(head.max_cruise_v2, (s2 + e2 + head.delta_v2) * 0.5), s2, e2});
  emit(head, s2, cruise_v2, e2);
  queue_.pop_front();
  if (!queue_.empty()) {
    queue_.front().max_start_v2 = e2;
    queue_.front().max_mcr_start_v2 = e2;
  }
}

void Planner::full_stop() {
  if (queue_.empty()) {
    junction_flush_s_ = kFullFlushTime_s;
    while (!pending_.empty()) {
      fire(pending_.front());
      pending_.pop_front();
    }
    return;
  }
  ++diag_.full_stops;
  if (machine_.firmware == Firmware::klipper) {
    flush(false);
  } else {
    while (!queue_.empty()) flush_marlin_head();
  }
  junction_flush_s_ = kFullFlushTime_s;
  while (!pending_.empty()) {
    fire(pending_.front());
    pending_.pop_front();
  }
}

void Planner::note_forced_flush(std::uint64_t line, const char* what) {
  if (diag_.forced_flushes++ == 0 && diag_.warnings.size() < 20) {
    diag_.warnings.push_back(fmt::format(
        "line {}: {} {}: planned early to keep memory bounded; the time here may differ "
        "slightly from the firmware's (further cases are counted, not listed)",
        line, opt_.max_queue, what));
  }
}

void Planner::post(PendingEvent&& e) {
  if (!queue_.empty() && pending_.size() >= opt_.max_queue) {
    // Tens of thousands of fan/heater/progress/layer commands behind one queued move: no
    // real file does this, and holding them all would make memory grow with the file. Stop
    // the motion (as an M400 would), which fires them, and count it.
    note_forced_flush(e.line, "commands waiting behind one move (stopped as M400 would)");
    full_stop();
  }
  if (queue_.empty()) {
    fire(e);
    return;
  }
  e.after_seq = queue_.back().seq;
  pending_.push_back(std::move(e));
}

void Planner::fire(const PendingEvent& e) {
  switch (e.kind) {
    case PendingEvent::Kind::heater: sink_.on_heater(print_time_s_, e.heater); break;
    case PendingEvent::Kind::fan: sink_.on_fan(print_time_s_, e.fan, e.line); break;
    case PendingEvent::Kind::progress: sink_.on_progress(print_time_s_, e.progress); break;
    case PendingEvent::Kind::layer: sink_.on_layer_change(print_time_s_, e.layer, e.line); break;
    case PendingEvent::Kind::untimed: sink_.on_untimed(print_time_s_, e.name, e.line); break;
  }
}

void Planner::on_dwell(double duration_s, std::uint64_t line) {
  full_stop();
  sink_.on_dwell(print_time_s_, duration_s, line);
  print_time_s_ += std::max(0.0, duration_s);
}

void Planner::on_wait_moves(std::uint64_t line) {
  (void)line;
  full_stop();
}

void Planner::on_set_position(const std::array<double, 4>& pos_mm, std::uint64_t line) {
  (void)pos_mm;
  (void)line;
  full_stop();
}

void Planner::on_heater(const gcode::HeaterCommand& cmd) {
  // A waiting heater command stops motion first (Klipper flushes look-ahead, then waits).
  if (cmd.wait) full_stop();
  PendingEvent e;
  e.kind = PendingEvent::Kind::heater;
  e.heater = cmd;
  e.line = cmd.line;
  post(std::move(e));
}

void Planner::on_fan(double fraction, std::uint64_t line) {
  PendingEvent e;
  e.kind = PendingEvent::Kind::fan;
  e.fan = fraction;
  e.line = line;
  post(std::move(e));
}

void Planner::on_progress(const gcode::ProgressMarker& m) {
  PendingEvent e;
  e.kind = PendingEvent::Kind::progress;
  e.progress = m;
  e.line = m.line;
  post(std::move(e));
}

void Planner::on_layer_change(std::int32_t layer, std::uint64_t line) {
  PendingEvent e;
  e.kind = PendingEvent::Kind::layer;
  e.layer = layer;
  e.line = line;
  post(std::move(e));
}

void Planner::on_untimed(std::string_view name, std::uint64_t line) {
  full_stop();
  PendingEvent e;
  e.kind = PendingEvent::Kind::untimed;
  e.name = std::string(name);
  e.line = line;
  post(std::move(e));
}

void Planner::finish() { full_stop(); }

}  // namespace amctl::plan
