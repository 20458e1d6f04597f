#pragma once
// Internal to the planner: the junction policies, one function per firmware rule. Each
// sets m.max_start_v2 (and m.max_mcr_start_v2 for the smoothed pass) from the previous move
// and the limits in force; derivations in docs/planner.md ("Junction speed", "Marlin and
// RepRapFirmware"). Header-only so that the per-move call inlines into on_move.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "move_queue.hpp"
#include "ramp_shape.hpp"

namespace amctl::plan::detail {

/// Klipper (toolhead.py): the junction deviation circle derived from square_corner_velocity
/// (m.junction_deviation, per move), the centripetal limit over half of either move, the
/// extruder's instantaneous_corner_velocity, and what the previous move can reach.
[[gnu::always_inline]] inline void junction_square_corner_velocity(
    Move& m, const Move& prev, const RampShape& ramps, double instantaneous_corner_velocity_mm_s) {
  if (!m.kinematic || !prev.kinematic) return;
  double max_start_v2 =
      std::min({m.max_cruise_v2, prev.max_cruise_v2, ramps.reach_v2(prev.max_start_v2, prev)});
  // Extruder: limit the instantaneous change of extrusion rate.
  const double diff_r = m.out.axes_r[3] - prev.out.axes_r[3];
  if (diff_r != 0.0) {
    const double v = instantaneous_corner_velocity_mm_s / std::fabs(diff_r);
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
    // Nested two-operand mins: the same value as std::min({...}), without its array and loop.
    max_start_v2 = std::min(std::min(std::min(max_start_v2, move_jd_v2), std::min(prev_jd_v2, move_cent_v2)),
                            prev_cent_v2);
  }
  m.max_start_v2 = max_start_v2;
  m.max_mcr_start_v2 = std::min(max_start_v2, ramps.reach_mcr_v2(prev.max_mcr_start_v2, prev));
}

/// Marlin 2 junction deviation: directions normalised over X, Y, Z and E together, the
/// acceleration limited along the junction vector, JD_HANDLE_SMALL_SEGMENTS below 1 mm, and
/// MINIMUM_PLANNER_SPEED for a full reversal.
inline void junction_marlin_deviation(Move& m, const Move& prev, double junction_deviation_mm,
                                      const std::array<double, 4>& max_axis_accel_mm_s2,
                                      double minimum_planner_speed_mm_s) {
  const auto& u = m.out.axes_r;
  const auto& pu = prev.out.axes_r;
  auto norm4 = [](const std::array<double, 4>& v) {
    return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
  };
  const double nu = norm4(u), npu = norm4(pu);
  if (nu == 0.0 || npu == 0.0) return;
  double cos_theta = 0.0;
  for (std::size_t i = 0; i < 4; ++i) cos_theta -= (u[i] / nu) * (pu[i] / npu);
  double v2 = 0.0;
  const double min_v = minimum_planner_speed_mm_s;
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
        if (c > 0.0) a = std::min(a, max_axis_accel_mm_s2[i] / c);
      }
    }
    const double sin_half = std::sqrt(0.5 * (1.0 - cos_theta));
    v2 = a * junction_deviation_mm * sin_half / (1.0 - sin_half);
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

/// Marlin's classic jerk: each axis' speed may jump by at most jerk[axis] at a junction; a
/// move from rest (prev with nominal_v == 0) may start at the "safe speed" the jerk allows.
/// Sets m.safe_v, which the next junction reads.
inline void junction_classic_jerk(Move& m, const Move& prev, const std::array<double, 4>& jerk) {
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

}  // namespace amctl::plan::detail
