// kin_corexz.c: stepper_x = X + Z, stepper_z* = X - Z; Y cartesian.
#include "amctl/kinematics/corexz.hpp"

#include "rail_kinematics.hpp"

namespace amctl::kinematics {
namespace {

constexpr detail::MotorRows kRows{{1, 0, 1, 0}, {0, 1, 0, 0}, {1, 0, -1, 0}};

}  // namespace

std::vector<KlipperStepper> CoreXZ::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

CoreXZ CoreXZ::from_klipper(const KlipperConfig& cfg) { return detail::rails_from_klipper<CoreXZ>(cfg); }

std::span<const ParamKey<CoreXZ>> CoreXZ::keys() { return detail::rail_keys<CoreXZ>(); }

std::unique_ptr<Kinematics> make_kinematics(const CoreXZ& p, const Context& ctx) {
  return std::make_unique<detail::RailKinematics<CoreXZ>>(p, ctx, kRows);
}

}  // namespace amctl::kinematics
