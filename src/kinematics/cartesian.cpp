// stepper_x = X, stepper_y = Y, stepper_z* = Z (kin_cartesian.c).
#include "amctl/kinematics/cartesian.hpp"

#include "rail_kinematics.hpp"

namespace amctl::kinematics {
namespace {

constexpr detail::MotorRows kRows{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

}  // namespace

std::vector<KlipperStepper> Cartesian::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

Cartesian Cartesian::from_klipper(const KlipperConfig& cfg) { return detail::rails_from_klipper<Cartesian>(cfg); }

std::span<const ParamKey<Cartesian>> Cartesian::keys() { return detail::rail_keys<Cartesian>(); }

std::unique_ptr<Kinematics> make_kinematics(const Cartesian& p, const Context& ctx) {
  return std::make_unique<detail::RailKinematics<Cartesian>>(p, ctx, kRows);
}

}  // namespace amctl::kinematics
