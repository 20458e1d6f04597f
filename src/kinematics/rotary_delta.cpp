// Rotary delta: the geometry Klipper derives at start-up (rotary_delta.py), the arm angles
// (kin_rotary_delta.c), the Z speed cap and build volume of check_move, homing.
#include "amctl/kinematics/rotary_delta.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/kinematics/delta.hpp"
#include "amctl/kinematics/rails.hpp"
#include "detail.hpp"

namespace amctl::kinematics {

double RotaryDeltaGeometry::arm_angle_rad(int arm, double x, double y, double z) const {
  const auto i = static_cast<std::size_t>(arm);
  const double ca = std::cos(angle_rad[i]), sa = std::sin(angle_rad[i]);
  const double u = x * ca + y * sa - shoulder_radius_mm;  // outward in the arm's plane
  const double v = z - shoulder_height_mm;                // up
  const double w = y * ca - x * sa;                       // off the plane
  const double l2 = lower_arm_mm[i] * lower_arm_mm[i] - w * w;
  const double u2 = upper_arm_mm[i] * upper_arm_mm[i];
  const double p2 = u * u + v * v;
  const double p = std::sqrt(p2);
  // e . p = (|p|^2 + U^2 - l^2) / 2 = U |p| cos(alpha - phi).
  const double c = (p2 + u2 - l2) / (2.0 * upper_arm_mm[i] * p);
  if (!(c >= -1.0 && c <= 1.0)) return std::numeric_limits<double>::quiet_NaN();
  const double phi = std::atan2(v, u), delta = std::acos(c);
  const double a1 = phi + delta, a2 = phi - delta;
  // The outer elbow (larger horizontal coordinate).
  return std::cos(a1) >= std::cos(a2) ? std::remainder(a1, 2.0 * std::numbers::pi)
                                      : std::remainder(a2, 2.0 * std::numbers::pi);
}

Vec3 RotaryDeltaGeometry::elbow_mm(int arm, double angle) const {
  const auto i = static_cast<std::size_t>(arm);
  const double r = upper_arm_mm[i] * std::cos(angle) + shoulder_radius_mm;
  return {r * std::cos(angle_rad[i]), r * std::sin(angle_rad[i]),
          upper_arm_mm[i] * std::sin(angle) + shoulder_height_mm};
}

double RotaryDeltaGeometry::limit_xy2_at(double z) const {
  if (z <= limit_z_mm) return max_xy2_mm2;
  return std::min(max_xy2_mm2, (max_z_mm - z) * (max_z_mm - z));
}

RotaryDeltaGeometry rotary_delta_geometry(const RotaryDelta& p) {
  RotaryDeltaGeometry g;
  if (!p.shoulder_radius_mm) throw Error("delta.shoulder_radius must be given for a rotary delta");
  if (!p.shoulder_height_mm) throw Error("delta.shoulder_height must be given for a rotary delta");
  g.shoulder_radius_mm = *p.shoulder_radius_mm;
  g.shoulder_height_mm = *p.shoulder_height_mm;
  static const RotaryArm kNone;
  const RotaryArm* arms[3];
  for (std::size_t i = 0; i < 3; ++i) {
    const auto it = p.arms.find(std::string(1, "abc"[i]));
    arms[i] = it == p.arms.end() ? &kNone : &it->second;
  }
  const RotaryArm& a = *arms[0];
  if (!a.upper_arm_length_mm) throw Error("stepper_a.upper_arm_length must be given for a rotary delta");
  if (!a.lower_arm_length_mm) throw Error("stepper_a.lower_arm_length must be given for a rotary delta");
  if (!a.position_endstop_mm) throw Error("stepper_a.position_endstop must be given for a rotary delta");
  constexpr double kDefaultAngles[] = {30.0, 150.0, 270.0};  // rotary_delta.py
  for (std::size_t i = 0; i < 3; ++i) {
    const RotaryArm& s = *arms[i];
    g.upper_arm_mm[i] = s.upper_arm_length_mm.value_or(*a.upper_arm_length_mm);
    g.lower_arm_mm[i] = s.lower_arm_length_mm.value_or(*a.lower_arm_length_mm);
    g.angle_rad[i] = s.angle_deg.value_or(kDefaultAngles[i]) * std::numbers::pi / 180.0;
    g.endstop_mm[i] = s.position_endstop_mm.value_or(*a.position_endstop_mm);
    if (!(g.lower_arm_mm[i] > g.shoulder_radius_mm)) {
      throw Error(fmt::format("stepper_{}.lower_arm_length ({} mm) must be > delta.shoulder_radius "
                              "({} mm)",
                              "abc"[i], g.lower_arm_mm[i], g.shoulder_radius_mm));
    }
  }
  std::array<Vec3, 3> elbows{};
  Vec3 lower2{};
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<std::size_t>(i);
    g.endstop_angle_rad[k] = g.arm_angle_rad(i, 0.0, 0.0, g.endstop_mm[k]);
    if (!std::isfinite(g.endstop_angle_rad[k])) {
      throw Error(fmt::format("stepper_{}.position_endstop ({} mm): the arms cannot reach the "
                              "centre at that height",
                              "abc"[k], g.endstop_mm[k]));
    }
    elbows[k] = g.elbow_mm(i, g.endstop_angle_rad[k]);
    lower2[k] = g.lower_arm_mm[k] * g.lower_arm_mm[k];
  }
  g.home_position_mm = trilaterate_below(elbows, lower2);
  g.max_z_mm = std::min({g.endstop_mm[0], g.endstop_mm[1], g.endstop_mm[2]});
  g.min_z_mm = p.minimum_z_position_mm.value_or(0.0);
  if (g.min_z_mm > g.max_z_mm) {
    throw Error(fmt::format("delta.minimum_z_position ({} mm) must be <= the lowest "
                            "position_endstop ({} mm)",
                            g.min_z_mm, g.max_z_mm));
  }
  double reach = std::numeric_limits<double>::infinity();
  g.limit_z_mm = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < 3; ++i) {
    reach = std::min({reach, g.shoulder_radius_mm + g.upper_arm_mm[i],
                      g.lower_arm_mm[i] - g.shoulder_radius_mm});
    g.limit_z_mm = std::min(g.limit_z_mm, elbows[i][2] - g.lower_arm_mm[i]);
  }
  g.max_xy2_mm2 = reach * reach;
  return g;
}

