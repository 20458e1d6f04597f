#pragma once
// Building a Machine: from a preset compiled into the library, a TOML file, or a Klipper
// printer.cfg; then command-line overrides (`--set section.key=value`) and validation.
// Every key, its unit and default are listed in docs/machine.md.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/machine/machine.hpp"

namespace amctl::machine {

/// The largest machine file (.toml, printer.cfg, each [include]) amctl reads: a real one is a
/// few tens of KiB.
inline constexpr std::uint64_t kMaxMachineFileBytes = 16ull << 20;

/// Resolves `spec` to a validated Machine:
///  - "" or a preset name ("default", "voron24", "prusa-mk3s", "ender3", see preset_names());
///  - a path ending in .toml: parse_machine_toml;
///  - a path ending in .cfg/.conf/.ini, or any other file that is not valid TOML but has an
///    INI-style [printer] section: parse_klipper_cfg (with [include ...] relative to the file).
/// Throws amctl::Error naming the spec (with a did-you-mean hint for near-miss preset names).
Machine load_machine(const std::string& spec);

/// load_machine(spec), then apply_override() for each assignment in order, then validate().
Machine load_machine(const std::string& spec, const std::vector<std::string>& overrides);

/// Parses amctl's TOML machine description. `source_name` is used in error messages
/// ("source_name:line:col: ..."). Unknown sections/keys, wrong types and out-of-range values
/// are errors. The result is validated.
Machine parse_machine_toml(std::string_view text, const std::string& source_name);

/// Parses a Klipper printer.cfg (configparser dialect as Klipper reads it: `key: value` or
/// `key = value`, `#` comments anywhere, `;` comments, indented continuation lines, repeated
/// sections merged, the SAVE_CONFIG block). `[include FILE]` (globs allowed) is resolved
/// relative to the directory of `source_name`. Reads [printer], [extruder], [gcode_arcs],
/// [firmware_retraction] and [stepper_*]; every other section is accepted and ignored.
/// Defaults are Klipper's; firmware = klipper, junction = square_corner_velocity.
Machine parse_klipper_cfg(std::string_view text, const std::string& source_name);

/// Names of the presets compiled in from configs/*.toml, sorted.
std::vector<std::string> preset_names();
/// The named preset; unknown name -> amctl::Error with did-you-mean.
Machine preset(const std::string& name);
/// The TOML text of a preset, exactly as in configs/<name>.toml.
std::string_view preset_toml(const std::string& name);

/// Applies one "section.key=value" assignment, e.g. "printer.max_accel=5000",
/// "marlin.jerk=[10,10,0.4,5]", "marlin.max_feedrate.z=12", "printer.firmware=marlin",
/// "stepper_x.microsteps=32". The value uses TOML syntax (bare words are accepted for text
/// keys). Unknown keys -> amctl::Error with did-you-mean; the value is range-checked for that
/// key, cross-key consistency is left to validate().
void apply_override(Machine& m, std::string_view assignment);

/// TOML text that parse_machine_toml turns back into a Machine equal to `m`.
std::string to_toml(const Machine& m);

/// Checks every limit: finite, > 0 or >= 0 as each key requires, ratios in range, and
/// cross-key rules (filament >= nozzle, min <= max arc segment). Throws amctl::Error naming
/// the key as "section.key".
void validate(const Machine& m);

/// Short names used in files and JSON: "klipper", "corexy", "square_corner_velocity", ...
std::string_view to_string(Firmware f);
std::string_view to_string(JunctionPolicy j);
std::string_view to_string(VelocityProfile p);

/// One documented key of the TOML schema (what docs/machine.md and `--set` list).
struct KeyInfo {
  std::string section;      ///< "printer", "marlin", ..., "stepper_*" for every stepper
  std::string key;          ///< "max_accel"
  std::string type;         ///< "number", "integer", "text", "[x, y, z, e]", "number (optional)"
  std::string unit;         ///< "mm/s^2", "" if dimensionless
  std::string description;
};
/// Every key of the schema, in file order.
std::vector<KeyInfo> schema();

}  // namespace amctl::machine
