// Winch: each cable's length |tool - anchor| (kin_winch.c); no limit is checked (winch.py).
#include "amctl/kinematics/winch.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {
namespace {

/// |p0 + u s - A|: the norm of an affine function of s, hence convex: at most one turning
/// point, where the cable goes from shortening to lengthening.
class CableCurve final : public MotorCurve {
 public:
  explicit CableCurve(const Vec3& anchor) : a_(anchor) {}
  double position(const Vec3& p) const override { return along(p, {0.0, 0.0, 0.0}, 0.0); }
  double along(const Vec3& p0, const Vec3& u, double s) const override {
    const double x = p0[0] - a_[0] + u[0] * s, y = p0[1] - a_[1] + u[1] * s,
                 z = p0[2] - a_[2] + u[2] * s;
    return std::sqrt(x * x + y * y + z * z);
  }
  double slope_along(const Vec3& p0, const Vec3& u, double s, double) const override {
    const double x = p0[0] - a_[0] + u[0] * s, y = p0[1] - a_[1] + u[1] * s;
    const double l = along(p0, u, s);
    return l > 0.0 ? (x * u[0] + y * u[1] + (p0[2] - a_[2] + u[2] * s) * u[2]) / l : 0.0;
  }

 private:
  Vec3 a_;
};

class WinchKinematics final : public Kinematics {
 public:
  explicit WinchKinematics(const Winch& p) : p_(p) {}
  std::string_view name() const override { return Winch::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    std::vector<Motor> out;
    for (const char* k : {"a", "b", "c", "d"}) {
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) {
        if (k[0] != 'd') missing.push_back(stepper_name(k));
        continue;
      }
      const auto it = p_.anchors.find(k);
      const WinchAnchor a = it == p_.anchors.end() ? WinchAnchor{} : it->second;
      Motor m;
      m.name = stepper_name(k);
      m.key = k;
      m.curve = std::make_shared<CableCurve>(Vec3{a.x_mm.value_or(0.0), a.y_mm.value_or(0.0),
                                                  a.z_mm.value_or(0.0)});
      out.push_back(std::move(m));
    }
    return out;
  }
  // Klipper's winch checks nothing: no Z limit, no range.
  MoveRules move_rules() const override { return {}; }

 private:
  Winch p_;
};

}  // namespace

std::vector<KlipperStepper> Winch::klipper_steppers(const KlipperConfig& cfg) {
  // winch.py: stepper_a, _b, _c required, more (d, e, ...) while present. amctl takes up to
  // four (stepper_e would be the extruder's name in amctl's TOML form).
  for (const char* cable : {"stepper_a", "stepper_b", "stepper_c"}) {
    if (!cfg.has(cable)) {
      throw Error(cfg.printer_where(),
                  fmt::format("a winch needs [{}] (cables stepper_a, stepper_b, stepper_c)", cable));
    }
  }
  if (cfg.has("stepper_d") && cfg.has("stepper_e")) {
    throw Error(cfg.section("stepper_e").where(),
                "amctl supports winches of 3 or 4 cables (stepper_a .. stepper_d)");
  }
  std::vector<KlipperStepper> out;
  for (const ConfigSection& s : cfg.sections()) {
    if (s.name == "stepper_a" || s.name == "stepper_b" || s.name == "stepper_c" || s.name == "stepper_d") {
      out.push_back({s.name, s.name.substr(8), false});
    }
  }
  return out;
}

Winch Winch::from_klipper(const KlipperConfig& cfg) {
  Winch w;
  for (const KlipperStepper& s : klipper_steppers(cfg)) {
    const KlipperSection sec = cfg.section(s.section);
    WinchAnchor& a = w.anchors[s.key];
    a.x_mm = sec.require_float("anchor_x");
    a.y_mm = sec.require_float("anchor_y");
    a.z_mm = sec.require_float("anchor_z");
  }
  detail::refuse_dual_carriage(cfg);
  return w;
}

namespace {

WinchAnchor* anchor_of(Winch& w, std::string_view key, bool create) {
  if (key != "a" && key != "b" && key != "c" && key != "d") return nullptr;
  if (create) return &w.anchors[std::string(key)];
  const auto it = w.anchors.find(std::string(key));
  return it == w.anchors.end() ? nullptr : &it->second;
}

}  // namespace

std::span<const ParamKey<Winch>> Winch::keys() {
  using Opt = std::optional<double>;
  static const std::vector<ParamKey<Winch>> keys = {
      {"stepper", "anchor_x", KeyBound::finite, "mm",
       "Winch cables (stepper_a .. stepper_d): X of the cable's anchor (Klipper anchor_x).",
       [](Winch& w, std::string_view i, bool c) -> Opt* {
         WinchAnchor* a = anchor_of(w, i, c);
         return a ? &a->x_mm : nullptr;
       }},
      {"stepper", "anchor_y", KeyBound::finite, "mm",
       "Winch cables: Y of the cable's anchor (Klipper anchor_y).",
       [](Winch& w, std::string_view i, bool c) -> Opt* {
         WinchAnchor* a = anchor_of(w, i, c);
         return a ? &a->y_mm : nullptr;
       }},
      {"stepper", "anchor_z", KeyBound::finite, "mm",
       "Winch cables: Z of the cable's anchor (Klipper anchor_z).",
       [](Winch& w, std::string_view i, bool c) -> Opt* {
         WinchAnchor* a = anchor_of(w, i, c);
         return a ? &a->z_mm : nullptr;
       }},
  };
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const Winch& p, const Context& ctx) {
  // A winch needs its three cables, each anchored.
  for (const char* cable : {"a", "b", "c", "d"}) {
    if (ctx.step_distance.count(cable) == 0) {
      if (cable[0] == 'd') break;
      throw Error(fmt::format("a winch needs stepper_a, stepper_b and stepper_c; stepper_{} is "
                              "missing",
                              cable));
    }
    const auto it = p.anchors.find(cable);
    if (it == p.anchors.end() || !it->second.x_mm || !it->second.y_mm || !it->second.z_mm) {
      throw Error(fmt::format("stepper_{}: a winch cable needs anchor_x, anchor_y and anchor_z",
                              cable));
    }
  }
  return std::make_unique<WinchKinematics>(p);
}

}  // namespace amctl::kinematics
