#pragma once
// Klipper's `none` kinematics (klippy/kinematics/none.py): no motors and no check; the
// toolhead's limits only. A developer kinematics, also what amctl's `default` preset uses
// when it plans without knowing the printer's motors.
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/keys.hpp"
#include "amctl/kinematics/kinematics.hpp"
#include "amctl/kinematics/klipper_config.hpp"

namespace amctl::kinematics {

struct None {
  static constexpr std::string_view kName = "none";
  bool operator==(const None&) const = default;

  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig&) { return {}; }
  [[nodiscard]] static None from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options() { return {}; }
  [[nodiscard]] static std::span<const ParamKey<None>> keys() { return {}; }
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): none.
  [[nodiscard]] bool owns_stepper(std::string_view) const { return false; }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const None& p, const Context& ctx);

}  // namespace amctl::kinematics