namespace {

/// An arm's angle: smooth along a line but with no shape to count on, so its turning points
/// are found on 16 intervals per move; the slope is a central difference.
class ArmCurve final : public MotorCurve {
 public:
  ArmCurve(std::shared_ptr<const RotaryDeltaGeometry> g, int arm) : g_(std::move(g)), arm_(arm) {
    samples_ = 16;
  }
  double position(const Vec3& p) const override { return g_->arm_angle_rad(arm_, p[0], p[1], p[2]); }
  std::string out_of_reach(const Vec3& p, std::string_view motor) const override {
    return fmt::format("the effector at X={:.3f} Y={:.3f} Z={:.3f} is out of reach of {}'s arms "
                       "(the move leaves the rotary delta's build volume)",
                       p[0], p[1], p[2], motor);
  }

 private:
  std::shared_ptr<const RotaryDeltaGeometry> g_;
  int arm_;
};

class RotaryDeltaKinematics final : public Kinematics {
 public:
  RotaryDeltaKinematics(const RotaryDelta& p, const Context& ctx)
      : p_(p),
        z_velocity_mm_s_(ctx.toolhead.max_z_velocity_mm_s > 0 ? ctx.toolhead.max_z_velocity_mm_s
                                                               : ctx.toolhead.max_velocity_mm_s) {
    if (!p.shoulder_radius_mm) throw Error("delta.shoulder_radius must be given for a rotary delta");
    if (!p.shoulder_height_mm) throw Error("delta.shoulder_height must be given for a rotary delta");
    for (const char* name : {"a", "b", "c"}) {
      if (ctx.step_distance.count(name) == 0) {
        throw Error(fmt::format("a rotary delta needs stepper_a, stepper_b and stepper_c; "
                                "stepper_{} is missing",
                                name));
      }
    }
    g_ = std::make_shared<RotaryDeltaGeometry>(rotary_delta_geometry(p));
  }
  std::string_view name() const override { return RotaryDelta::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    std::vector<Motor> out;
    for (int i = 0; i < 3; ++i) {
      const std::string k(1, static_cast<char>('a' + i));
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) {
        missing.push_back(stepper_name(k));
        continue;
      }
      Motor m;
      m.name = stepper_name(k);
      m.key = k;
      m.step_distance.unit = Unit::rad;
      m.curve = std::make_shared<ArmCurve>(g_, i);
      out.push_back(std::move(m));
    }
    return out;
  }
  MoveRules move_rules() const override {
    // rotary_delta.py: any move with Z motion at most max_z_velocity (no accel limit, not
    // scaled to the move); the build volume always checked.
    MoveRules r;
    r.special = true;
    return r;
  }
  std::optional<RangeViolation> check_range(const MoveGeometry& m) const override {
    // As delta.py's, the radius tapered to max_z - z above limit_z.
    return detail::tower_volume(*g_, m);
  }
  void limit_move(const MoveGeometry& m, double& velocity, double&) const override {
    if (m.d[2] != 0.0) velocity = std::min(velocity, z_velocity_mm_s_);
  }
  Homing homing() const override {
    // rotary_delta.py home(): all arms home together; the effector ends at the home position.
    Homing h;
    h.all_axes = true;
    for (std::size_t a = 0; a < 3; ++a) h.position_mm[a] = g_->home_position_mm[a];
    return h;
  }
  void describe(Json& j) const override {
    const RotaryDeltaGeometry& g = *g_;
    j["rotary_delta"] = {{"shoulder_radius", g.shoulder_radius_mm},
                         {"shoulder_height", g.shoulder_height_mm},
                         {"build_radius", std::sqrt(g.max_xy2_mm2)},
                         {"max_z", g.max_z_mm},
                         {"min_z", g.min_z_mm},
                         {"taper_start_z", g.limit_z_mm},
                         {"home_position", {g.home_position_mm[0], g.home_position_mm[1],
                                            g.home_position_mm[2]}}};
  }

