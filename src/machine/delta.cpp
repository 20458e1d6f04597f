#include "amctl/machine/delta.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"

namespace amctl::machine {

double DeltaGeometry::carriage_mm(int tower, double x, double y, double z) const {
  const auto i = static_cast<std::size_t>(tower);
  const double dx = x - tower_x_mm[i], dy = y - tower_y_mm[i];
  return z + std::sqrt(arm2_mm2[i] - dx * dx - dy * dy);
}

double DeltaGeometry::limit_xy2_at(double z) const {
  if (z <= limit_z_mm) return max_xy2_mm2;
  // Above limit_z the shortest rod, pivoting on its tower's top, reaches in by
  // L - sqrt(L^2 - (L - dz)^2) less.
  const double above = z - limit_z_mm;
  const double l = min_arm_length_mm;
  const double allowed = radius_mm - std::sqrt(l * l - (l - above) * (l - above));
  return std::min(max_xy2_mm2, allowed * allowed);
}

std::array<double, 3> trilaterate_below(const std::array<std::array<double, 3>, 3>& c,
                                        const std::array<double, 3>& r2) {
  auto sub = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return std::array<double, 3>{a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  };
  auto dot = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  };
  auto scale = [](const std::array<double, 3>& a, double s) {
    return std::array<double, 3>{a[0] * s, a[1] * s, a[2] * s};
  };
  // Frame: ex along c0->c1, ey in the plane of the three centres, ez normal to it.
  const auto d01 = sub(c[1], c[0]);
  const double d = std::sqrt(dot(d01, d01));
  const auto ex = scale(d01, 1.0 / d);
  const auto d02 = sub(c[2], c[0]);
  const double i = dot(ex, d02);
  auto ey = sub(d02, scale(ex, i));
  ey = scale(ey, 1.0 / std::sqrt(dot(ey, ey)));
  const std::array<double, 3> ez{ex[1] * ey[2] - ex[2] * ey[1], ex[2] * ey[0] - ex[0] * ey[2],
                                 ex[0] * ey[1] - ex[1] * ey[0]};
  const double j = dot(ey, d02);
  const double x = (r2[0] - r2[1] + d * d) / (2.0 * d);
  const double y = (r2[0] - r2[2] + i * i + j * j) / (2.0 * j) - i * x / j;
  const double h = std::sqrt(std::max(0.0, r2[0] - x * x - y * y));
  std::array<double, 3> p{}, q{};
  for (std::size_t k = 0; k < 3; ++k) {
    p[k] = c[0][k] + x * ex[k] + y * ey[k] + h * ez[k];
    q[k] = c[0][k] + x * ex[k] + y * ey[k] - h * ez[k];
  }
  return p[2] < q[2] ? p : q;
}

