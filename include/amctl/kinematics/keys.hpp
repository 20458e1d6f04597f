#pragma once
// The keys of a kinematics' parameters in amctl's TOML machine description, `--set`, the JSON
// of `amctl machine show` and the key list of `amctl machine keys`: one table per kinematics,
// which the machine module's generic reader and writer walk (docs/machine.md).
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace amctl::kinematics {

/// The range a numeric key accepts (the machine's Bound values of the same names).
enum class KeyBound { finite, non_negative, positive };

/// One key of kinematics K. `section` is "printer", "delta", "dual_carriage" (a table of the
/// TOML file), "stepper" (a key of the [stepper_NAME] tables, `instance` the stepper's
/// drive-train key) or "carriage" (a key of the [carriage.NAME] tables, `instance` the
/// carriage name). The accessor returns the field for `instance` (creating what holds it when
/// `create`), or null when the key does not apply there: a stepper this kinematics gives no
/// such key, an absent dual carriage. Exactly one accessor (or the get_index / set_index pair)
/// is set.
template <class K>
struct ParamKey {
  std::string_view section;
  std::string_view key;
  KeyBound bound = KeyBound::finite;
  std::string_view unit;
  std::string_view description;
  std::optional<double>* (*optional_number)(K&, std::string_view instance, bool create) = nullptr;
  double* (*number)(K&, std::string_view instance, bool create) = nullptr;
  std::string* (*text)(K&, std::string_view instance, bool create) = nullptr;
  /// Text keys: the values accepted (empty: any).
  std::span<const std::string_view> choices = {};
  /// "carriage" keys: the instances that exist.
  std::vector<std::string> (*instances)(const K&) = nullptr;
  /// A choice kept as an enumeration (set instead of `text`): the index into `choices` of the
  /// value held (-1 where the key does not apply), and setting it (false where it does not).
  int (*get_index)(K&, std::string_view instance) = nullptr;
  bool (*set_index)(K&, std::string_view instance, int index) = nullptr;
  /// A true/false key, written only when false (its default is true).
  bool* (*boolean)(K&, std::string_view instance, bool create) = nullptr;
  /// Number keys: not written while they hold this value (keys added after machine
  /// descriptions existed, so that those print as before).
  std::optional<double> unwritten_default = std::nullopt;
};

}  // namespace amctl::kinematics