 private:
  RotaryDelta p_;
  double z_velocity_mm_s_;
  std::shared_ptr<const RotaryDeltaGeometry> g_;
};

}  // namespace

std::vector<KlipperStepper> RotaryDelta::klipper_steppers(const KlipperConfig& cfg) {
  for (const char* arm : {"stepper_a", "stepper_b", "stepper_c"}) {
    if (!cfg.has(arm)) {
      throw Error(cfg.printer_where(),
                  fmt::format("a rotary delta needs [{}] (arms stepper_a, stepper_b, stepper_c)", arm));
    }
  }
  std::vector<KlipperStepper> out;
  for (const ConfigSection& s : cfg.sections()) {
    if (s.name == "stepper_a" || s.name == "stepper_b" || s.name == "stepper_c") {
      out.push_back({s.name, s.name.substr(8), true});
    }
  }
  return out;
}

RotaryDelta RotaryDelta::from_klipper(const KlipperConfig& cfg) {
  // rotary_delta.py: shoulder_radius, shoulder_height (required, > 0), minimum_z_position
  // (0, at most the lowest endstop: rotary_delta_geometry); max_z_accel is not an option.
  const KlipperSection printer = cfg.section("printer");
  RotaryDelta d;
  d.shoulder_radius_mm = printer.require_float("shoulder_radius", {.above = 0.0});
  d.shoulder_height_mm = printer.require_float("shoulder_height", {.above = 0.0});
  d.minimum_z_position_mm = printer.get_float("minimum_z_position");
  if (printer.has("max_z_accel")) {
    throw Error(printer.raw("max_z_accel")->where,
                "[printer] max_z_accel: not an option of a rotary delta (rotary_delta.py caps "
                "only the speed of moves with Z), expected no max_z_accel");
  }
  for (const KlipperStepper& s : klipper_steppers(cfg)) {
    // rotary_delta.py: arms in radians (gear_ratio); upper_arm_length, lower_arm_length and
    // position_endstop required on a, b and c default to a's; angle 30/150/270.
    const KlipperSection sec = cfg.section(s.section);
    RotaryArm& arm = d.arms[s.key];
    const bool a = s.key == "a";
    arm.upper_arm_length_mm = a ? std::optional(sec.require_float("upper_arm_length", {.above = 0.0}))
                                : sec.get_float("upper_arm_length", {.above = 0.0});
    arm.lower_arm_length_mm = a ? std::optional(sec.require_float("lower_arm_length", {.above = 0.0}))
                                : sec.get_float("lower_arm_length", {.above = 0.0});
    arm.angle_deg = sec.get_float("angle");
    arm.position_endstop_mm = a ? std::optional(sec.require_float("position_endstop"))
                                : sec.get_float("position_endstop");
  }
  // Sections that give none of these keys hold no entry (as a TOML machine reads them).
  std::erase_if(d.arms, [](const auto& kv) { return kv.second == RotaryArm{}; });
  detail::refuse_dual_carriage(cfg);
  return d;
}

