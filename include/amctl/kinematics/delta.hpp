#pragma once
// Linear delta (klippy/kinematics/delta.py, chelper/kin_delta.c; read at 84104bbb, nothing
// copied): three towers whose carriages hold rods of length L to the effector. Tower i stands
// at (tx_i, ty_i) = delta_radius (cos angle_i, sin angle_i); its carriage height is
//     c_i(x, y, z) = z + sqrt(L_i^2 - (x - tx_i)^2 - (y - ty_i)^2).
// The speed zones come from the ratio of carriage to effector motion: for a horizontal move
// along the radius through the tower, dc/dr = d / sqrt(L^2 - d^2) with d the horizontal rod
// projection; Klipper's ratio_to_xy(k) is the effector radius at which that ratio reaches k
// (with half a step of slack), r(k) = k sqrt(L^2 / (k^2 + 1) - h^2) + h - R, h half the
// smallest step distance, R the delta radius. Moves touching r > r(3) run at half the
// configured max_velocity and max_accel, r > r(6) at a quarter; the build radius is
// min(print_radius, L_min - R, r(12)). docs/machine.md, "Delta".
#include <array>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/kinematics/keys.hpp"
#include "amctl/kinematics/kinematics.hpp"
#include "amctl/kinematics/klipper_config.hpp"

namespace amctl::kinematics {

/// One tower ([stepper_a], _b, _c): rod length (Klipper arm_length, > delta_radius; b and c
/// default to a's), angle around the centre [degrees] (210, 330, 90) and endstop.
struct DeltaTower {
  std::optional<double> arm_length_mm, angle_deg, position_endstop_mm;
  bool operator==(const DeltaTower&) const = default;
};

struct Delta {
  static constexpr std::string_view kName = "delta";
  std::optional<double> radius_mm;              ///< delta_radius (required)
  std::optional<double> print_radius_mm;        ///< unset: delta_radius
  std::optional<double> minimum_z_position_mm;  ///< unset: 0
  std::map<std::string, DeltaTower> towers;     ///< by drive-train key a, b, c
  bool operator==(const Delta&) const = default;

  /// printer.cfg: [stepper_a], [stepper_b], [stepper_c] (required).
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  /// [printer] delta_radius (required, > 0), print_radius (> 0), minimum_z_position; the
  /// towers' arm_length (required on a, > delta_radius), angle, position_endstop (required on a).
  [[nodiscard]] static Delta from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options();
  /// TOML: [delta] radius, print_radius, minimum_z_position; [stepper_a..c] arm_length,
  /// angle, position_endstop.
  [[nodiscard]] static std::span<const ParamKey<Delta>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): The towers stepper_a, _b, _c.
  [[nodiscard]] bool owns_stepper(std::string_view key) const { return key == "a" || key == "b" || key == "c"; }
};

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

/// Klipper's defaults applied (print_radius = delta_radius, arm_length, position_endstop of
/// b and c = a's, angles 210/330/90, minimum_z_position 0); `step_distance_mm` of the towers
/// a, b, c (for the speed zones). Throws amctl::Error naming the missing or inconsistent key
/// (delta.radius, stepper_a.arm_length must be > delta.radius, stepper_a.position_endstop).
[[nodiscard]] DeltaGeometry delta_geometry(const Delta& p, const std::array<double, 3>& step_distance_mm);

/// The point where three spheres (centres c_i, squared radii r2_i) meet, the lower of the two
/// (the effector hangs below the carriages); Klipper's mathutil.trilateration does the same.
[[nodiscard]] Vec3 trilaterate_below(const std::array<Vec3, 3>& centres, const Vec3& r2);

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const Delta& p, const Context& ctx);

}  // namespace amctl::kinematics
