// Linear delta: the geometry Klipper derives at start-up (delta.py), the towers' carriage
// heights (kin_delta.c), the slow zones and the build volume of check_move, homing.
#include "amctl/kinematics/delta.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/kinematics/rails.hpp"
#include "detail.hpp"

namespace amctl::kinematics {

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

Vec3 trilaterate_below(const std::array<Vec3, 3>& c, const Vec3& r2) {
  auto sub = [](const Vec3& a, const Vec3& b) { return Vec3{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
  auto dot = [](const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  auto scale = [](const Vec3& a, double s) { return Vec3{a[0] * s, a[1] * s, a[2] * s}; };
  // Frame: ex along c0->c1, ey in the plane of the three centres, ez normal to it.
  const auto d01 = sub(c[1], c[0]);
  const double d = std::sqrt(dot(d01, d01));
  const auto ex = scale(d01, 1.0 / d);
  const auto d02 = sub(c[2], c[0]);
  const double i = dot(ex, d02);
  auto ey = sub(d02, scale(ex, i));
  ey = scale(ey, 1.0 / std::sqrt(dot(ey, ey)));
  const Vec3 ez{ex[1] * ey[2] - ex[2] * ey[1], ex[2] * ey[0] - ex[0] * ey[2],
                ex[0] * ey[1] - ex[1] * ey[0]};
  const double j = dot(ey, d02);
  const double x = (r2[0] - r2[1] + d * d) / (2.0 * d);
  const double y = (r2[0] - r2[2] + i * i + j * j) / (2.0 * j) - i * x / j;
  const double h = std::sqrt(std::max(0.0, r2[0] - x * x - y * y));
  Vec3 p{}, q{};
  for (std::size_t k = 0; k < 3; ++k) {
    p[k] = c[0][k] + x * ex[k] + y * ey[k] + h * ez[k];
    q[k] = c[0][k] + x * ex[k] + y * ey[k] - h * ez[k];
  }
  return p[2] < q[2] ? p : q;
}

DeltaGeometry delta_geometry(const Delta& p, const std::array<double, 3>& step_distance_mm) {
  DeltaGeometry g;
  if (!p.radius_mm) {
    throw Error("delta.radius (Klipper [printer] delta_radius) must be given for a delta");
  }
  g.radius_mm = *p.radius_mm;
  static const DeltaTower kNone;
  const DeltaTower* towers[3];
  for (std::size_t i = 0; i < 3; ++i) {
    const auto it = p.towers.find(std::string(1, "abc"[i]));
    towers[i] = it == p.towers.end() ? &kNone : &it->second;
  }
  if (!towers[0]->arm_length_mm) throw Error("stepper_a.arm_length must be given for a delta");
  if (!towers[0]->position_endstop_mm) {
    throw Error("stepper_a.position_endstop must be given for a delta");
  }
  static constexpr double kDefaultAngle[3] = {210.0, 330.0, 90.0};
  double half_min_step = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < 3; ++i) {
    const DeltaTower& s = *towers[i];
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
    g.step_distance_mm[i] = step_distance_mm[i];
    half_min_step = std::min(half_min_step, 0.5 * g.step_distance_mm[i]);
  }
  g.max_z_mm = std::min({g.endstop_mm[0], g.endstop_mm[1], g.endstop_mm[2]});
  g.min_z_mm = p.minimum_z_position_mm.value_or(0.0);
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
  const double max_xy = std::min({p.print_radius_mm.value_or(R), l - R, ratio_to_xy(12.0)});
  g.max_xy2_mm2 = max_xy * max_xy;
  std::array<Vec3, 3> centres{};
  for (std::size_t i = 0; i < 3; ++i) centres[i] = {g.tower_x_mm[i], g.tower_y_mm[i], g.abs_endstop_mm[i]};
  g.home_position_mm = trilaterate_below(centres, g.arm2_mm2);
  return g;
}

namespace detail {

/// A tower's carriage height (kin_delta.c): q(s) = z + sqrt(L^2 - (x - tx)^2 - (y - ty)^2) on
/// the line p0 + u s. The radicand is a concave quadratic in s, so q is concave: at most one
/// turning point per move. `planar`: a deltesian tower, the same in the XZ plane.
class TowerCurve final : public MotorCurve {
 public:
  TowerCurve(double arm2_mm2, double tower_x_mm, double tower_y_mm, bool planar, const char* what)
      : arm2_(arm2_mm2), tx_(tower_x_mm), ty_(tower_y_mm), planar_(planar), what_(what) {}
  double position(const Vec3& p) const override { return along(p, {0.0, 0.0, 0.0}, 0.0); }
  double along(const Vec3& p0, const Vec3& u, double s) const override {
    const double r = root(p0, u, s);
    return p0[2] + u[2] * s + r;
  }
  double slope_along(const Vec3& p0, const Vec3& u, double s, double) const override {
    const double x = p0[0] - tx_ + u[0] * s;
    const double uy = planar_ ? 0.0 : u[1];
    const double y = planar_ ? 0.0 : p0[1] - ty_ + uy * s;
    return u[2] - (x * u[0] + y * uy) / root(p0, u, s);
  }
  bool moves_along(const Vec3& u) const override {
    return u[0] != 0.0 || (!planar_ && u[1] != 0.0) || u[2] != 0.0;
  }
  std::string out_of_reach(const Vec3& p, std::string_view motor) const override {
    return fmt::format("the effector at X={:.3f} Y={:.3f} is out of reach of {}'s rods (the move "
                       "leaves the {}'s build volume)",
                       p[0], p[1], motor, what_);
  }

 private:
  double root(const Vec3& p0, const Vec3& u, double s) const {
    const double x = p0[0] - tx_ + u[0] * s;
    const double y = planar_ ? 0.0 : p0[1] - ty_ + u[1] * s;
    const double r2 = arm2_ - x * x - y * y;
    return r2 > 0.0 ? std::sqrt(r2) : std::numeric_limits<double>::quiet_NaN();
  }
  double arm2_, tx_, ty_;
  bool planar_;
  const char* what_;
};

std::shared_ptr<const MotorCurve> tower_curve(double arm2_mm2, double tower_x_mm, double tower_y_mm,
                                              bool planar, const char* what) {
  return std::make_shared<TowerCurve>(arm2_mm2, tower_x_mm, tower_y_mm, planar, what);
}

}  // namespace detail

namespace {

class DeltaKinematics final : public Kinematics {
 public:
  DeltaKinematics(const Delta& p, const Context& ctx) : p_(p), th_(ctx.toolhead) {
    if (!p.radius_mm) {
      throw Error("delta.radius (Klipper [printer] delta_radius) must be given for a delta");
    }
    std::array<double, 3> step{};
    for (std::size_t i = 0; i < 3; ++i) {
      const auto it = ctx.step_distance.find(std::string(1, "abc"[i]));
      if (it == ctx.step_distance.end()) {
        throw Error(fmt::format("a delta needs [stepper_a], [stepper_b] and [stepper_c]; "
                                "stepper_{} is missing",
                                "abc"[i]));
      }
      step[i] = it->second;
    }
    g_ = delta_geometry(p, step);
  }
  std::string_view name() const override { return Delta::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    std::vector<Motor> out;
    for (std::size_t i = 0; i < 3; ++i) {
      const std::string k(1, "abc"[i]);
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) {
        missing.push_back(stepper_name(k));
        continue;
      }
      Motor m;
      m.name = stepper_name(k);
      m.key = k;
      m.curve = detail::tower_curve(g_.arm2_mm2[i], g_.tower_x_mm[i], g_.tower_y_mm[i], false, "delta");
      out.push_back(std::move(m));
    }
    return out;
  }
  MoveRules move_rules() const override {
    MoveRules r;
    r.z_velocity_mm_s = th_.max_z_velocity_mm_s > 0 ? th_.max_z_velocity_mm_s : th_.max_velocity_mm_s;
    r.z_accel_mm_s2 = th_.max_z_accel_mm_s2 > 0 ? th_.max_z_accel_mm_s2 : th_.max_accel_mm_s2;
    r.special = true;  // Klipper always checks a delta's build volume
    return r;
  }
  std::optional<RangeViolation> check_range(const MoveGeometry& m) const override {
    return detail::tower_volume(g_, m);
  }
  void limit_move(const MoveGeometry& m, double& velocity, double& accel) const override {
    // A move touching the outer zones (either end beyond the radius where a tower moves 3x
    // (6x) faster than the effector) runs at 1/2 (1/4) of the configured limits; delta.py
    // reads max_velocity / max_accel once at start-up for them.
    const double extreme_xy2 = std::max(m.start[0] * m.start[0] + m.start[1] * m.start[1],
                                        m.end[0] * m.end[0] + m.end[1] * m.end[1]);
    if (extreme_xy2 > g_.slow_xy2_mm2) {
      const double f = extreme_xy2 > g_.very_slow_xy2_mm2 ? 0.25 : 0.5;
      velocity = std::min(velocity, th_.max_velocity_mm_s * f);
      accel = std::min(accel, th_.max_accel_mm_s2 * f);
    }
  }
  Homing homing() const override {
    // delta.py home(): all towers home together; the effector ends at the home position.
    Homing h;
    h.all_axes = true;
    for (std::size_t a = 0; a < 3; ++a) h.position_mm[a] = g_.home_position_mm[a];
    return h;
  }
  void describe(Json& j) const override {
    // The keys as given, and what Klipper derives from them.
    auto opt = [](const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); };
    j["delta"] = {{"radius", g_.radius_mm},
                  {"print_radius", opt(p_.print_radius_mm)},
                  {"minimum_z_position", opt(p_.minimum_z_position_mm)},
                  {"build_radius", std::sqrt(g_.max_xy2_mm2)},
                  {"slow_radius", std::sqrt(g_.slow_xy2_mm2)},
                  {"very_slow_radius", std::sqrt(g_.very_slow_xy2_mm2)},
                  {"max_z", g_.max_z_mm},
                  {"cone_start_z", g_.limit_z_mm}};
  }

 private:
  Delta p_;
  Toolhead th_;
  DeltaGeometry g_;
};

}  // namespace

std::vector<KlipperStepper> Delta::klipper_steppers(const KlipperConfig& cfg) {
  std::vector<KlipperStepper> out;
  for (const char* tower : {"stepper_a", "stepper_b", "stepper_c"}) {
    if (!cfg.has(tower)) {
      throw Error(cfg.printer_where(),
                  fmt::format("a delta needs [{}] (towers stepper_a, stepper_b, stepper_c)", tower));
    }
  }
  for (const ConfigSection& s : cfg.sections()) {
    if (s.name == "stepper_a" || s.name == "stepper_b" || s.name == "stepper_c") {
      out.push_back({s.name, s.name.substr(8), false});
    }
  }
  return out;
}

Delta Delta::from_klipper(const KlipperConfig& cfg) {
  // kinematics/delta.py: delta_radius (required, > 0), print_radius (> 0, default the
  // radius), minimum_z_position (default 0, at most the lowest endstop: delta_geometry).
  const KlipperSection printer = cfg.section("printer");
  Delta d;
  d.radius_mm = printer.require_float("delta_radius", {.above = 0.0});
  d.print_radius_mm = printer.get_float("print_radius", {.above = 0.0});
  d.minimum_z_position_mm = printer.get_float("minimum_z_position");
  for (const KlipperStepper& s : klipper_steppers(cfg)) {
    // delta.py: arm_length required on stepper_a, > delta_radius; b and c default to a's
    // (delta_geometry applies those defaults); angle 210/330/90; position_endstop required
    // on a, b and c default to a's.
    const KlipperSection sec = cfg.section(s.section);
    const Limits arm{.above = *d.radius_mm};
    DeltaTower& t = d.towers[s.key];
    const bool a = s.key == "a";
    t.arm_length_mm = a ? std::optional(sec.require_float("arm_length", arm)) : sec.get_float("arm_length", arm);
    t.angle_deg = sec.get_float("angle");
    t.position_endstop_mm = a ? std::optional(sec.require_float("position_endstop"))
                              : sec.get_float("position_endstop");
  }
  // Sections that give none of these keys hold no entry (as a TOML machine reads them).
  std::erase_if(d.towers, [](const auto& kv) { return kv.second == DeltaTower{}; });
  detail::refuse_dual_carriage(cfg);
  return d;
}

std::span<const std::string_view> Delta::printer_options() {
  static constexpr std::string_view kOptions[] = {"delta_radius", "print_radius", "minimum_z_position"};
  return kOptions;
}

namespace {

DeltaTower* tower_of(Delta& d, std::string_view key, bool create) {
  if (key != "a" && key != "b" && key != "c") return nullptr;
  if (create) return &d.towers[std::string(key)];
  const auto it = d.towers.find(std::string(key));
  return it == d.towers.end() ? nullptr : &it->second;
}

}  // namespace

std::span<const ParamKey<Delta>> Delta::keys() {
  using Opt = std::optional<double>;
  static const std::vector<ParamKey<Delta>> keys = {
      {"delta", "radius", KeyBound::positive, "mm",
       "Delta: horizontal distance from the centre to each tower's arm joint (Klipper "
       "[printer] delta_radius; required for a delta).",
       [](Delta& d, std::string_view, bool) -> Opt* { return &d.radius_mm; }},
      {"delta", "print_radius", KeyBound::positive, "mm",
       "Delta: radius of the printable disc (Klipper print_radius; unset = radius).",
       [](Delta& d, std::string_view, bool) -> Opt* { return &d.print_radius_mm; }},
      {"delta", "minimum_z_position", KeyBound::finite, "mm",
       "Delta: lowest Z a move may reach (Klipper minimum_z_position; unset = 0).",
       [](Delta& d, std::string_view, bool) -> Opt* { return &d.minimum_z_position_mm; }},
      {"stepper", "arm_length", KeyBound::positive, "mm",
       "Delta towers (stepper_a, _b, _c): length of the diagonal rods (Klipper arm_length; "
       "unset on b and c = a's).",
       [](Delta& d, std::string_view i, bool c) -> Opt* {
         DeltaTower* t = tower_of(d, i, c);
         return t ? &t->arm_length_mm : nullptr;
       }},
      {"stepper", "angle", KeyBound::finite, "degrees",
       "Delta towers: angle of the tower around the centre (Klipper angle; unset = 210, 330, "
       "90 for a, b, c).",
       [](Delta& d, std::string_view i, bool c) -> Opt* {
         DeltaTower* t = tower_of(d, i, c);
         return t ? &t->angle_deg : nullptr;
       }},
      {"stepper", "position_endstop", KeyBound::finite, "mm",
       "Klipper position_endstop: the position after homing (informative).",
       [](Delta& d, std::string_view i, bool c) -> Opt* {
         DeltaTower* t = tower_of(d, i, c);
         return t ? &t->position_endstop_mm : nullptr;
       }},
  };
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const Delta& p, const Context& ctx) {
  return std::make_unique<DeltaKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
