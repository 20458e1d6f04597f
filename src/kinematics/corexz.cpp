// kin_corexz.c: stepper_x = X + Z, stepper_z* = X - Z; Y cartesian.
#include "amctl/kinematics/corexz.hpp"

namespace amctl::kinematics {
namespace {

constexpr std::array<double, 4> kRowX{1, 0, 1, 0}, kRowY{0, 1, 0, 0}, kRowZ{1, 0, -1, 0};

class CoreXZKinematics final : public Kinematics {
 public:
  CoreXZKinematics(const CoreXZ& p, const Context& ctx) : p_(p), th_(ctx.toolhead) {
    detail::check_rails(p.rails);
  }
  std::string_view name() const override { return CoreXZ::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    return detail::cartesian_motors(keys, kRowX, kRowY, kRowZ, missing);
  }
  MoveRules move_rules() const override { return detail::cartesian_move_rules(p_.rails, th_); }
  Homing homing() const override { return detail::cartesian_homing(p_.rails); }
  std::optional<LinearMap> linear_map() const override {
    std::vector<std::string> missing;
    return detail::linear_map_of(motors({"x", "y", "z"}, missing));
  }

 private:
  CoreXZ p_;
  Toolhead th_;
};

}  // namespace

std::vector<KlipperStepper> CoreXZ::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

CoreXZ CoreXZ::from_klipper(const KlipperConfig& cfg) {
  CoreXZ k;
  for (const KlipperStepper& s : klipper_steppers(cfg)) detail::read_rail(cfg.section(s.section), k.rails, s.key);
  detail::refuse_dual_carriage(cfg);
  return k;
}

std::span<const ParamKey<CoreXZ>> CoreXZ::keys() {
  static const std::vector<ParamKey<CoreXZ>> keys = [] {
    std::vector<ParamKey<CoreXZ>> k;
    detail::add_rail_keys(k);
    return k;
  }();
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const CoreXZ& p, const Context& ctx) {
  return std::make_unique<CoreXZKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