DeltaGeometry delta_geometry(const Machine& m) {
  if (m.kinematics != Kinematics::delta) {
    throw Error(fmt::format("machine '{}' is not a delta (kinematics = {})", m.name,
                            to_string(m.kinematics)));
  }
  DeltaGeometry g;
  if (!m.delta.radius_mm) {
    throw Error("delta.radius (Klipper [printer] delta_radius) must be given for a delta");
  }
  g.radius_mm = *m.delta.radius_mm;
  const Stepper* towers[3] = {nullptr, nullptr, nullptr};
  for (int i = 0; i < 3; ++i) {
    const auto it = m.steppers.find(std::string(1, "abc"[i]));
    if (it == m.steppers.end()) {
      throw Error(fmt::format("a delta needs [stepper_a], [stepper_b] and [stepper_c]; "
                              "stepper_{} is missing",
                              "abc"[i]));
    }
    towers[i] = &it->second;
  }
  if (!towers[0]->arm_length_mm) {
    throw Error("stepper_a.arm_length must be given for a delta");
  }
  if (!towers[0]->position_endstop_mm) {
    throw Error("stepper_a.position_endstop must be given for a delta");
  }
  static constexpr double kDefaultAngle[3] = {210.0, 330.0, 90.0};
  double half_min_step = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < 3; ++i) {
    const Stepper& s = *towers[i];
    const double arm = s.arm_length_mm.value_or(*towers[0]->arm_length_mm);
    if (!(arm > g.radius_mm)) {
      throw Error(fmt::format("stepper_{}.arm_length ({} mm) must be > delta.radius ({} mm)",
                              "abc"[i], arm, g.radius_mm));
    }
    g.arm_length_mm[i] = arm;
    g.arm2_mm2[i] = arm * arm;
    const double angle = s.angle_deg.value_or(kDefaultAngle[i]) * std::numbers::pi / 180.0;
    g.tower_x_mm[i] = std::cos(angle) * g.radius_mm;
    g.tower_y_mm[i] = std::sin(angle) * g.radius_mm;
    g.endstop_mm[i] = s.position_endstop_mm.value_or(*towers[0]->position_endstop_mm);
    g.abs_endstop_mm[i] = g.endstop_mm[i] + std::sqrt(g.arm2_mm2[i] - g.radius_mm * g.radius_mm);
    g.step_distance_mm[i] =
        s.rotation_distance_mm / (static_cast<double>(s.full_steps_per_rotation) * s.microsteps);
    half_min_step = std::min(half_min_step, 0.5 * g.step_distance_mm[i]);
  }
  g.max_z_mm = std::min({g.endstop_mm[0], g.endstop_mm[1], g.endstop_mm[2]});
  g.min_z_mm = m.delta.minimum_z_position_mm.value_or(0.0);
  if (g.min_z_mm > g.max_z_mm) {
    throw Error(fmt::format("delta.minimum_z_position ({} mm) must be <= the lowest "
                            "position_endstop ({} mm)",
                            g.min_z_mm, g.max_z_mm));
  }
  g.min_arm_length_mm = std::min({g.arm_length_mm[0], g.arm_length_mm[1], g.arm_length_mm[2]});
  g.limit_z_mm = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < 3; ++i) {
    g.limit_z_mm = std::min(g.limit_z_mm, g.abs_endstop_mm[i] - g.arm_length_mm[i]);
  }
  const double l = g.min_arm_length_mm, h = half_min_step, R = g.radius_mm;
  auto ratio_to_xy = [&](double k) { return k * std::sqrt(l * l / (k * k + 1.0) - h * h) + h - R; };
  const double slow = ratio_to_xy(3.0), very_slow = ratio_to_xy(6.0);
  g.slow_xy2_mm2 = slow * slow;
  g.very_slow_xy2_mm2 = very_slow * very_slow;
  const double max_xy = std::min({m.delta.print_radius_mm.value_or(R), l - R, ratio_to_xy(12.0)});
  g.max_xy2_mm2 = max_xy * max_xy;
  std::array<std::array<double, 3>, 3> centres{};
  for (std::size_t i = 0; i < 3; ++i) centres[i] = {g.tower_x_mm[i], g.tower_y_mm[i], g.abs_endstop_mm[i]};
  g.home_position_mm = trilaterate_below(centres, g.arm2_mm2);
  return g;
}

}  // namespace amctl::machine

