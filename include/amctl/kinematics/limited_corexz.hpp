#pragma once
// Limited CoreXZ (Kalico's limited_corexz): corexz's motors, ranges and homing with the
// per-axis limits of limited_cartesian.hpp (X, Y, Z velocities and accels along the move's
// direction; scale_xy_accel), whose defaults here are max_velocity and max_accel and which
// may exceed them. klippy/kinematics/limited_corexz.py of Kalico (read at f2532ee3, nothing
// copied).
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/limited_cartesian.hpp"

namespace amctl::kinematics {

struct LimitedCoreXZ {
  static constexpr std::string_view kName = "limited_corexz";
  AxisLimits limits;
  Rails rails;
  bool operator==(const LimitedCoreXZ&) const = default;

  /// printer.cfg: corexz's sections; [printer] max_x_velocity, max_y_velocity, max_x_accel,
  /// max_y_accel (> 0), scale_xy_accel.
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  [[nodiscard]] static LimitedCoreXZ from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options();
  [[nodiscard]] static std::span<const ParamKey<LimitedCoreXZ>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  [[nodiscard]] bool owns_stepper(std::string_view) const { return false; }
  static Rail* rail(LimitedCoreXZ& k, std::string_view key, bool create) {
    return detail::rail_of(k.rails, key, create);
  }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const LimitedCoreXZ& p, const Context& ctx);

}  // namespace amctl::kinematics
