// hybrid_corexy.py allocates corexy's '-' callback for rail 0: stepper_x = X - Y; Y and Z cartesian.
#include "amctl/kinematics/hybrid_corexy.hpp"

#include "rail_kinematics.hpp"

namespace amctl::kinematics {
namespace {

constexpr detail::MotorRows kRows{{1, -1, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

}  // namespace

std::vector<KlipperStepper> HybridCoreXY::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

HybridCoreXY HybridCoreXY::from_klipper(const KlipperConfig& cfg) { return detail::rails_from_klipper<HybridCoreXY>(cfg); }

std::span<const ParamKey<HybridCoreXY>> HybridCoreXY::keys() { return detail::rail_keys<HybridCoreXY>(); }

std::unique_ptr<Kinematics> make_kinematics(const HybridCoreXY& p, const Context& ctx) {
  return std::make_unique<detail::RailKinematics<HybridCoreXY>>(p, ctx, kRows);
}

}  // namespace amctl::kinematics