namespace amctl::machine {

double DeltesianGeometry::pillars_z_max(double x) const {
  const double l = std::sqrt(arm2_mm2[0] - (arm_x_mm[0] + x) * (arm_x_mm[0] + x));
  const double r = std::sqrt(arm2_mm2[1] - (arm_x_mm[1] - x) * (arm_x_mm[1] - x));
  return std::min(abs_endstop_mm[0] - l, abs_endstop_mm[1] - r);
}

DeltesianGeometry deltesian_geometry(const Machine& m) {
  DeltesianGeometry g;
  const Stepper* towers[2] = {nullptr, nullptr};
  for (int i = 0; i < 2; ++i) {
    const char* name = i == 0 ? "left" : "right";
    const auto it = m.steppers.find(name);
    if (it == m.steppers.end()) {
      throw Error(fmt::format("a deltesian needs [stepper_left], [stepper_right] and "
                              "[stepper_y]; stepper_{} is missing",
                              name));
    }
    towers[i] = &it->second;
  }
  const auto y = m.steppers.find("y");
  if (y == m.steppers.end() || !y->second.position_max_mm) {
    throw Error("a deltesian needs [stepper_y] with position_max");
  }
  const Stepper& left = *towers[0];
  if (!left.arm_x_length_mm) throw Error("stepper_left.arm_x_length must be given for a deltesian");
  if (!left.arm_length_mm) throw Error("stepper_left.arm_length must be given for a deltesian");
  if (!left.position_endstop_mm) {
    throw Error("stepper_left.position_endstop must be given for a deltesian");
  }
  std::array<double, 2> arm{}, endstop{};
  for (std::size_t i = 0; i < 2; ++i) {
    const Stepper& s = *towers[i];
    g.arm_x_mm[i] = s.arm_x_length_mm.value_or(*left.arm_x_length_mm);
    arm[i] = s.arm_length_mm.value_or(*left.arm_length_mm);
    if (!(arm[i] > g.arm_x_mm[i])) {
      throw Error(fmt::format("stepper_{}.arm_length ({} mm) must be > arm_x_length ({} mm)",
                              i == 0 ? "left" : "right", arm[i], g.arm_x_mm[i]));
    }
    g.arm2_mm2[i] = arm[i] * arm[i];
    endstop[i] = s.position_endstop_mm.value_or(*left.position_endstop_mm);
    g.abs_endstop_mm[i] = endstop[i] + std::sqrt(g.arm2_mm2[i] - g.arm_x_mm[i] * g.arm_x_mm[i]);
  }
  g.tower_x_mm = {-g.arm_x_mm[0], g.arm_x_mm[1]};
  // X: where the arms keep min_angle with the horizontal, or print_width centred.
  const double min_angle = m.delta.min_angle_deg.value_or(5.0);
  if (min_angle > 90.0) throw Error(fmt::format("delta.min_angle must be <= 90, got {}", min_angle));
  const double cos_angle = std::cos(min_angle * std::numbers::pi / 180.0);
  const double x_min = std::ceil(-std::min(g.arm_x_mm[0], cos_angle * arm[1] - g.arm_x_mm[1]));
  const double x_max = std::floor(std::min(g.arm_x_mm[1], cos_angle * arm[0] - g.arm_x_mm[0]));
  const double x_range = std::min({x_max - x_min, 2.0 * x_max, -2.0 * x_min});
  const double width = m.delta.print_width_mm.value_or(0.0);
  if (width > x_range) {
    throw Error(fmt::format("delta.print_width ({} mm) must be <= {} mm, what the arms reach",
                            width, x_range));
  }
  g.limits_mm[0] = width > 0.0 ? std::array<double, 2>{-0.5 * width, 0.5 * width}
                               : std::array<double, 2>{x_min, x_max};
  g.limits_mm[1] = {y->second.position_min_mm.value_or(0.0), *y->second.position_max_mm};
  g.home_y_mm = y->second.position_endstop_mm.value_or(0.0);
  // Home: trilateration of the two pivots in the XZ plane with the carriages at the endstops.
  {
    const double dx = g.arm_x_mm[0] + g.arm_x_mm[1];
    const double dz = g.abs_endstop_mm[1] - g.abs_endstop_mm[0];
    const double pivots = std::sqrt(dx * dx + dz * dz);
    const double xt = (pivots * pivots + g.arm2_mm2[0] - g.arm2_mm2[1]) / (2.0 * pivots);
    const double zt = std::sqrt(g.arm2_mm2[0] - xt * xt);
    g.home_z_mm = xt * dz / pivots - zt * dx / pivots + g.abs_endstop_mm[0];
  }
  const double z_max = std::min(g.pillars_z_max(g.limits_mm[0][0]), g.pillars_z_max(g.limits_mm[0][1]));
  const double z_min = m.delta.minimum_z_position_mm.value_or(0.0);
  if (z_min > z_max) {
    throw Error(fmt::format("delta.minimum_z_position ({} mm) must be <= {} mm", z_min, z_max));
  }
  g.limits_mm[2] = {z_min, z_max};
  const double ratio = m.delta.slow_ratio.value_or(3.0);
  if (ratio > 0.0) {
    const double sr2 = ratio * ratio;
    double slow = std::numeric_limits<double>::infinity(), very = slow;
    for (std::size_t i = 0; i < 2; ++i) {
      slow = std::min(slow, std::sqrt(sr2 * g.arm2_mm2[i] / (sr2 + 1.0)) - g.arm_x_mm[i]);
      very = std::min(very, std::sqrt(2.0 * sr2 * g.arm2_mm2[i] / (2.0 * sr2 + 1.0)) - g.arm_x_mm[i]);
    }
    g.slow_x2_mm2 = slow * slow;
    g.very_slow_x2_mm2 = very * very;
  }
  return g;
}

}  // namespace amctl::machine
