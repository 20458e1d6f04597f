// corexy.py gives rail 0 (stepper_x) the '+' callback of kin_corexy.c, rail 1 the '-' one: A = X + Y, B = X - Y.
#include "amctl/kinematics/corexy.hpp"

namespace amctl::kinematics {
namespace {

constexpr std::array<double, 4> kRowX{1, 1, 0, 0}, kRowY{1, -1, 0, 0}, kRowZ{0, 0, 1, 0};

class CoreXYKinematics final : public Kinematics {
 public:
  CoreXYKinematics(const CoreXY& p, const Context& ctx) : p_(p), th_(ctx.toolhead) {
    detail::check_rails(p.rails);
  }
  std::string_view name() const override { return CoreXY::kName; }
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
  CoreXY p_;
  Toolhead th_;
};

}  // namespace

std::vector<KlipperStepper> CoreXY::klipper_steppers(const KlipperConfig& cfg) {
  return detail::axis_steppers(cfg, "xyz");
}

CoreXY CoreXY::from_klipper(const KlipperConfig& cfg) {
  CoreXY k;
  for (const KlipperStepper& s : klipper_steppers(cfg)) detail::read_rail(cfg.section(s.section), k.rails, s.key);
  detail::refuse_dual_carriage(cfg);
  return k;
}

std::span<const ParamKey<CoreXY>> CoreXY::keys() {
  static const std::vector<ParamKey<CoreXY>> keys = [] {
    std::vector<ParamKey<CoreXY>> k;
    detail::add_rail_keys(k);
    return k;
  }();
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const CoreXY& p, const Context& ctx) {
  return std::make_unique<CoreXYKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
