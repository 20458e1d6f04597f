#pragma once
// Polar (klippy/kinematics/polar.py, chelper/kin_polar.c; read at 84104bbb, nothing copied):
// the bed turns (stepper_bed: the angle atan2(y, x), in radians), the arm sets the radius
// (stepper_arm: sqrt(x^2 + y^2)), Z is cartesian.
#include <array>
#include <memory>
#include <optional>
#include <string_view>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct Polar {
  static constexpr std::string_view kName = "polar";
  /// [printer] max_angular_velocity (unset or 0 = no limit): moves passing within d of the
  /// bed's centre at speed v are slowed when v / d exceeds it [rad/s].
  std::optional<double> max_angular_velocity_rad_s;
  Rails rails;  ///< arm (position_max: the reach; position_endstop), z, z1, ...
  bool operator==(const Polar&) const = default;
};

struct PolarGeometry {
  double max_radius_mm = 0.0;  ///< stepper_arm position_max: Klipper's limit_xy2 = max^2
  std::array<double, 2> z_limits_mm{};
  double arm_endstop_mm = 0.0;
};
[[nodiscard]] PolarGeometry polar_geometry(const Polar& p);

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const Polar& p, const Context& ctx);

}  // namespace amctl::kinematics
