#pragma once
// Linear delta geometry as Klipper derives it at start-up (klippy/kinematics/delta.py, read
// at commit 84104bbb; nothing of it is copied): tower positions, the build volume and the
// zones where Klipper slows moves down. docs/machine.md, "Delta".
//
// Tower i stands at (tx_i, ty_i) = delta_radius (cos angle_i, sin angle_i); its carriage
// carries a rod of length L_i to the effector, so the carriage height is
//     c_i(x, y, z) = z + sqrt(L_i^2 - (x - tx_i)^2 - (y - ty_i)^2).
// The speed zones come from the ratio of carriage to effector motion: for a horizontal move
// of the effector along the radius through the tower, dc/dr = d / sqrt(L^2 - d^2) with d the
// horizontal rod projection; Klipper's ratio_to_xy(k) is the effector radius at which that
// ratio reaches k (with half a step of slack), r(k) = k sqrt(L^2 / (k^2 + 1) - h^2) + h - R,
// h half the smallest step distance, R the delta radius. Moves touching r > r(3) run at half
// the configured max_velocity and max_accel, r > r(6) at a quarter; the build radius is
// min(print_radius, L_min - R, r(12)).
#include <array>

#include "amctl/machine/machine.hpp"

namespace amctl::machine {

struct DeltaGeometry {
  double radius_mm = 0.0;
  std::array<double, 3> arm_length_mm{};   ///< rods of towers a, b, c
  std::array<double, 3> arm2_mm2{};        ///< their squares
  std::array<double, 3> tower_x_mm{}, tower_y_mm{};
  std::array<double, 3> endstop_mm{};      ///< position_endstop of each tower
  std::array<double, 3> abs_endstop_mm{};  ///< carriage height at the endstop: endstop + sqrt(L^2 - R^2)
  std::array<double, 3> step_distance_mm{};
  double max_z_mm = 0.0;       ///< min of the endstops: the top of the build volume
  double min_z_mm = 0.0;       ///< minimum_z_position
  double limit_z_mm = 0.0;     ///< above this the build radius tapers (min abs_endstop - L)
  double min_arm_length_mm = 0.0;
  double max_xy2_mm2 = 0.0;        ///< build radius squared
  double slow_xy2_mm2 = 0.0;       ///< beyond: half speed and accel
  double very_slow_xy2_mm2 = 0.0;  ///< beyond: a quarter
  std::array<double, 3> home_position_mm{};  ///< effector position with the carriages at the endstops

  /// Carriage height of tower i for the effector at (x, y, z) [mm]; NaN outside the reach
  /// of the rod.
  [[nodiscard]] double carriage_mm(int tower, double x_mm, double y_mm, double z_mm) const;
  /// Squared build radius at height z: max_xy2 below limit_z, tapered above it (the rods
  /// would have to reach over the tower tops).
  [[nodiscard]] double limit_xy2_at(double z_mm) const;
};

/// The geometry of a delta machine: Klipper's defaults applied (print_radius = delta_radius,
/// arm_length, position_endstop of b and c = a's, angles 210/330/90, minimum_z_position 0).
/// Throws amctl::Error naming the missing or inconsistent key (delta.radius, stepper_a.arm_length
/// must be > delta.radius, stepper_a.position_endstop, a missing stepper_a/_b/_c).
[[nodiscard]] DeltaGeometry delta_geometry(const Machine& m);

/// The point where three spheres (centres c_i, squared radii r2_i) meet, the lower of the two
/// (the effector hangs below the carriages); Klipper's mathutil.trilateration does the same.
[[nodiscard]] std::array<double, 3> trilaterate_below(const std::array<std::array<double, 3>, 3>& centres,
                                                      const std::array<double, 3>& r2);

}  // namespace amctl::machine

namespace amctl::machine {

/// Deltesian geometry as Klipper's kinematics/deltesian.py derives it: two towers in the XZ
/// plane at x = -arm_x_left and x = +arm_x_right whose carriages hold arms of length L to the
/// effector, a cartesian Y. Carriage height of the left tower c = z + sqrt(L^2 - (x + ax)^2),
/// the right one c = z + sqrt(L^2 - (x - ax)^2) (kin_deltesian.c).
struct DeltesianGeometry {
  std::array<double, 2> arm_x_mm{};       ///< arm_x_length of left, right
  std::array<double, 2> arm2_mm2{};       ///< squared arm lengths
  std::array<double, 2> tower_x_mm{};     ///< -arm_x_left, +arm_x_right
  std::array<double, 2> abs_endstop_mm{}; ///< endstop + sqrt(L^2 - ax^2)
  std::array<std::array<double, 2>, 3> limits_mm{};  ///< [min, max] of x, y, z
  double home_z_mm = 0.0;
  double home_y_mm = 0.0;             ///< stepper_y's position_endstop
  double slow_x2_mm2 = 0.0;           ///< beyond |x|: half speed (0 = no slow zone)
  double very_slow_x2_mm2 = 0.0;      ///< beyond: a quarter
  /// Highest z the carriages allow at x (both below their endstops).
  [[nodiscard]] double pillars_z_max(double x_mm) const;
};

/// Klipper's defaults applied (arm_x_length and arm_length of right = left's, min_angle 5,
/// slow_ratio 3, minimum_z_position 0). Throws amctl::Error naming the missing or inconsistent
/// key.
[[nodiscard]] DeltesianGeometry deltesian_geometry(const Machine& m);

}  // namespace amctl::machine
