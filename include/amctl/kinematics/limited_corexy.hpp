#pragma once
// Limited CoreXY (Kalico's limited_corexy): corexy's motors, ranges and homing, with the
// motors' speed and the X and Y accelerations limited in check_move. For a move of
// displacement (x, y, z) and length d, with |.|_AB = max(|x + y|, |x - y|) (the faster belt):
//     v <= max_velocity d / |(x, y)|_AB          (no belt faster than max_velocity)
//     a <= d / |(x / max_x_accel, y / max_y_accel)|_AB
// and with scale_xy_accel the accel limit is instead max_accel d / (|(x / max_x_accel,
// y / max_y_accel)|_AB max(max_x_accel, max_y_accel)), max_velocity and max_accel as M204 and
// SET_VELOCITY_LIMIT leave them; Z keeps max_z_velocity and max_z_accel. klippy/kinematics/
// limited_corexy.py of Kalico (read at f2532ee3, nothing copied).
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/limited_cartesian.hpp"

namespace amctl::kinematics {

struct LimitedCoreXY {
  static constexpr std::string_view kName = "limited_corexy";
  /// max_x_accel, max_y_accel (default max_accel), scale_xy_accel; no per-axis velocities.
  AxisLimits limits;
  Rails rails;
  bool operator==(const LimitedCoreXY&) const = default;

  /// printer.cfg: corexy's sections; [printer] max_x_accel, max_y_accel (> 0), scale_xy_accel.
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  [[nodiscard]] static LimitedCoreXY from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options();
  [[nodiscard]] static std::span<const ParamKey<LimitedCoreXY>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  [[nodiscard]] bool owns_stepper(std::string_view) const { return false; }
  static Rail* rail(LimitedCoreXY& k, std::string_view key, bool create) {
    return detail::rail_of(k.rails, key, create);
  }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const LimitedCoreXY& p, const Context& ctx);

}  // namespace amctl::kinematics
