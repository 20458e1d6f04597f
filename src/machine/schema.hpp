#pragma once
// Internal: the single table of machine keys that drives the TOML reader and writer,
// `--set` overrides, validate() and the key list in docs/machine.md.
#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/machine/machine.hpp"

namespace amctl::machine::detail {

/// What a key holds.
enum class Kind {
  number,           ///< double
  optional_number,  ///< std::optional<double>; absent = derived default
  integer,          ///< int
  axes4,            ///< [x, y, z, e] doubles
  text,             ///< std::string
  boolean,          ///< bool
  firmware,
  kinematics,
  junction,
  profile,
  accel_to_decel,   ///< Klipper's legacy max_accel_to_decel: read-only alias, maps to minimum_cruise_ratio
  gear_ratio        ///< stepper gear_ratio "a:b, c:d" (folded into rotation_distance)
};

/// The range a numeric key accepts.
enum class Bound {
  finite,        ///< any finite number
  non_negative,  ///< >= 0
  positive,      ///< > 0
  ratio,         ///< 0 <= r < 1
  at_least_one   ///< integer >= 1
};

struct KeyDef {
  std::string_view section;
  std::string_view key;
  Kind kind;
  Bound bound;
  std::string_view unit;
  std::string_view description;
  double& (*number)(Machine&) = nullptr;
  std::optional<double>& (*optional_number)(Machine&) = nullptr;
  int& (*integer)(Machine&) = nullptr;
  std::array<double, 4>& (*axes)(Machine&) = nullptr;
  std::string& (*text)(Machine&) = nullptr;
  bool& (*boolean)(Machine&) = nullptr;
};

struct StepperKeyDef {
  std::string_view key;
  Kind kind;
  Bound bound;
  std::string_view unit;
  std::string_view description;
  double& (*number)(Stepper&) = nullptr;
  int& (*integer)(Stepper&) = nullptr;
  std::optional<double>& (*optional_number)(Stepper&) = nullptr;
  std::string& (*text)(Stepper&) = nullptr;
};

/// Every [printer]/[marlin]/[extruder]/[arcs]/[firmware_retraction] key, in file order.
std::span<const KeyDef> machine_keys();
/// Keys of a [stepper_<name>] section.
std::span<const StepperKeyDef> stepper_keys();
/// Section names in file order (without the stepper ones).
std::span<const std::string_view> machine_sections();

const KeyDef* find_key(std::string_view section, std::string_view key);
const StepperKeyDef* find_stepper_key(std::string_view key);
/// "x", "y", "z", "e", "z1", "e2", ...: the axes' stepper names, valid on every machine (a
/// kinematics' own motors: stepper_a of a delta, ... are its owns_stepper()).
bool valid_stepper_name(std::string_view name);
/// Throws at `where` unless `text` names a shaper `amctl shaper show` knows (zv, mzv, zvd, ei,
/// 2hump_ei, 3hump_ei, zvdd, zvddd, any case, optionally with parameters: "mzv(n=4, t=0.9)");
/// the parameters are checked where the shaper is built.
void check_shaper_type(std::string_view text, const SourceLocation& where, std::string_view label);

// Enumerations as text.
std::span<const std::string_view> enum_names(Kind kind);
/// Index into enum_names(kind) of the machine's current value.
int get_enum(const Machine& m, Kind kind);
void set_enum(Machine& m, Kind kind, int index);

/// "> 0", ">= 0", "in [0, 1)" ...
std::string_view bound_text(Bound b);
bool within(Bound b, double v);
/// Throws amctl::Error at `where` naming `label` (and its unit) unless `v` is within `b`.
void check_bound(Bound b, double v, const SourceLocation& where, std::string_view label,
                 std::string_view unit);

/// Throws amctl::Error at `where` naming `label` unless `name` is a motor preset
/// (amctl/machine/motor_presets.hpp).
void check_motor_preset(std::string_view name, const SourceLocation& where, std::string_view label);

/// Levenshtein distance, case-insensitive.
std::size_t edit_distance(std::string_view a, std::string_view b);
/// The closest candidate if it is close enough to be a plausible typo.
std::optional<std::string> closest(std::string_view word, const std::vector<std::string>& candidates);
/// "; did you mean 'x'?" or "".
std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates);

/// Number formatting that round-trips through TOML and strtod.
std::string format_number(double v);

/// Klipper gear_ratio "57:11, 2:1" -> 57/11 * 2/1. Throws Error(where, ...) if malformed.
double parse_gear_ratio(std::string_view text, const SourceLocation& where,
                        std::string_view label);

struct EmbeddedPreset {
  std::string_view name;
  std::string_view text;
};
/// Generated at build time from configs/*.toml (presets_data.cpp), sorted by name.
std::span<const EmbeddedPreset> embedded_presets();

}  // namespace amctl::machine::detail
