// limited_cartesian: cartesian's motors (kin_cartesian.c) with Kalico's per-axis limits; the
// per-axis options every limited kinematics reads (axis_limits.hpp).
#include "amctl/kinematics/limited_cartesian.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "axis_limits.hpp"

namespace amctl::kinematics {

namespace detail {

void read_axis_limits(const KlipperConfig& cfg, AxisLimits& l, AxisLimitOptions o) {
  const KlipperSection printer = cfg.section("printer");
  Limits v{.above = 0.0}, a{.above = 0.0};
  if (o.capped) {
    v.maxval = printer.require_float("max_velocity", {.above = 0.0});
    a.maxval = printer.require_float("max_accel", {.above = 0.0});
  }
  if (o.velocities) {
    l.max_x_velocity_mm_s = printer.get_float("max_x_velocity", v);
    l.max_y_velocity_mm_s = printer.get_float("max_y_velocity", v);
  }
  l.max_x_accel_mm_s2 = printer.get_float("max_x_accel", a);
  l.max_y_accel_mm_s2 = printer.get_float("max_y_accel", a);
  // configfile.py getboolean: configparser's true/false words.
  const std::string s = printer.get_choice("scale_xy_accel", "false",
                                           {"1", "yes", "true", "on", "0", "no", "false", "off"});
  l.scale_xy_accel = s == "1" || s == "yes" || s == "true" || s == "on";
}

std::span<const std::string_view> axis_limit_options(bool velocities) {
  static constexpr std::string_view kAll[] = {"max_x_velocity", "max_y_velocity", "max_x_accel",
                                              "max_y_accel", "scale_xy_accel"};
  return velocities ? std::span<const std::string_view>(kAll)
                    : std::span<const std::string_view>(kAll).subspan(2);
}

void check_axis_limits(const AxisLimits& l, const Toolhead& th, AxisLimitOptions o) {
  const auto check = [](const std::optional<double>& v, const char* key, double cap, bool capped,
                        const char* cap_name) {
    if (!v) return;
    if (!(*v > 0.0) || !std::isfinite(*v)) {
      throw Error(fmt::format("printer.{} = {}: expected a finite value above 0", key, *v));
    }
    if (capped && *v > cap) {
      throw Error(fmt::format("printer.{} = {} is above {} ({}), which Klipper refuses", key, *v,
                              cap_name, cap));
    }
  };
  if (o.velocities) {
    check(l.max_x_velocity_mm_s, "max_x_velocity", th.max_velocity_mm_s, o.capped, "max_velocity");
    check(l.max_y_velocity_mm_s, "max_y_velocity", th.max_velocity_mm_s, o.capped, "max_velocity");
  }
  check(l.max_x_accel_mm_s2, "max_x_accel", th.max_accel_mm_s2, o.capped, "max_accel");
  check(l.max_y_accel_mm_s2, "max_y_accel", th.max_accel_mm_s2, o.capped, "max_accel");
}

void describe_axis_limits(const AxisLimits& l, Json& j) {
  auto put = [&](const char* key, const std::optional<double>& v) {
    if (v) j["printer"][key] = *v;
  };
  put("max_x_velocity", l.max_x_velocity_mm_s);
  put("max_y_velocity", l.max_y_velocity_mm_s);
  put("max_x_accel", l.max_x_accel_mm_s2);
  put("max_y_accel", l.max_y_accel_mm_s2);
  j["printer"]["scale_xy_accel"] = l.scale_xy_accel;
}

}  // namespace detail

namespace {

constexpr detail::MotorRows kRows{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
constexpr detail::AxisLimitOptions kOptions{.velocities = true, .capped = true};

}  // namespace

std::vector<KlipperStepper> LimitedCartesian::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

LimitedCartesian LimitedCartesian::from_klipper(const KlipperConfig& cfg) {
  return detail::limited_from_klipper<LimitedCartesian>(cfg, kOptions);
}

std::span<const std::string_view> LimitedCartesian::printer_options() {
  return detail::axis_limit_options(true);
}

std::span<const ParamKey<LimitedCartesian>> LimitedCartesian::keys() {
  return detail::limited_keys<LimitedCartesian>(true);
}

std::unique_ptr<Kinematics> make_kinematics(const LimitedCartesian& p, const Context& ctx) {
  // limited_cartesian.py: velocities default to sqrt(2) max_velocity (Z's too, as its own
  // max_z_velocity default), accels to max_accel.
  return std::make_unique<detail::PerAxisKinematics<LimitedCartesian>>(
      p, ctx, kRows, kOptions, std::numbers::sqrt2 * ctx.toolhead.max_velocity_mm_s);
}

}  // namespace amctl::kinematics
