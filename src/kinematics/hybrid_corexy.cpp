// hybrid_corexy.py allocates corexy's '-' callback for rail 0: stepper_x = X - Y; Y and Z cartesian.
#include "amctl/kinematics/hybrid_corexy.hpp"

namespace amctl::kinematics {
namespace {

constexpr std::array<double, 4> kRowX{1, -1, 0, 0}, kRowY{0, 1, 0, 0}, kRowZ{0, 0, 1, 0};

class HybridCoreXYKinematics final : public Kinematics {
 public:
  HybridCoreXYKinematics(const HybridCoreXY& p, const Context& ctx) : p_(p), th_(ctx.toolhead) {
    detail::check_rails(p.rails);
    detail::check_dual_carriage(p.rails, p.dual_carriage);
  }
  std::string_view name() const override { return HybridCoreXY::kName; }
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
  HybridCoreXY p_;
  Toolhead th_;
};

}  // namespace

std::vector<KlipperStepper> HybridCoreXY::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

HybridCoreXY HybridCoreXY::from_klipper(const KlipperConfig& cfg) {
  HybridCoreXY k;
  for (const KlipperStepper& s : klipper_steppers(cfg)) detail::read_rail(cfg.section(s.section), k.rails, s.key);
  k.dual_carriage = detail::read_dual_carriage(cfg);
  return k;
}

std::span<const ParamKey<HybridCoreXY>> HybridCoreXY::keys() {
  static const std::vector<ParamKey<HybridCoreXY>> keys = [] {
    std::vector<ParamKey<HybridCoreXY>> k;
    detail::add_rail_keys(k);
    detail::add_dual_carriage_keys(k);
    return k;
  }();
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const HybridCoreXY& p, const Context& ctx) {
  return std::make_unique<HybridCoreXYKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
