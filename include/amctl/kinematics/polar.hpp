#pragma once
// Polar (klippy/kinematics/polar.py, chelper/kin_polar.c; read at 84104bbb, nothing copied):
// the bed turns (stepper_bed: the angle atan2(y, x), in radians), the arm sets the radius
// (stepper_arm: sqrt(x^2 + y^2)), Z is cartesian.
#include <array>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct Polar {
  static constexpr std::string_view kName = "polar";
  /// [printer] max_angular_velocity (unset or 0 = no limit): moves passing within d of the
  /// bed's centre at speed v are slowed when v / d exceeds it [rad/s].
  std::optional<double> max_angular_velocity_rad_s;
  Rails rails;  ///< arm (position_max: the reach; position_endstop), z, z1, ...
  bool operator==(const Polar&) const = default;

  /// printer.cfg: [stepper_bed] (radians), [stepper_arm], [stepper_z] (required) and the
  /// extra Z steppers.
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  /// [printer] max_angular_velocity (> 0); stepper_arm's position_endstop, position_max
  /// (required) and position_min (0); the Z rail.
  [[nodiscard]] static Polar from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options();
  /// TOML: printer.max_angular_velocity; the rails' ranges of stepper_arm and stepper_z.
  [[nodiscard]] static std::span<const ParamKey<Polar>> keys();
  /// The bed turns: its drive train is in radians.
  [[nodiscard]] static Unit unit_of(std::string_view key) { return key == "bed" ? Unit::rad : Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): stepper_bed, stepper_arm.
  [[nodiscard]] bool owns_stepper(std::string_view key) const { return key == "bed" || key == "arm"; }
  static Rail* rail(Polar& k, std::string_view key, bool create) {
    if (key == "bed") return nullptr;
    return detail::rail_of(k.rails, key, create);
  }
};

struct PolarGeometry {
  double max_radius_mm = 0.0;  ///< stepper_arm position_max: Klipper's limit_xy2 = max^2
  std::array<double, 2> z_limits_mm{};
  double arm_endstop_mm = 0.0;
};
[[nodiscard]] PolarGeometry polar_geometry(const Polar& p);

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const Polar& p, const Context& ctx);

}  // namespace amctl::kinematics