std::span<const std::string_view> RotaryDelta::printer_options() {
  static constexpr std::string_view kOptions[] = {"shoulder_radius", "shoulder_height",
                                                  "minimum_z_position"};
  return kOptions;
}

namespace {

RotaryArm* arm_of(RotaryDelta& d, std::string_view key, bool create) {
  if (key != "a" && key != "b" && key != "c") return nullptr;
  if (create) return &d.arms[std::string(key)];
  const auto it = d.arms.find(std::string(key));
  return it == d.arms.end() ? nullptr : &it->second;
}

}  // namespace

std::span<const ParamKey<RotaryDelta>> RotaryDelta::keys() {
  using Opt = std::optional<double>;
  using R = RotaryDelta;
  static const std::vector<ParamKey<R>> keys = {
      {"delta", "shoulder_radius", KeyBound::positive, "mm",
       "Rotary delta: horizontal distance from the centre to each shoulder joint (Klipper "
       "[printer] shoulder_radius; required for a rotary delta).",
       [](R& d, std::string_view, bool) -> Opt* { return &d.shoulder_radius_mm; }},
      {"delta", "shoulder_height", KeyBound::positive, "mm",
       "Rotary delta: height of the shoulder joints above z = 0 (Klipper [printer] "
       "shoulder_height; required for a rotary delta).",
       [](R& d, std::string_view, bool) -> Opt* { return &d.shoulder_height_mm; }},
      {"delta", "minimum_z_position", KeyBound::finite, "mm",
       "Rotary delta: lowest Z a move may reach (Klipper minimum_z_position; unset = 0).",
       [](R& d, std::string_view, bool) -> Opt* { return &d.minimum_z_position_mm; }},
      {"stepper", "upper_arm_length", KeyBound::positive, "mm",
       "Rotary delta arms (stepper_a, _b, _c): shoulder-to-elbow length (Klipper "
       "upper_arm_length; required on a, b and c default to a's).",
       [](R& d, std::string_view i, bool c) -> Opt* {
         RotaryArm* a = arm_of(d, i, c);
         return a ? &a->upper_arm_length_mm : nullptr;
       }},
      {"stepper", "lower_arm_length", KeyBound::positive, "mm",
       "Rotary delta arms: elbow-to-effector length (Klipper lower_arm_length; required on a, "
       "b and c default to a's).",
       [](R& d, std::string_view i, bool c) -> Opt* {
         RotaryArm* a = arm_of(d, i, c);
         return a ? &a->lower_arm_length_mm : nullptr;
       }},
      {"stepper", "angle", KeyBound::finite, "degrees",
       "Rotary delta arms: azimuth of the arm around the centre (Klipper angle; unset = 30, "
       "150, 270 for a, b, c).",
       [](R& d, std::string_view i, bool c) -> Opt* {
         RotaryArm* a = arm_of(d, i, c);
         return a ? &a->angle_deg : nullptr;
       }},
      {"stepper", "position_endstop", KeyBound::finite, "mm",
       "Klipper position_endstop: the position after homing (informative).",
       [](R& d, std::string_view i, bool c) -> Opt* {
         RotaryArm* a = arm_of(d, i, c);
         return a ? &a->position_endstop_mm : nullptr;
       }},
  };
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const RotaryDelta& p, const Context& ctx) {
  return std::make_unique<RotaryDeltaKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
