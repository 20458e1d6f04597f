#pragma once
// Limits that a Machine leaves implicit ("0 = same as max_velocity", unset extruder limits)
// resolved the way Klipper resolves them at config time (klippy/kinematics/*.py,
// klippy/kinematics/extruder.py, klippy/toolhead.py).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "amctl/machine/machine.hpp"

namespace amctl::machine {

/// Klipper max_z_velocity (defaults to max_velocity).
inline double effective_max_z_velocity_mm_s(const Machine& m) {
  return m.max_z_velocity_mm_s > 0.0 ? m.max_z_velocity_mm_s : m.max_velocity_mm_s;
}
/// Klipper max_z_accel (defaults to max_accel).
inline double effective_max_z_accel_mm_s2(const Machine& m) {
  return m.max_z_accel_mm_s2 > 0.0 ? m.max_z_accel_mm_s2 : m.max_accel_mm_s2;
}
/// Filament cross-section pi (D/2)^2. [mm^2]
inline double filament_area_mm2(const Machine& m) {
  const double r = 0.5 * m.extruder.filament_diameter_mm;
  return std::numbers::pi * r * r;
}
/// Klipper max_extrude_cross_section (default 4 d_nozzle^2). [mm^2]
inline double effective_max_extrude_cross_section_mm2(const Machine& m) {
  const double d = m.extruder.nozzle_diameter_mm;
  return m.extruder.max_extrude_cross_section_mm2.value_or(4.0 * d * d);
}
/// Klipper max_extrude_only_velocity: default max_velocity * 4 d_nozzle^2 / filament_area.
inline double effective_max_extrude_only_velocity_mm_s(const Machine& m) {
  if (m.extruder.max_extrude_only_velocity_mm_s) return *m.extruder.max_extrude_only_velocity_mm_s;
  const double d = m.extruder.nozzle_diameter_mm;
  return m.max_velocity_mm_s * 4.0 * d * d / filament_area_mm2(m);
}
/// Klipper max_extrude_only_accel: default max_accel * 4 d_nozzle^2 / filament_area.
inline double effective_max_extrude_only_accel_mm_s2(const Machine& m) {
  if (m.extruder.max_extrude_only_accel_mm_s2) return *m.extruder.max_extrude_only_accel_mm_s2;
  const double d = m.extruder.nozzle_diameter_mm;
  return m.max_accel_mm_s2 * 4.0 * d * d / filament_area_mm2(m);
}
/// Klipper's junction deviation for an acceleration `accel_mm_s2`:
/// scv^2 (sqrt(2) - 1) / accel (toolhead.py _calc_junction_deviation). [mm]
inline double klipper_junction_deviation_mm(double square_corner_velocity_mm_s,
                                            double accel_mm_s2) {
  return square_corner_velocity_mm_s * square_corner_velocity_mm_s * (std::numbers::sqrt2 - 1.0) /
         accel_mm_s2;
}

/// Klipper's mapping of the legacy max_accel_to_decel (config) / ACCEL_TO_DECEL
/// (SET_VELOCITY_LIMIT) onto minimum_cruise_ratio: 1 - min(1, accel_to_decel / accel)
/// (klippy/toolhead.py, commit 0105aa33). `accel_mm_s2` is the accel in effect (the command's
/// ACCEL if it gives one).
inline double minimum_cruise_ratio_from_accel_to_decel(double accel_to_decel_mm_s2,
                                                       double accel_mm_s2) {
  return 1.0 - std::min(1.0, accel_to_decel_mm_s2 / accel_mm_s2);
}

}  // namespace amctl::machine
