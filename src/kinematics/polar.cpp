// Polar: the bed's angle and the arm's radius (kin_polar.c), the angular speed limit and the
// reach of check_move (polar.py), homing.
#include "amctl/kinematics/polar.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

PolarGeometry polar_geometry(const Polar& p) {
  PolarGeometry g;
  const auto arm = p.rails.find("arm");
  const auto z = p.rails.find("z");
  if (arm == p.rails.end() || !arm->second.position_max_mm) {
    throw Error("stepper_arm.position_max must be given for a polar printer");
  }
  if (!arm->second.position_endstop_mm) {
    throw Error("stepper_arm.position_endstop must be given for a polar printer");
  }
  if (z == p.rails.end() || !z->second.position_max_mm) {
    throw Error("stepper_z.position_max must be given for a polar printer");
  }
  g.max_radius_mm = *arm->second.position_max_mm;
  g.arm_endstop_mm = *arm->second.position_endstop_mm;
  g.z_limits_mm = {z->second.position_min_mm.value_or(0.0), *z->second.position_max_mm};
  return g;
}

namespace {

/// The arm: sqrt(x^2 + y^2), convex along a line (one turning point at most).
class RadiusCurve final : public MotorCurve {
 public:
  double position(const Vec3& p) const override { return std::sqrt(p[0] * p[0] + p[1] * p[1]); }
  double slope_along(const Vec3& p0, const Vec3& u, double s, double) const override {
    const double x = p0[0] + u[0] * s, y = p0[1] + u[1] * s;
    const double r = std::sqrt(x * x + y * y);
    return r > 0.0 ? (x * u[0] + y * u[1]) / r : 0.0;
  }
  bool moves_along(const Vec3& u) const override { return u[0] != 0.0 || u[1] != 0.0; }
};

/// The bed: atan2(y, x), unwrapped along a line from its start: the angle swept from the start
/// direction, atan2(p0 x p, p0 . p), plus the start's angle. A straight line sweeps less than
/// pi unless it passes through the centre, where the angle jumps by pi (the bed would have to
/// turn at once); a move from the centre keeps the bed still (the angle is constant along the
/// ray), the turn to it is taken as a jump between moves, like G92.
class AngleCurve final : public MotorCurve {
 public:
  double position(const Vec3& p) const override { return std::atan2(p[1], p[0]); }
  double along(const Vec3& p0, const Vec3& u, double s) const override {
    const double x = p0[0] + u[0] * s, y = p0[1] + u[1] * s;
    return std::atan2(p0[1], p0[0]) + std::atan2(p0[0] * y - p0[1] * x, p0[0] * x + p0[1] * y);
  }
  double slope_along(const Vec3& p0, const Vec3& u, double s, double) const override {
    const double x = p0[0] + u[0] * s, y = p0[1] + u[1] * s;
    const double r2 = x * x + y * y;
    return r2 > 0.0 ? (x * u[1] - y * u[0]) / r2 : 0.0;
  }
  // Monotone along a line.
  void turning_points(const Vec3&, const Vec3&, double, std::vector<double>&) const override {}
  bool moves_along(const Vec3& u) const override { return u[0] != 0.0 || u[1] != 0.0; }
};

class PolarKinematics final : public Kinematics {
 public:
  PolarKinematics(const Polar& p, const Context& ctx) : p_(p), th_(ctx.toolhead) {
    for (const char* name : {"bed", "arm", "z"}) {
      if (ctx.step_distance.count(name) == 0) {
        throw Error(fmt::format("a polar printer needs stepper_bed, stepper_arm and stepper_z; "
                                "stepper_{} is missing",
                                name));
      }
    }
    detail::check_rails(p.rails);
    g_ = polar_geometry(p);
  }
  std::string_view name() const override { return Polar::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    std::vector<Motor> out;
    for (const char* k : {"bed", "arm"}) {
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) {
        missing.push_back(stepper_name(k));
        continue;
      }
      Motor m;
      m.name = stepper_name(k);
      m.key = k;
      if (k[0] == 'b') {
        m.step_distance.unit = Unit::rad;
        m.curve = std::make_shared<AngleCurve>();
      } else {
        m.curve = std::make_shared<RadiusCurve>();
      }
      out.push_back(std::move(m));
    }
    const auto zs = axis_motor_keys(keys, "z");
    if (zs.empty() || zs.front() != "z") missing.push_back("stepper_z");
    for (const std::string& k : zs) {
      Motor m;
      m.name = stepper_name(k);
      m.key = k;
      m.row = {0, 0, 1, 0};
      out.push_back(std::move(m));
    }
    return out;
  }
  MoveRules move_rules() const override {
    MoveRules r;
    r.z_velocity_mm_s = th_.max_z_velocity_mm_s > 0 ? th_.max_z_velocity_mm_s : th_.max_velocity_mm_s;
    r.z_accel_mm_s2 = th_.max_z_accel_mm_s2 > 0 ? th_.max_z_accel_mm_s2 : th_.max_accel_mm_s2;
    r.special = true;  // the radius always checked
    return r;
  }
  std::optional<RangeViolation> check_range(const MoveGeometry& m) const override {
    // polar.py check_move: every kinematic move must end within the arm's reach; Z is
    // checked like cartesian's.
    const double dx = m.end[0] - m.start[0], dy = m.end[1] - m.start[1], dz = m.end[2] - m.start[2];
    if (std::sqrt(dx * dx + dy * dy + dz * dz) >= 1e-9) {
      const double xy2 = m.end[0] * m.end[0] + m.end[1] * m.end[1];
      const double max_r2 = g_.max_radius_mm * g_.max_radius_mm;
      if (xy2 > max_r2) return RangeViolation{'r', std::sqrt(xy2), std::sqrt(max_r2)};
    }
    if (m.end[2] != m.start[2]) {
      const double z = m.end[2];
      if (z < g_.z_limits_mm[0] || z > g_.z_limits_mm[1]) {
        return RangeViolation{'z', z, z < g_.z_limits_mm[0] ? g_.z_limits_mm[0] : g_.z_limits_mm[1]};
      }
    }
    return std::nullopt;
  }
  void limit_move(const MoveGeometry& m, double& velocity, double& accel) const override {
    // polar.py: the segment's closest approach to the centre d; the bed turns at up to v / d;
    // max_velocity / max_accel read once at start-up.
    const double v_rad_max = p_.max_angular_velocity_rad_s.value_or(0.0);
    if (!((m.d[0] != 0.0 || m.d[1] != 0.0) && v_rad_max > 0.0)) return;
    const double ax = m.start[0], ay = m.start[1], bx = m.end[0], by = m.end[1];
    const double ux = bx - ax, uy = by - ay;
    const double along = -(ux * ax + uy * ay);  // (b - a) . (0 - a)
    const double len2 = ux * ux + uy * uy;
    double dist = 0.0;
    if (along <= 0.0) dist = std::sqrt(ax * ax + ay * ay);
    else if (along >= len2) dist = std::sqrt(bx * bx + by * by);
    else dist = std::fabs(ux * ay - uy * ax) / std::sqrt(len2);
    if (dist == 0.0) return;  // through the centre: Klipper leaves it unlimited
    const double v_angular = velocity / dist;
    if (v_rad_max < v_angular) {
      const double scale = v_rad_max / v_angular;
      velocity = std::min(velocity, th_.max_velocity_mm_s * scale);
      accel = std::min(accel, th_.max_accel_mm_s2 * scale);
    }
  }
  Homing homing() const override {
    // polar.py homes X and Y together to (arm position_endstop, 0); Z homes to 0 as on every
    // cartesian-like machine in amctl.
    Homing h;
    h.position_mm = {g_.arm_endstop_mm, 0.0, 0.0};
    return h;
  }
  void describe(Json& j) const override {
    if (p_.max_angular_velocity_rad_s) j["printer"]["max_angular_velocity"] = *p_.max_angular_velocity_rad_s;
  }

