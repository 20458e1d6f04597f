#pragma once
// Hybrid CoreXY (Markforged): stepper_x = X - Y (the '-' callback
// hybrid_corexy.py allocates for rail 0), stepper_y = Y, stepper_z* = Z; an optional
// [dual_carriage] on X or Y.
// klippy/kinematics/hybrid_corexy.py, chelper/kin_corexy.c (read at 84104bbb, nothing copied).
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct HybridCoreXY {
  static constexpr std::string_view kName = "hybrid_corexy";
  Rails rails;
  std::optional<DualCarriage> dual_carriage;
  bool operator==(const HybridCoreXY&) const = default;

  /// printer.cfg: [stepper_x], [stepper_y], [stepper_z] and their extra steppers
  /// (stepper_z1, ...), [dual_carriage].
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  [[nodiscard]] static HybridCoreXY from_klipper(const KlipperConfig& cfg);
  /// [printer] options beyond the toolhead's: none.
  [[nodiscard]] static std::span<const std::string_view> printer_options() { return {}; }
  /// TOML keys: the rails' position_min, position_max, position_endstop and [dual_carriage].
  [[nodiscard]] static std::span<const ParamKey<HybridCoreXY>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): none.
  [[nodiscard]] bool owns_stepper(std::string_view) const { return false; }
  static Rail* rail(HybridCoreXY& k, std::string_view key, bool create) {
    return detail::rail_of(k.rails, key, create);
  }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const HybridCoreXY& p, const Context& ctx);

}  // namespace amctl::kinematics
