#pragma once
// Internal to the machine module: the keys the kinematics and the extruder own
// (kinematics::ParamKey), bound to a Machine and without their parameter type, so that the
// TOML reader and writer, `--set`, the JSON and the key list walk them like the machine's own.
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/machine/machine.hpp"
#include "schema.hpp"

namespace amctl::machine::detail {

struct BoundKey {
  enum class Kind { number, optional_number, text, choice, boolean };
  std::string_view section, key;
  Kind kind = Kind::number;
  Bound bound = Bound::finite;
  std::string_view unit, description;
  std::span<const std::string_view> choices;
  std::function<double*(std::string_view, bool)> number;
  std::function<std::optional<double>*(std::string_view, bool)> optional_number;
  std::function<std::string*(std::string_view, bool)> text;
  std::function<bool*(std::string_view, bool)> boolean;
  std::function<int(std::string_view)> get_index;
  std::function<bool(std::string_view, int)> set_index;
  /// "carriage" keys: the instances that exist.
  std::function<std::vector<std::string>()> instances;
  std::optional<double> unwritten_default;
  /// A key of the extruder (not of the kinematics).
  bool extruder = false;
};

/// The extruder's keys, then the kinematics' keys, bound to m (valid while m lives and its
/// kinematics keeps its type).
[[nodiscard]] std::vector<BoundKey> bound_keys(Machine& m);
/// The first bound key of (section, key) that applies to `instance` (for "stepper" and
/// "carriage" keys), or null. For assignment: what holds the field is made on the way.
[[nodiscard]] const BoundKey* find_bound(const std::vector<BoundKey>& keys, std::string_view section,
                                         std::string_view key, std::string_view instance);
/// The names of the kinematics that have keys in `section`, in list order.
[[nodiscard]] std::vector<std::string_view> kinematics_with_section(std::string_view section);
/// Every kinematics' keys and the extruder's, once each (section, key), for the key list:
/// (section, key, kind, bound, unit, description) as BoundKey without accessors.
[[nodiscard]] std::vector<BoundKey> all_kinematics_keys();
/// True when drive train `key` is one of m's kinematics' motors beyond the axes' (a delta's
/// a, b, c; a generic_cartesian stepper with carriages).
[[nodiscard]] bool owned_stepper(const Machine& m, std::string_view key);
/// The unit of drive train `key` on machine m (the kinematics' motor unit).
[[nodiscard]] kinematics::Unit drive_train_unit(const Machine& m, std::string_view key);

}  // namespace amctl::machine::detail
