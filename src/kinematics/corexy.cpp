// corexy.py gives rail 0 (stepper_x) the '+' callback of kin_corexy.c, rail 1 the '-' one: A = X + Y, B = X - Y.
#include "amctl/kinematics/corexy.hpp"

#include "rail_kinematics.hpp"

namespace amctl::kinematics {
namespace {

constexpr detail::MotorRows kRows{{1, 1, 0, 0}, {1, -1, 0, 0}, {0, 0, 1, 0}};

}  // namespace

std::vector<KlipperStepper> CoreXY::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

CoreXY CoreXY::from_klipper(const KlipperConfig& cfg) { return detail::rails_from_klipper<CoreXY>(cfg); }

std::span<const ParamKey<CoreXY>> CoreXY::keys() { return detail::rail_keys<CoreXY>(); }

std::unique_ptr<Kinematics> make_kinematics(const CoreXY& p, const Context& ctx) {
  return std::make_unique<detail::RailKinematics<CoreXY>>(p, ctx, kRows);
}

}  // namespace amctl::kinematics
