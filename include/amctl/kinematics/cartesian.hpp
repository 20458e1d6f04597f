#pragma once
// Cartesian: stepper_x = X, stepper_y = Y, stepper_z* = Z (kin_cartesian.c). An optional
// [dual_carriage] adds a second carriage on X or Y (IDEX, idex_modes.py).
// klippy/kinematics/cartesian.py, chelper/kin_cartesian.c (read at 84104bbb, nothing copied).
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct Cartesian {
  static constexpr std::string_view kName = "cartesian";
  Rails rails;
  std::optional<DualCarriage> dual_carriage;
  bool operator==(const Cartesian&) const = default;

  /// printer.cfg: [stepper_x], [stepper_y], [stepper_z] and their extra steppers
  /// (stepper_z1, ...), [dual_carriage].
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  [[nodiscard]] static Cartesian from_klipper(const KlipperConfig& cfg);
  /// [printer] options beyond the toolhead's: none.
  [[nodiscard]] static std::span<const std::string_view> printer_options() { return {}; }
  /// TOML keys: the rails' position_min, position_max, position_endstop and [dual_carriage].
  [[nodiscard]] static std::span<const ParamKey<Cartesian>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): none.
  [[nodiscard]] bool owns_stepper(std::string_view) const { return false; }
  static Rail* rail(Cartesian& k, std::string_view key, bool create) {
    return detail::rail_of(k.rails, key, create);
  }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const Cartesian& p, const Context& ctx);

}  // namespace amctl::kinematics
