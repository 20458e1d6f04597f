#pragma once
// Stepper motor presets: the datasheet values of the motors common on 3D printers, selectable
// by name with the `motor` key of a [stepper_*] section (TOML, printer.cfg, or a printer.cfg's
// [autotune_tmc stepper_x] motor). Step-level physics only (amctl stepper simulate,
// docs/closedloop.md section 1); docs/machine.md gives each number's source.
#include <span>
#include <string>
#include <string_view>

namespace amctl::machine {

struct MotorPreset {
  std::string_view name;          ///< the key's value, lower case ("ldo-42sth48-2004mah")
  std::string_view description;   ///< what it is ("LDO 0.9 deg NEMA17, 48 mm, Voron 2.4 Rev D A/B")
  int full_steps_per_rotation = 200;
  double holding_torque_n_m = 0.0;   ///< two phases at the rated current
  double rated_current_a = 0.0;      ///< per phase
  double phase_resistance_ohm = 0.0;
  double phase_inductance_h = 0.0;
  double rotor_inertia_kg_m2 = 0.0;
  double detent_torque_n_m = 0.0;
};

/// Every preset, the default (17hs4401) first.
[[nodiscard]] std::span<const MotorPreset> motor_presets();
/// The preset of that name (case-insensitive), or nullptr.
[[nodiscard]] const MotorPreset* find_motor_preset(std::string_view name);
/// The preset a stepper without a `motor` key is simulated with (17hs4401).
[[nodiscard]] const MotorPreset& default_motor_preset();
/// "17hs4401, ldo-42sth48-2504ac, ..." for error messages.
[[nodiscard]] std::string motor_preset_names();

}  // namespace amctl::machine
