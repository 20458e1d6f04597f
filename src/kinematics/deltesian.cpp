// Deltesian: the geometry Klipper derives at start-up (deltesian.py), the towers' carriage
// heights (kin_deltesian.c), the slow zones in |x| and the limits of check_move, homing.
#include "amctl/kinematics/deltesian.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "detail.hpp"

namespace amctl::kinematics {

double DeltesianGeometry::pillars_z_max(double x) const {
  const double l = std::sqrt(arm2_mm2[0] - (arm_x_mm[0] + x) * (arm_x_mm[0] + x));
  const double r = std::sqrt(arm2_mm2[1] - (arm_x_mm[1] - x) * (arm_x_mm[1] - x));
  return std::min(abs_endstop_mm[0] - l, abs_endstop_mm[1] - r);
}

DeltesianGeometry deltesian_geometry(const Deltesian& p) {
  DeltesianGeometry g;
  static const DeltesianTower kNone;
  const auto lit = p.towers.find("left"), rit = p.towers.find("right");
  const DeltesianTower* towers[2] = {lit == p.towers.end() ? &kNone : &lit->second,
                                     rit == p.towers.end() ? &kNone : &rit->second};
  const auto y = p.rails.find("y");
  if (y == p.rails.end() || !y->second.position_max_mm) {
    throw Error("a deltesian needs [stepper_y] with position_max");
  }
  const DeltesianTower& left = *towers[0];
  if (!left.arm_x_length_mm) throw Error("stepper_left.arm_x_length must be given for a deltesian");
  if (!left.arm_length_mm) throw Error("stepper_left.arm_length must be given for a deltesian");
  if (!left.position_endstop_mm) {
    throw Error("stepper_left.position_endstop must be given for a deltesian");
  }
  std::array<double, 2> arm{}, endstop{};
  for (std::size_t i = 0; i < 2; ++i) {
    const DeltesianTower& s = *towers[i];
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
  const double min_angle = p.min_angle_deg.value_or(5.0);
  if (min_angle > 90.0) throw Error(fmt::format("delta.min_angle must be <= 90, got {}", min_angle));
  const double cos_angle = std::cos(min_angle * std::numbers::pi / 180.0);
  const double x_min = std::ceil(-std::min(g.arm_x_mm[0], cos_angle * arm[1] - g.arm_x_mm[1]));
  const double x_max = std::floor(std::min(g.arm_x_mm[1], cos_angle * arm[0] - g.arm_x_mm[0]));
  const double x_range = std::min({x_max - x_min, 2.0 * x_max, -2.0 * x_min});
  const double width = p.print_width_mm.value_or(0.0);
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
  const double z_min = p.minimum_z_position_mm.value_or(0.0);
  if (z_min > z_max) {
    throw Error(fmt::format("delta.minimum_z_position ({} mm) must be <= {} mm", z_min, z_max));
  }
  g.limits_mm[2] = {z_min, z_max};
  const double ratio = p.slow_ratio.value_or(3.0);
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

namespace {

class DeltesianKinematics final : public Kinematics {
 public:
  DeltesianKinematics(const Deltesian& p, const Context& ctx) : th_(ctx.toolhead) {
    for (const char* name : {"left", "right"}) {
      if (ctx.step_distance.count(name) == 0) {
        throw Error(fmt::format("a deltesian needs [stepper_left], [stepper_right] and "
                                "[stepper_y]; stepper_{} is missing",
                                name));
      }
    }
    detail::check_rails(p.rails);
    g_ = deltesian_geometry(p);
  }
  std::string_view name() const override { return Deltesian::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    std::vector<Motor> out;
    for (const char* k : {"left", "right", "y"}) {
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) {
        missing.push_back(stepper_name(k));
        continue;
      }
      Motor m;
      m.name = stepper_name(k);
      m.key = k;
      if (k[0] == 'y') {
        m.row = {0, 1, 0, 0};
      } else {
        const std::size_t i = k[0] == 'l' ? 0 : 1;
        m.curve = detail::tower_curve(g_.arm2_mm2[i], g_.tower_x_mm[i], 0.0, true, "deltesian");
      }
      out.push_back(std::move(m));
    }
    return out;
  }
  MoveRules move_rules() const override {
    MoveRules r;
    r.z_velocity_mm_s = th_.max_z_velocity_mm_s > 0 ? th_.max_z_velocity_mm_s : th_.max_velocity_mm_s;
    r.z_accel_mm_s2 = th_.max_z_accel_mm_s2 > 0 ? th_.max_z_accel_mm_s2 : th_.max_accel_mm_s2;
    r.special = true;  // its X, Y, Z ranges always checked
    return r;
  }
  std::optional<RangeViolation> check_range(const MoveGeometry& m) const override {
    // deltesian.py check_move: every moving axis must end inside its limits; above the top of
    // the volume the Z limit is the carriages' reach at that X; a move to (0, home_z) without
    // Y motion is homing and allowed.
    const double x = m.end[0], z = m.end[2];
    const bool homing = x == 0.0 && z == g_.home_z_mm && m.end[1] == m.start[1];
    if (homing) return std::nullopt;
    auto limits = g_.limits_mm;
    if (z > limits[2][1]) limits[2][1] = g_.pillars_z_max(x);
    for (std::size_t i = 0; i < 3; ++i) {
      if (m.end[i] == m.start[i]) continue;
      const double p = m.end[i];
      if (p < limits[i][0] || p > limits[i][1]) {
        RangeViolation e;
        e.axis = "xyz"[i];
        e.position_mm = p;
        e.limit_mm = p < limits[i][0] ? limits[i][0] : limits[i][1];
        return e;
      }
    }
    return std::nullopt;
  }
  void limit_move(const MoveGeometry& m, double& velocity, double& accel) const override {
    // deltesian.py: moves with X motion beyond slow_x2 (very_slow_x2) at 1/2 (1/4) of the
    // configured limits.
    const double extreme_x2 = std::max(m.start[0] * m.start[0], m.end[0] * m.end[0]);
    const bool applies = m.d[0] != 0.0 && g_.slow_x2_mm2 > 0.0 && g_.very_slow_x2_mm2 > 0.0;
    if (applies && extreme_x2 > g_.slow_x2_mm2) {
      const double f = extreme_x2 > g_.very_slow_x2_mm2 ? 0.25 : 0.5;
      velocity = std::min(velocity, th_.max_velocity_mm_s * f);
      accel = std::min(accel, th_.max_accel_mm_s2 * f);
    }
  }
  Homing homing() const override {
    // deltesian.py home(): X and Z home together to (0, home_z); Y to its endstop. amctl homes
    // all three on any G28.
    Homing h;
    h.all_axes = true;
    h.position_mm = {0.0, g_.home_y_mm, g_.home_z_mm};
    return h;
  }

 private:
  Toolhead th_;
  DeltesianGeometry g_;
};

}  // namespace

std::vector<KlipperStepper> Deltesian::klipper_steppers(const KlipperConfig& cfg) {
  for (const char* tower : {"stepper_left", "stepper_right", "stepper_y"}) {
    if (!cfg.has(tower)) {
      throw Error(cfg.printer_where(),
                  fmt::format("a deltesian needs [{}] (stepper_left, stepper_right, stepper_y)", tower));
    }
  }
  std::vector<KlipperStepper> out;
  for (const ConfigSection& s : cfg.sections()) {
    if (s.name == "stepper_left" || s.name == "stepper_right") out.push_back({s.name, s.name.substr(8), false});
  }
  for (KlipperStepper& s : detail::axis_steppers(cfg, "xyz")) out.push_back(std::move(s));
  return out;
}

Deltesian Deltesian::from_klipper(const KlipperConfig& cfg) {
  // deltesian.py: min_angle (5, [0, 90]), print_width (>= 0, at most the arms' reach:
  // deltesian_geometry), slow_ratio (3, >= 0), minimum_z_position (0).
  const KlipperSection printer = cfg.section("printer");
  Deltesian d;
  d.min_angle_deg = printer.get_float("min_angle", {.minval = 0.0, .maxval = 90.0});
  d.print_width_mm = printer.get_float("print_width", {.minval = 0.0});
  d.slow_ratio = printer.get_float("slow_ratio", {.minval = 0.0});
  d.minimum_z_position_mm = printer.get_float("minimum_z_position");
  for (const KlipperStepper& s : klipper_steppers(cfg)) {
    const KlipperSection sec = cfg.section(s.section);
    if (s.key != "left" && s.key != "right") {
      detail::read_rail(sec, d.rails, s.key);
      continue;
    }
    // deltesian.py: arm_x_length (> 0) and arm_length (> arm_x_length) required on left,
    // right defaults to left's; position_endstop required on left.
    DeltesianTower& t = d.towers[s.key];
    const bool left = s.key == "left";
    t.arm_x_length_mm = left ? std::optional(sec.require_float("arm_x_length", {.above = 0.0}))
                             : sec.get_float("arm_x_length", {.above = 0.0});
    t.arm_length_mm = left ? std::optional(sec.require_float("arm_length", {.above = 0.0}))
                           : sec.get_float("arm_length", {.above = 0.0});
    t.position_endstop_mm = left ? std::optional(sec.require_float("position_endstop"))
                                 : sec.get_float("position_endstop");
  }
  // Sections that give none of these keys hold no entry (as a TOML machine reads them).
  std::erase_if(d.towers, [](const auto& kv) { return kv.second == DeltesianTower{}; });
  detail::refuse_dual_carriage(cfg);
  return d;
}

std::span<const std::string_view> Deltesian::printer_options() {
  static constexpr std::string_view kOptions[] = {"min_angle", "print_width", "slow_ratio",
                                                  "minimum_z_position"};
  return kOptions;
}

namespace {

DeltesianTower* tower_of(Deltesian& d, std::string_view key, bool create) {
  if (key != "left" && key != "right") return nullptr;
  if (create) return &d.towers[std::string(key)];
  const auto it = d.towers.find(std::string(key));
  return it == d.towers.end() ? nullptr : &it->second;
}

}  // namespace

std::span<const ParamKey<Deltesian>> Deltesian::keys() {
  using Opt = std::optional<double>;
  static const std::vector<ParamKey<Deltesian>> keys = [] {
    std::vector<ParamKey<Deltesian>> k = {
        {"delta", "min_angle", KeyBound::non_negative, "degrees",
         "Deltesian: smallest angle of the arms with the horizontal (Klipper min_angle; unset = "
         "5).",
         [](Deltesian& d, std::string_view, bool) -> Opt* { return &d.min_angle_deg; }},
        {"delta", "print_width", KeyBound::non_negative, "mm",
         "Deltesian: printable width in X, centred (Klipper print_width; unset = the arms' "
         "reach).",
         [](Deltesian& d, std::string_view, bool) -> Opt* { return &d.print_width_mm; }},
        {"delta", "slow_ratio", KeyBound::non_negative, "",
         "Deltesian: carriage-to-effector speed ratio beyond which moves run at half (twice it: "
         "a quarter) of the limits (Klipper slow_ratio; unset = 3, 0 = off).",
         [](Deltesian& d, std::string_view, bool) -> Opt* { return &d.slow_ratio; }},
        {"delta", "minimum_z_position", KeyBound::finite, "mm",
         "Deltesian: lowest Z a move may reach (Klipper minimum_z_position; unset = 0).",
         [](Deltesian& d, std::string_view, bool) -> Opt* { return &d.minimum_z_position_mm; }},
        {"stepper", "arm_x_length", KeyBound::positive, "mm",
         "Deltesian towers (stepper_left, stepper_right): horizontal distance from the centre to "
         "the arm's carriage joint (Klipper arm_x_length; required on left).",
         [](Deltesian& d, std::string_view i, bool c) -> Opt* {
           DeltesianTower* t = tower_of(d, i, c);
           return t ? &t->arm_x_length_mm : nullptr;
         }},
        {"stepper", "arm_length", KeyBound::positive, "mm",
         "Deltesian towers: length of the arm from the carriage to the effector (Klipper "
         "arm_length; required on left).",
         [](Deltesian& d, std::string_view i, bool c) -> Opt* {
           DeltesianTower* t = tower_of(d, i, c);
           return t ? &t->arm_length_mm : nullptr;
         }},
        {"stepper", "position_endstop", KeyBound::finite, "mm",
         "Klipper position_endstop: the position after homing (informative).",
         [](Deltesian& d, std::string_view i, bool c) -> Opt* {
           DeltesianTower* t = tower_of(d, i, c);
           return t ? &t->position_endstop_mm : nullptr;
         }},
    };
    detail::add_rail_keys(k);
    return k;
  }();
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const Deltesian& p, const Context& ctx) {
  return std::make_unique<DeltesianKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