 private:
  Polar p_;
  Toolhead th_;
  PolarGeometry g_;
};

}  // namespace

std::vector<KlipperStepper> Polar::klipper_steppers(const KlipperConfig& cfg) {
  for (const char* s : {"stepper_bed", "stepper_arm", "stepper_z"}) {
    if (!cfg.has(s)) {
      throw Error(cfg.printer_where(),
                  fmt::format("a polar printer needs [{}] (stepper_bed, stepper_arm, stepper_z)", s));
    }
  }
  std::vector<KlipperStepper> out;
  for (const ConfigSection& s : cfg.sections()) {
    if (s.name == "stepper_bed") out.push_back({s.name, "bed", true});
    if (s.name == "stepper_arm") out.push_back({s.name, "arm", false});
  }
  for (KlipperStepper& s : detail::axis_steppers(cfg, "z")) out.push_back(std::move(s));
  return out;
}

Polar Polar::from_klipper(const KlipperConfig& cfg) {
  // polar.py: max_angular_velocity (> 0, default 0 = off); stepper_bed (radians),
  // stepper_arm (position_max: the reach), stepper_z (+ z1, ...).
  const KlipperSection printer = cfg.section("printer");
  Polar p;
  if (printer.has("max_angular_velocity")) {
    p.max_angular_velocity_rad_s = printer.get_float("max_angular_velocity", {.above = 0.0});
  }
  for (const KlipperStepper& s : klipper_steppers(cfg)) {
    const KlipperSection sec = cfg.section(s.section);
    if (s.key == "arm") {
      Rail& r = p.rails["arm"];
      r.position_endstop_mm = sec.require_float("position_endstop");
      r.position_min_mm = sec.get_float("position_min", 0.0);
      r.position_max_mm = sec.require_float("position_max", {.above = *r.position_min_mm});
    } else if (s.key != "bed") {
      detail::read_rail(sec, p.rails, s.key);
    }
  }
  detail::refuse_dual_carriage(cfg);
  return p;
}

std::span<const std::string_view> Polar::printer_options() {
  static constexpr std::string_view kOptions[] = {"max_angular_velocity"};
  return kOptions;
}

std::span<const ParamKey<Polar>> Polar::keys() {
  static const std::vector<ParamKey<Polar>> keys = [] {
    std::vector<ParamKey<Polar>> k = {
        {"printer", "max_angular_velocity", KeyBound::non_negative, "rad/s",
         "Polar: moves passing within d of the bed's centre at speed v are slowed when v / d "
         "exceeds it (Klipper max_angular_velocity; unset or 0 = no limit).",
         [](Polar& p, std::string_view, bool) -> std::optional<double>* {
           return &p.max_angular_velocity_rad_s;
         }},
    };
    detail::add_rail_keys(k);
    return k;
  }();
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const Polar& p, const Context& ctx) {
  return std::make_unique<PolarKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
