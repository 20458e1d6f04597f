#pragma once
// The rails of the cartesian-like kinematics (Klipper stepper.py PrinterRail): the range a
// carriage may move in and where homing leaves it, and the second carriage of an IDEX axis
// (Klipper [dual_carriage], kinematics/idex_modes.py).
#include <map>
#include <optional>
#include <string>

#include "amctl/kinematics/kinematics.hpp"

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
