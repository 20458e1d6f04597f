// Winch: each cable's length |tool - anchor| (kin_winch.c); no limit is checked (winch.py).
#include "amctl/kinematics/winch.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

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
