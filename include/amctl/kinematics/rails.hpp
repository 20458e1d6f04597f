#pragma once
// The rails of the cartesian-like kinematics (Klipper stepper.py PrinterRail): the range a
// carriage may move in and where homing leaves it, and the second carriage of an IDEX axis
// (Klipper [dual_carriage], kinematics/idex_modes.py).
#include <map>
#include <optional>
#include <string>

#include "amctl/kinematics/keys.hpp"
#include "amctl/kinematics/kinematics.hpp"
#include "amctl/kinematics/klipper_config.hpp"

namespace amctl::kinematics {

/// Klipper [stepper_*] position_min / position_max / position_endstop (machine coordinates).
/// Klipper refuses a move whose end lies outside [position_min, position_max] ("Move out of
/// range"). Unset: no range known (presets, TOML without them).
struct Rail {
  std::optional<double> position_min_mm, position_max_mm, position_endstop_mm;
  bool operator==(const Rail&) const = default;
};

/// Rails by drive-train key ("x", "y", "z", "z1", ...; Klipper reads the range of an axis
/// from its first stepper).
using Rails = std::map<std::string, Rail>;

/// Klipper [dual_carriage] (IDEX): a second carriage on X or Y with its own rail. The first
/// carriage's rail is stepper_x's (or stepper_y's).
struct DualCarriage {
  std::string axis;  ///< "x" or "y"
  /// The second carriage's rail; position_min defaults to 0, position_endstop and
  /// position_max are required, as in Klipper.
  std::optional<double> position_min_mm, position_max_mm, position_endstop_mm;
  /// Klipper safe_distance (the closest the carriages may come); unset: the smaller
  /// difference of the rails' minima or maxima (0 = no collision check), as Klipper.
  std::optional<double> safe_distance_mm;
  /// homing_speed of the second rail and of the first one: RESTORE_DUAL_CARRIAGE_STATE moves
  /// at the lower of the two (Klipper's default is 5 mm/s).
  double homing_speed_mm_s = 5.0;
  double primary_homing_speed_mm_s = 5.0;
  bool operator==(const DualCarriage&) const = default;
};

namespace detail {

/// Klipper's rail rules: position_min <= position_max on every rail.
void check_rails(const Rails& rails);
/// A dual carriage's axis is x or y, its range and endstop given and consistent, the first
/// carriage's rail complete (no dual carriage, or one with axis "": nothing to check).
void check_dual_carriage(const Rails& rails, const std::optional<DualCarriage>& dc);

/// The MoveRules of a cartesian-like kinematics: Z limited by the toolhead, the ranges of the
/// x, y, z rails.
[[nodiscard]] MoveRules cartesian_move_rules(const Rails& rails, const Toolhead& th);
/// Homing of a cartesian-like kinematics: each axis at its rail's position_endstop.
[[nodiscard]] Homing cartesian_homing(const Rails& rails);
/// The IDEX pair of a [dual_carriage]; throws amctl::Error when the first rail lacks its
/// position_endstop or position_max.
[[nodiscard]] IdexPair idex_pair(const Rails& rails, const DualCarriage& dc);
/// The motors of a cartesian-like kinematics: stepper_x, stepper_y, then every stepper_z*,
/// with the rows given (over x, y, z, e); `missing` gets those of x, y, z without a drive train.
[[nodiscard]] std::vector<Motor> cartesian_motors(const std::vector<std::string>& keys,
                                                  const std::array<double, 4>& row_x,
                                                  const std::array<double, 4>& row_y,
                                                  const std::array<double, 4>& row_z,
                                                  std::vector<std::string>& missing);
/// The linear map of those motors.
[[nodiscard]] LinearMap linear_map_of(const std::vector<Motor>& motors);

}  // namespace detail

}  // namespace amctl::kinematics

namespace amctl::kinematics::detail {

/// The [stepper_NAME] sections of axes `axes` ("xyz": stepper_x, stepper_x1, ..., stepper_z3;
/// Klipper's extra steppers of a rail), in file order.
[[nodiscard]] std::vector<KlipperStepper> axis_steppers(const KlipperConfig& cfg, std::string_view axes);
/// stepper.py PrinterRail: the first stepper of rail `key` holds its range when it gives
/// position_max: position_min (default 0), position_max (above position_min), position_endstop.
void read_rail(const KlipperSection& s, Rails& rails, const std::string& key);
/// Klipper [dual_carriage] (idex_modes.py; stepper.py's rail rules: position_min 0, endstop
/// and max required); unset without the section.
[[nodiscard]] std::optional<DualCarriage> read_dual_carriage(const KlipperConfig& cfg);
/// Throws at a [dual_carriage] section: Klipper has one on cartesian, hybrid_corexy and
/// hybrid_corexz printers only.
void refuse_dual_carriage(const KlipperConfig& cfg);
/// The TOML keys of the rails (position_min, position_max, position_endstop of the
/// [stepper_NAME] tables whose instance `accept` takes) and of [dual_carriage].
template <class K>
void add_rail_keys(std::vector<ParamKey<K>>& keys);
template <class K>
void add_dual_carriage_keys(std::vector<ParamKey<K>>& keys);

}  // namespace amctl::kinematics::detail

