#pragma once
// Internal to the kinematics module: Kalico's per-axis limits (AxisLimits, limited_cartesian.hpp)
// as limited_cartesian, limited_corexz and limited_corexy read and key them, and the per-axis
// check_move of the first two.
#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/limited_cartesian.hpp"
#include "rail_kinematics.hpp"

namespace amctl::kinematics::detail {

/// Which of AxisLimits' options a kinematics has, and Klipper's bounds on them.
struct AxisLimitOptions {
  bool velocities = true;  ///< max_x_velocity, max_y_velocity (limited_corexy has none)
  bool capped = false;     ///< a value above max_velocity (max_accel) is refused
};

/// [printer]'s per-axis options into `l`, with Klipper's checks (file:line:col on error).
void read_axis_limits(const KlipperConfig& cfg, AxisLimits& l, AxisLimitOptions o);
/// TOML and --set: those a kinematics with `velocities` has.
[[nodiscard]] std::span<const std::string_view> axis_limit_options(bool velocities);
/// A value given above the toolhead's limit (a TOML machine): amctl::Error naming the key.
void check_axis_limits(const AxisLimits& l, const Toolhead& th, AxisLimitOptions o);
/// `amctl machine show --json`: the options given.
void describe_axis_limits(const AxisLimits& l, Json& machine);

/// The limits in force of limited_cartesian and limited_corexz: X, Y, Z.
struct PerAxisLimits {
  std::array<double, 3> velocity_mm_s{}, accel_mm_s2{};
  bool scale_xy_accel = false;
  double xy_hypot_accel_mm_s2 = 0.0;  ///< hypot(max_x_accel, max_y_accel)
};

/// check_move of limited_cartesian and limited_corexz: per-axis limits along the move's unit
/// direction (an axis moving less than DBL_EPSILON of the move sets none).
inline void limit_per_axis(const PerAxisLimits& l, const MoveGeometry& m, double& velocity,
                           double& accel) {
  const double xr = std::max(std::fabs(m.d[0] / m.distance_mm), DBL_EPSILON);
  const double yr = std::max(std::fabs(m.d[1] / m.distance_mm), DBL_EPSILON);
  double max_v = std::min(l.velocity_mm_s[0] / xr, l.velocity_mm_s[1] / yr);
  double max_a = std::min(l.accel_mm_s2[0] / xr, l.accel_mm_s2[1] / yr);
  if (l.scale_xy_accel) max_a *= m.toolhead_accel_mm_s2 / l.xy_hypot_accel_mm_s2;
  const double zr = m.d[2] / m.distance_mm;
  if (zr != 0.0) {
    max_v = std::min(max_v, l.velocity_mm_s[2] / std::fabs(zr));
    max_a = std::min(max_a, l.accel_mm_s2[2] / std::fabs(zr));
  }
  velocity = std::min(velocity, max_v);
  accel = std::min(accel, max_a);
}

/// The TOML keys of AxisLimits for kinematics K (a `limits` member), appended to `k`.
template <class K>
void add_axis_limit_keys(std::vector<ParamKey<K>>& k, bool velocities) {
  static constexpr std::string_view kBool[] = {"false", "true"};
  if (velocities) {
    k.push_back({"printer", "max_x_velocity", KeyBound::positive, "mm/s",
                 "Largest X velocity (Kalico's limited kinematics); unset: the kinematics' default.",
                 [](K& p, std::string_view, bool) -> std::optional<double>* {
                   return &p.limits.max_x_velocity_mm_s;
                 }});
    k.push_back({"printer", "max_y_velocity", KeyBound::positive, "mm/s",
                 "Largest Y velocity (Kalico's limited kinematics); unset: the kinematics' default.",
                 [](K& p, std::string_view, bool) -> std::optional<double>* {
                   return &p.limits.max_y_velocity_mm_s;
                 }});
  }
  k.push_back({"printer", "max_x_accel", KeyBound::positive, "mm/s^2",
               "Largest X acceleration (Kalico's limited kinematics); unset: max_accel.",
               [](K& p, std::string_view, bool) -> std::optional<double>* {
                 return &p.limits.max_x_accel_mm_s2;
               }});
  k.push_back({"printer", "max_y_accel", KeyBound::positive, "mm/s^2",
               "Largest Y acceleration (Kalico's limited kinematics); unset: max_accel.",
               [](K& p, std::string_view, bool) -> std::optional<double>* {
                 return &p.limits.max_y_accel_mm_s2;
               }});
  ParamKey<K> scale{"printer", "scale_xy_accel", KeyBound::finite, "",
                    "\"true\": the X and Y accel limits scale with the accel in force (M204, "
                    "SET_VELOCITY_LIMIT) over hypot(max_x_accel, max_y_accel); \"false\" (default): "
                    "they are limits of their own."};
  scale.choices = kBool;
  scale.get_index = [](K& p, std::string_view) { return p.limits.scale_xy_accel ? 1 : -1; };
  scale.set_index = [](K& p, std::string_view, int i) {
    p.limits.scale_xy_accel = i == 1;
    return true;
  };
  k.push_back(scale);
}

/// A limited kinematics' rules: its rails' ranges inline, the Z limit among its own.
template <class P>
MoveRules limited_move_rules(const P& p, const Toolhead& th) {
  MoveRules r = cartesian_move_rules(p.rails, th);
  r.z_velocity_mm_s.reset();
  r.z_accel_mm_s2.reset();
  r.limits_speed = true;
  return r;
}

/// limited_cartesian and limited_corexz: rail kinematics with the per-axis limits, whose X and
/// Y velocities default to `default_velocity_mm_s` (and Z's, without max_z_velocity).
template <class P>
class PerAxisKinematics final : public RailKinematics<P> {
 public:
  PerAxisKinematics(const P& p, const Context& ctx, const MotorRows& rows, AxisLimitOptions o,
                    double default_velocity_mm_s)
      : RailKinematics<P>(p, ctx, rows) {
    check_axis_limits(p.limits, ctx.toolhead, o);
    const Toolhead& th = ctx.toolhead;
    const double v = default_velocity_mm_s;
    l_.velocity_mm_s = {p.limits.max_x_velocity_mm_s.value_or(v),
                        p.limits.max_y_velocity_mm_s.value_or(v),
                        th.max_z_velocity_mm_s > 0.0 ? th.max_z_velocity_mm_s : v};
    l_.accel_mm_s2 = {p.limits.max_x_accel_mm_s2.value_or(th.max_accel_mm_s2),
                      p.limits.max_y_accel_mm_s2.value_or(th.max_accel_mm_s2),
                      th.max_z_accel_mm_s2 > 0.0 ? th.max_z_accel_mm_s2 : th.max_accel_mm_s2};
    l_.scale_xy_accel = p.limits.scale_xy_accel;
    l_.xy_hypot_accel_mm_s2 = std::hypot(l_.accel_mm_s2[0], l_.accel_mm_s2[1]);
  }
  MoveRules move_rules() const override { return limited_move_rules(this->p_, this->th_); }
  void limit_move(const MoveGeometry& m, double& velocity, double& accel) const override {
    limit_per_axis(l_, m, velocity, accel);
  }
  void describe(Json& j) const override { describe_axis_limits(this->p_.limits, j); }

 private:
  PerAxisLimits l_;
};

/// P's printer.cfg: its rails (and dual carriage) and [printer]'s per-axis options.
template <class P>
P limited_from_klipper(const KlipperConfig& cfg, AxisLimitOptions o) {
  P k = rails_from_klipper<P>(cfg);
  read_axis_limits(cfg, k.limits, o);
  return k;
}

/// P's TOML keys: the per-axis options, then the rails' (and dual carriage's).
template <class P>
std::span<const ParamKey<P>> limited_keys(bool velocities) {
  static const std::vector<ParamKey<P>> keys = [velocities] {
    std::vector<ParamKey<P>> k;
    add_axis_limit_keys(k, velocities);
    for (const auto& r : rail_keys<P>()) k.push_back(r);
    return k;
  }();
  return keys;
}

}  // namespace amctl::kinematics::detail
