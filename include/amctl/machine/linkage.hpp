#pragma once
// Geometry of the kinematics Klipper added beyond the linear gantries and deltas, as Klipper
// derives it at start-up (read at commit 84104bbb; nothing of it is copied):
// klippy/kinematics/generic_cartesian.py with kinematic_stepper.py, polar.py, rotary_delta.py
// and chelper/kin_generic.c, kin_polar.c, kin_rotary_delta.c. docs/machine.md, "Kinematics".
#include <array>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/machine/machine.hpp"

namespace amctl::machine {

/// One generic_cartesian stepper: its position is coeffs . (X, Y, Z) [mm] with the dual
/// carriages parked (their terms contribute no motion).
struct GenericStepper {
  std::string name;                 ///< Machine::steppers key (Klipper [stepper NAME])
  std::array<double, 3> coeffs{};   ///< over X, Y, Z
};

struct GenericCartesianGeometry {
  /// [min, max] of X, Y, Z: the primary carriage of each axis (Klipper checks a move against
  /// them as cartesian.py does).
  std::array<std::array<double, 2>, 3> limits_mm{};
  /// Every stepper with a `carriages` expression, in Machine::steppers order.
  std::vector<GenericStepper> steppers;
};

/// Reads Klipper's `carriages` expression: terms separated by + or -, each `NAME` or
/// `COEFF*NAME`, NAME one of m.carriages. Returns the coefficient per axis of every carriage
/// referenced, dual carriages included (`with_dual` true) or left out (parked). Throws
/// amctl::Error naming `label` for an unknown carriage, a malformed term or an axis referenced
/// twice (Klipper's kinematic_stepper.py rules).
[[nodiscard]] std::array<double, 3> parse_carriages(std::string_view expr, const Machine& m,
                                                    std::string_view label, bool with_dual);

/// Klipper's checks applied: one primary carriage per axis, extra and dual carriages naming a
/// primary one, each carriage referenced by a stepper, every stepper referencing one, and the
/// steppers moving all three axes independently with either carriage of a dual axis active.
[[nodiscard]] GenericCartesianGeometry generic_cartesian_geometry(const Machine& m);

/// Klipper's checks of SET_STEPPER_CARRIAGES STEPPER=`stepper` CARRIAGES=`expr` on a
/// generic_cartesian printer (generic_cartesian.py cmd_SET_STEPPER_CARRIAGES), the steppers'
/// expressions in force being `now` (by the word after "stepper"): the expression is read as
/// at start-up, must name the same carriages in the same order and not be all zero; with
/// `full` (no DISABLE_CHECKS) the steppers must still move X, Y and Z independently, with the
/// primary and with the dual carriages active. Empty when accepted, else the reason.
[[nodiscard]] std::string stepper_carriages_error(
    const Machine& m, const std::map<std::string, std::string, std::less<>>& now,
    const std::string& stepper, const std::string& expr, bool full);

/// Polar: the bed turns (stepper_bed: the angle atan2(y, x)), the arm sets the radius
/// (stepper_arm: sqrt(x^2 + y^2)), Z is cartesian (kin_polar.c).
struct PolarGeometry {
  double max_radius_mm = 0.0;  ///< stepper_arm position_max: Klipper's limit_xy2 = max^2
  std::array<double, 2> z_limits_mm{};
  double arm_endstop_mm = 0.0;
};
[[nodiscard]] PolarGeometry polar_geometry(const Machine& m);

/// Rotary delta: arm i swings about a shoulder at radius R (shoulder_radius), height H
/// (shoulder_height), azimuth angle_i; the elbow sits at upper arm length U_i from the
/// shoulder and lower arm length L_i from the effector. The arm angle (stepper position, in
/// radians above the horizontal) for the effector at (x, y, z): in the arm's vertical plane,
/// with the shoulder at the origin, the effector at (u, v) = (x cos a + y sin a - R, z - H)
/// and w = y cos a - x sin a its distance from that plane, the elbow e solves |e| = U and
/// |p - e|^2 = L^2 - w^2; of the two solutions Klipper takes the outer one (larger u).
struct RotaryDeltaGeometry {
  double shoulder_radius_mm = 0.0, shoulder_height_mm = 0.0;
  std::array<double, 3> upper_arm_mm{}, lower_arm_mm{}, angle_rad{}, endstop_mm{};
  std::array<double, 3> endstop_angle_rad{};  ///< arm angle with the effector at (0, 0, endstop)
  double max_z_mm = 0.0;       ///< min of the endstops
  double min_z_mm = 0.0;       ///< minimum_z_position
  double limit_z_mm = 0.0;     ///< above: radius tapered to max_z - z
  double max_xy2_mm2 = 0.0;    ///< min(R + U, L - R)^2
  std::array<double, 3> home_position_mm{};
  /// Arm angle of arm i [rad]; NaN out of reach.
  [[nodiscard]] double arm_angle_rad(int arm, double x_mm, double y_mm, double z_mm) const;
  /// Elbow of arm i at arm angle `angle` [mm].
  [[nodiscard]] std::array<double, 3> elbow_mm(int arm, double angle_rad) const;
  /// Squared build radius at height z (rotary_delta.py check_move).
  [[nodiscard]] double limit_xy2_at(double z_mm) const;
};
[[nodiscard]] RotaryDeltaGeometry rotary_delta_geometry(const Machine& m);

}  // namespace amctl::machine