namespace amctl::kinematics::detail {

inline Rail* rail_of(Rails& rails, std::string_view key, bool create) {
  if (create) return &rails[std::string(key)];
  const auto it = rails.find(std::string(key));
  return it == rails.end() ? nullptr : &it->second;
}

template <class K>
void add_rail_keys(std::vector<ParamKey<K>>& keys) {
  using Opt = std::optional<double>;
  keys.push_back({"stepper", "position_min", KeyBound::finite, "mm",
                  "Klipper position_min: lowest position a move may end at (unset: no range check).",
                  [](K& k, std::string_view i, bool c) -> Opt* {
                    Rail* r = K::rail(k, i, c);
                    return r ? &r->position_min_mm : nullptr;
                  }});
  keys.push_back({"stepper", "position_max", KeyBound::finite, "mm",
                  "Klipper position_max: highest position a move may end at (unset: no range check).",
                  [](K& k, std::string_view i, bool c) -> Opt* {
                    Rail* r = K::rail(k, i, c);
                    return r ? &r->position_max_mm : nullptr;
                  }});
  keys.push_back({"stepper", "position_endstop", KeyBound::finite, "mm",
                  "Klipper position_endstop: the position after homing (informative).",
                  [](K& k, std::string_view i, bool c) -> Opt* {
                    Rail* r = K::rail(k, i, c);
                    return r ? &r->position_endstop_mm : nullptr;
                  }});
}

inline constexpr std::string_view kDualCarriageAxes[] = {"", "x", "y"};

template <class K>
void add_dual_carriage_keys(std::vector<ParamKey<K>>& keys) {
  using Opt = std::optional<double>;
  keys.push_back({"dual_carriage", "axis", KeyBound::finite, "",
                  "Klipper [dual_carriage] axis: \"x\" or \"y\" for an IDEX (a second carriage on "
                  "that axis, SET_DUAL_CARRIAGE); \"\" = none.",
                  nullptr, nullptr,
                  [](K& k, std::string_view, bool c) -> std::string* {
                    if (c && !k.dual_carriage) k.dual_carriage.emplace();
                    return k.dual_carriage ? &k.dual_carriage->axis : nullptr;
                  },
                  kDualCarriageAxes});
  keys.push_back({"dual_carriage", "position_min", KeyBound::finite, "mm",
                  "Second carriage: lowest position (Klipper position_min; unset = 0).",
                  [](K& k, std::string_view, bool c) -> Opt* {
                    if (c && !k.dual_carriage) k.dual_carriage.emplace();
                    return k.dual_carriage ? &k.dual_carriage->position_min_mm : nullptr;
                  }});
  keys.push_back({"dual_carriage", "position_max", KeyBound::finite, "mm",
                  "Second carriage: highest position (Klipper position_max; required with an axis).",
                  [](K& k, std::string_view, bool c) -> Opt* {
                    if (c && !k.dual_carriage) k.dual_carriage.emplace();
                    return k.dual_carriage ? &k.dual_carriage->position_max_mm : nullptr;
                  }});
  keys.push_back({"dual_carriage", "position_endstop", KeyBound::finite, "mm",
                  "Second carriage: where G28 parks it (Klipper position_endstop; required with an "
                  "axis).",
                  [](K& k, std::string_view, bool c) -> Opt* {
                    if (c && !k.dual_carriage) k.dual_carriage.emplace();
                    return k.dual_carriage ? &k.dual_carriage->position_endstop_mm : nullptr;
                  }});
  keys.push_back({"dual_carriage", "safe_distance", KeyBound::non_negative, "mm",
                  "Closest approach of the two carriages (Klipper safe_distance; unset = the "
                  "smaller difference of the rails' minima or maxima).",
                  [](K& k, std::string_view, bool c) -> Opt* {
                    if (c && !k.dual_carriage) k.dual_carriage.emplace();
                    return k.dual_carriage ? &k.dual_carriage->safe_distance_mm : nullptr;
                  }});
  keys.push_back({"dual_carriage", "homing_speed", KeyBound::positive, "mm/s",
                  "Second carriage's homing speed (Klipper homing_speed).", nullptr,
                  [](K& k, std::string_view, bool c) -> double* {
                    if (c && !k.dual_carriage) k.dual_carriage.emplace();
                    return k.dual_carriage ? &k.dual_carriage->homing_speed_mm_s : nullptr;
                  }});
  keys.push_back({"dual_carriage", "primary_homing_speed", KeyBound::positive, "mm/s",
                  "First carriage's homing speed ([stepper_x] or [stepper_y] homing_speed); "
                  "RESTORE_DUAL_CARRIAGE_STATE moves at the lower of the two.",
                  nullptr,
                  [](K& k, std::string_view, bool c) -> double* {
                    if (c && !k.dual_carriage) k.dual_carriage.emplace();
                    return k.dual_carriage ? &k.dual_carriage->primary_homing_speed_mm_s : nullptr;
                  }});
}

}  // namespace amctl::kinematics::detail
