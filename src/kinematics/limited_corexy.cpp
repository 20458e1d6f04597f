// limited_corexy: corexy's motors (kin_corexy.c: A = X + Y, B = X - Y) with Kalico's belt speed
// and per-axis accel limits (limited_corexy.hpp).
#include "amctl/kinematics/limited_corexy.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "axis_limits.hpp"

namespace amctl::kinematics {
namespace {

constexpr detail::MotorRows kRows{{1, 1, 0, 0}, {1, -1, 0, 0}, {0, 0, 1, 0}};
constexpr detail::AxisLimitOptions kOptions{.velocities = false, .capped = false};

class LimitedCoreXYKinematics final : public detail::RailKinematics<LimitedCoreXY> {
 public:
  LimitedCoreXYKinematics(const LimitedCoreXY& p, const Context& ctx)
      : RailKinematics(p, ctx, kRows) {
    detail::check_axis_limits(p.limits, ctx.toolhead, kOptions);
    const Toolhead& th = ctx.toolhead;
    accel_x_ = p.limits.max_x_accel_mm_s2.value_or(th.max_accel_mm_s2);
    accel_y_ = p.limits.max_y_accel_mm_s2.value_or(th.max_accel_mm_s2);
    z_velocity_ = th.max_z_velocity_mm_s > 0.0 ? th.max_z_velocity_mm_s : th.max_velocity_mm_s;
    z_accel_ = th.max_z_accel_mm_s2 > 0.0 ? th.max_z_accel_mm_s2 : th.max_accel_mm_s2;
  }
  MoveRules move_rules() const override { return detail::limited_move_rules(p_, th_); }
  void limit_move(const MoveGeometry& m, double& velocity, double& accel) const override {
    double max_v = m.toolhead_velocity_mm_s, max_a = m.toolhead_accel_mm_s2;
    const double x = m.d[0], y = m.d[1], z = m.d[2], d = m.distance_mm;
    const double ab = std::max(std::fabs(x + y), std::fabs(x - y));
    if (ab > 2.0 * DBL_EPSILON) {  // the move turns a belt
      max_v *= d / ab;
      const double xa = x / accel_x_, ya = y / accel_y_;
      const double ab_a = std::max(std::fabs(xa + ya), std::fabs(xa - ya));
      if (p_.limits.scale_xy_accel) max_a *= d / (ab_a * std::max(accel_x_, accel_y_));
      else max_a = d / ab_a;
    }
    if (z != 0.0) {
      const double z_ratio = d / std::fabs(z);
      max_v = std::min(max_v, z_velocity_ * z_ratio);
      max_a = std::min(max_a, z_accel_ * z_ratio);
    }
    velocity = std::min(velocity, max_v);
    accel = std::min(accel, max_a);
  }
  void describe(Json& j) const override { detail::describe_axis_limits(p_.limits, j); }

 private:
  double accel_x_ = 0.0, accel_y_ = 0.0, z_velocity_ = 0.0, z_accel_ = 0.0;
};

}  // namespace

std::vector<KlipperStepper> LimitedCoreXY::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

LimitedCoreXY LimitedCoreXY::from_klipper(const KlipperConfig& cfg) {
  return detail::limited_from_klipper<LimitedCoreXY>(cfg, kOptions);
}

std::span<const std::string_view> LimitedCoreXY::printer_options() {
  return detail::axis_limit_options(false);
}

std::span<const ParamKey<LimitedCoreXY>> LimitedCoreXY::keys() {
  return detail::limited_keys<LimitedCoreXY>(false);
}

std::unique_ptr<Kinematics> make_kinematics(const LimitedCoreXY& p, const Context& ctx) {
  return std::make_unique<LimitedCoreXYKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
