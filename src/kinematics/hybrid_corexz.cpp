// hybrid_corexz.py allocates corexz's '-' callback for rail 0: stepper_x = X - Z; Y and Z cartesian.
#include "amctl/kinematics/hybrid_corexz.hpp"

namespace amctl::kinematics {
namespace {

constexpr std::array<double, 4> kRowX{1, 0, -1, 0}, kRowY{0, 1, 0, 0}, kRowZ{0, 0, 1, 0};

class HybridCoreXZKinematics final : public Kinematics {
 public:
  HybridCoreXZKinematics(const HybridCoreXZ& p, const Context& ctx) : p_(p), th_(ctx.toolhead) {
    detail::check_rails(p.rails);
    detail::check_dual_carriage(p.rails, p.dual_carriage);
  }
  std::string_view name() const override { return HybridCoreXZ::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    return detail::cartesian_motors(keys, kRowX, kRowY, kRowZ, missing);
  }
  MoveRules move_rules() const override { return detail::cartesian_move_rules(p_.rails, th_); }
  std::vector<IdexPair> idex_pairs() const override {
    if (!p_.dual_carriage || p_.dual_carriage->axis.empty()) return {};
    return {detail::idex_pair(p_.rails, *p_.dual_carriage)};
  }
  Homing homing() const override {
    Homing h = detail::cartesian_homing(p_.rails);
    // G28 puts the first carriage of an IDEX axis at its endstop.
    if (p_.dual_carriage && !p_.dual_carriage->axis.empty()) {
      const IdexPair d = detail::idex_pair(p_.rails, *p_.dual_carriage);
      h.position_mm[static_cast<std::size_t>(d.axis)] = d.position_endstop_mm[0];
    }
    return h;
  }
  std::optional<LinearMap> linear_map() const override {
    std::vector<std::string> missing;
    return detail::linear_map_of(motors({"x", "y", "z"}, missing));
  }

 private:
  HybridCoreXZ p_;
  Toolhead th_;
};

}  // namespace

std::vector<KlipperStepper> HybridCoreXZ::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

HybridCoreXZ HybridCoreXZ::from_klipper(const KlipperConfig& cfg) {
  HybridCoreXZ k;
  for (const KlipperStepper& s : klipper_steppers(cfg)) detail::read_rail(cfg.section(s.section), k.rails, s.key);
  k.dual_carriage = detail::read_dual_carriage(cfg);
  return k;
}

std::span<const ParamKey<HybridCoreXZ>> HybridCoreXZ::keys() {
  static const std::vector<ParamKey<HybridCoreXZ>> keys = [] {
    std::vector<ParamKey<HybridCoreXZ>> k;
    detail::add_rail_keys(k);
    detail::add_dual_carriage_keys(k);
    return k;
  }();
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const HybridCoreXZ& p, const Context& ctx) {
  return std::make_unique<HybridCoreXZKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
