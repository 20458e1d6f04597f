#pragma once
// CoreXY: stepper_x = A = X + Y, stepper_y = B = X - Y (kin_corexy.c; corexy.py gives
// rail 0 the '+' callback, rail 1 the '-' one), stepper_z* = Z.
// klippy/kinematics/corexy.py, chelper/kin_corexy.c (read at 84104bbb, nothing copied).
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct CoreXY {
  static constexpr std::string_view kName = "corexy";
  Rails rails;
  bool operator==(const CoreXY&) const = default;

  /// printer.cfg: [stepper_x], [stepper_y], [stepper_z] and their extra steppers
  /// (stepper_z1, ...).
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  [[nodiscard]] static CoreXY from_klipper(const KlipperConfig& cfg);
  /// [printer] options beyond the toolhead's: none.
  [[nodiscard]] static std::span<const std::string_view> printer_options() { return {}; }
  /// TOML keys: the rails' position_min, position_max, position_endstop.
  [[nodiscard]] static std::span<const ParamKey<CoreXY>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): none.
  [[nodiscard]] bool owns_stepper(std::string_view) const { return false; }
  static Rail* rail(CoreXY& k, std::string_view key, bool create) {
    return detail::rail_of(k.rails, key, create);
  }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const CoreXY& p, const Context& ctx);

}  // namespace amctl::kinematics
