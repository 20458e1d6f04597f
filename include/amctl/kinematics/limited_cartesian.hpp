#pragma once
// Limited cartesian (Kalico's limited_cartesian, formerly Danger Klipper's): the cartesian
// kinematics' motors, ranges and homing, with per-axis velocity and acceleration limits in
// check_move. A move along the unit direction r is limited to
//     v <= min(max_x_velocity / |r_x|, max_y_velocity / |r_y|, max_z_velocity / |r_z|)
//     a <= min(max_x_accel / |r_x|, max_y_accel / |r_y|, max_z_accel / |r_z|)
// (an axis that does not move sets no limit), and with scale_xy_accel the X and Y accel
// limits are scaled by the toolhead's accel in force (M204, SET_VELOCITY_LIMIT) over
// hypot(max_x_accel, max_y_accel). klippy/kinematics/limited_cartesian.py of Kalico (read at
// f2532ee3, nothing copied); docs/machine.md "Kinematics".
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

/// Kalico's per-axis toolhead limits ([printer] max_x_velocity, max_y_velocity, max_x_accel,
/// max_y_accel, scale_xy_accel); unset: the kinematics' default. Z keeps the toolhead's
/// max_z_velocity and max_z_accel.
struct AxisLimits {
  std::optional<double> max_x_velocity_mm_s, max_y_velocity_mm_s;
  std::optional<double> max_x_accel_mm_s2, max_y_accel_mm_s2;
  bool scale_xy_accel = false;
  bool operator==(const AxisLimits&) const = default;
};

struct LimitedCartesian {
  static constexpr std::string_view kName = "limited_cartesian";
  /// Defaults: velocities sqrt(2) max_velocity (also Z's when max_z_velocity is unset),
  /// accels max_accel; a value given may not exceed max_velocity (max_accel).
  AxisLimits limits;
  Rails rails;
  std::optional<DualCarriage> dual_carriage;
  bool operator==(const LimitedCartesian&) const = default;

  /// printer.cfg: cartesian's sections ([stepper_x], [stepper_y], [stepper_z]...,
  /// [dual_carriage]).
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  /// [printer] max_x_velocity, max_y_velocity (> 0, <= max_velocity), max_x_accel,
  /// max_y_accel (> 0, <= max_accel), scale_xy_accel; the rails.
  [[nodiscard]] static LimitedCartesian from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options();
  /// TOML: printer.max_x_velocity ... printer.scale_xy_accel, the rails, [dual_carriage].
  [[nodiscard]] static std::span<const ParamKey<LimitedCartesian>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  [[nodiscard]] bool owns_stepper(std::string_view) const { return false; }
  static Rail* rail(LimitedCartesian& k, std::string_view key, bool create) {
    return detail::rail_of(k.rails, key, create);
  }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const LimitedCartesian& p,
                                                          const Context& ctx);

}  // namespace amctl::kinematics
