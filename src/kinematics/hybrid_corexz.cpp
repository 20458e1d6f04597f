// hybrid_corexz.py allocates corexz's '-' callback for rail 0: stepper_x = X - Z; Y and Z cartesian.
#include "amctl/kinematics/hybrid_corexz.hpp"

#include "rail_kinematics.hpp"

namespace amctl::kinematics {
namespace {

constexpr detail::MotorRows kRows{{1, 0, -1, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

}  // namespace

std::vector<KlipperStepper> HybridCoreXZ::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

HybridCoreXZ HybridCoreXZ::from_klipper(const KlipperConfig& cfg) { return detail::rails_from_klipper<HybridCoreXZ>(cfg); }

std::span<const ParamKey<HybridCoreXZ>> HybridCoreXZ::keys() { return detail::rail_keys<HybridCoreXZ>(); }

std::unique_ptr<Kinematics> make_kinematics(const HybridCoreXZ& p, const Context& ctx) {
  return std::make_unique<detail::RailKinematics<HybridCoreXZ>>(p, ctx, kRows);
}

}  // namespace amctl::kinematics
