// limited_corexz: corexz's motors (kin_corexz.c: X + Z, Y, X - Z) with Kalico's per-axis limits.
#include "amctl/kinematics/limited_corexz.hpp"

#include "axis_limits.hpp"

namespace amctl::kinematics {
namespace {

constexpr detail::MotorRows kRows{{1, 0, 1, 0}, {0, 1, 0, 0}, {1, 0, -1, 0}};
constexpr detail::AxisLimitOptions kOptions{.velocities = true, .capped = false};

}  // namespace

std::vector<KlipperStepper> LimitedCoreXZ::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

LimitedCoreXZ LimitedCoreXZ::from_klipper(const KlipperConfig& cfg) {
  return detail::limited_from_klipper<LimitedCoreXZ>(cfg, kOptions);
}

std::span<const std::string_view> LimitedCoreXZ::printer_options() {
  return detail::axis_limit_options(true);
}

std::span<const ParamKey<LimitedCoreXZ>> LimitedCoreXZ::keys() {
  return detail::limited_keys<LimitedCoreXZ>(true);
}

std::unique_ptr<Kinematics> make_kinematics(const LimitedCoreXZ& p, const Context& ctx) {
  // limited_corexz.py: every limit defaults to the toolhead's (Z: max_z_velocity, max_z_accel).
  return std::make_unique<detail::PerAxisKinematics<LimitedCoreXZ>>(
      p, ctx, kRows, kOptions, ctx.toolhead.max_velocity_mm_s);
}

}  // namespace amctl::kinematics
