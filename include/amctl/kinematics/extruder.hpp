#pragma once
// The extruder as Klipper's kinematics/extruder.py and chelper/kin_extruder.c have it (read at
// 84104bbb, nothing copied): the [extruder] limits of check_move (extrude-only moves, the
// largest cross-section), the motor (its position follows E), and pressure advance.
//
// Pressure advance (kin_extruder.c): the motor runs ahead of the nominal filament position by
// pressure_advance times the nominal extrusion speed, on moves that extrude while moving in X
// or Y, and the result is averaged over pressure_advance_smooth_time with a triangular weight:
//     e_pa(t) = e(t) + pa v_e(t)   (pa = 0 on retracts and extrude-only moves),
//     e_motor(t) = integral e_pa(x) (T/2 - |t - x|) dx over [t - T/2, t + T/2] / (T/2)^2.
// With pressure_advance = 0 Klipper smooths nothing (the motor follows E).
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/keys.hpp"
#include "amctl/kinematics/kinematics.hpp"
#include "amctl/kinematics/klipper_config.hpp"

namespace amctl::kinematics {

/// Klipper [extruder] semantics. A printer.cfg without [extruder] has none (`present` false):
/// a move that extrudes is then an error, as in Klipper ("Extrude when no extruder present").
struct Extruder {
  bool present = true;
  double nozzle_diameter_mm = 0.4;
  double filament_diameter_mm = 1.75;
  /// Extrude-only (and retract) move limits. Unset = Klipper's defaults derived from the
  /// toolhead limits times (4 d_nozzle^2) / filament area.
  std::optional<double> max_extrude_only_velocity_mm_s;
  std::optional<double> max_extrude_only_accel_mm_s2;
  double max_extrude_only_distance_mm = 50.0;
  /// Max instantaneous change of extruder speed at a junction.
  double instantaneous_corner_velocity_mm_s = 1.0;
  /// Unset = 4 * nozzle_diameter^2 (Klipper's default).
  std::optional<double> max_extrude_cross_section_mm2;
  /// Klipper pressure_advance [s] (mm of filament per mm/s of extrusion; >= 0) and
  /// pressure_advance_smooth_time [s] (> 0, at most 0.2); SET_PRESSURE_ADVANCE changes both.
  double pressure_advance_s = 0.0;
  double pressure_advance_smooth_time_s = 0.040;
  bool operator==(const Extruder&) const = default;

  /// Reads [extruder] with Klipper's checks; `present` false without the section.
  [[nodiscard]] static Extruder from_klipper(const KlipperConfig& cfg);
  /// TOML: the [extruder] table.
  [[nodiscard]] static std::span<const ParamKey<Extruder>> keys();
  /// The checks beyond each key's bound: smooth time at most Klipper's 0.2 s.
  void check() const;
};

/// Klipper's smooth_time limit (extruder.py: pressure_advance_smooth_time maxval) [s].
inline constexpr double kMaxPressureAdvanceSmoothTimeS = 0.200;

/// What the planner applies to a move with E (Klipper PrinterExtruder.check_move).
struct ExtruderLimits {
  double filament_area_mm2 = 0.0;
  double extrude_only_velocity_mm_s = 0.0;
  double extrude_only_accel_mm_s2 = 0.0;
  double max_cross_section_mm2 = 0.0;
  double max_extrude_ratio = 0.0;  ///< max cross-section / filament area
};
[[nodiscard]] ExtruderLimits extruder_limits(const Extruder& e, const Toolhead& th);

/// The extruder motor: "extruder", drive-train key "e", position = E.
[[nodiscard]] Motor extruder_motor();

}  // namespace amctl::kinematics
