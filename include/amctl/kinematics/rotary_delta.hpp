#pragma once
// Rotary delta (klippy/kinematics/rotary_delta.py, chelper/kin_rotary_delta.c; read at
// 84104bbb, nothing copied): arm i swings about a shoulder at radius R (shoulder_radius),
// height H (shoulder_height), azimuth angle_i; the elbow sits at upper arm length U_i from the
// shoulder and lower arm length L_i from the effector. The arm angle (stepper position, in
// radians above the horizontal) for the effector at (x, y, z): in the arm's vertical plane,
// with the shoulder at the origin, the effector at (u, v) = (x cos a + y sin a - R, z - H)
// and w = y cos a - x sin a its distance from that plane, the elbow e solves |e| = U and
// |p - e|^2 = L^2 - w^2; of the two solutions Klipper takes the outer one (larger u).
#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/keys.hpp"
#include "amctl/kinematics/kinematics.hpp"
#include "amctl/kinematics/klipper_config.hpp"

namespace amctl::kinematics {

/// An arm ([stepper_a], _b, _c): upper arm (shoulder to elbow) and lower arm (elbow to
/// effector) lengths (required on a, b and c default to a's), azimuth [degrees] (30, 150,
/// 270) and endstop (b and c default to a's).
struct RotaryArm {
  std::optional<double> upper_arm_length_mm, lower_arm_length_mm, angle_deg, position_endstop_mm;
  bool operator==(const RotaryArm&) const = default;
};

struct RotaryDelta {
  static constexpr std::string_view kName = "rotary_delta";
  /// [printer] shoulder_radius, shoulder_height (required), minimum_z_position (0).
  std::optional<double> shoulder_radius_mm, shoulder_height_mm, minimum_z_position_mm;
  std::map<std::string, RotaryArm> arms;  ///< a, b, c
  bool operator==(const RotaryDelta&) const = default;

  /// printer.cfg: [stepper_a], [stepper_b], [stepper_c] (required; radians).
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  /// [printer] shoulder_radius, shoulder_height (required, > 0), minimum_z_position (no
  /// max_z_accel); the arms' upper_arm_length, lower_arm_length, position_endstop (required on
  /// a) and angle.
  [[nodiscard]] static RotaryDelta from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options();
  /// TOML: [delta] shoulder_radius, shoulder_height, minimum_z_position; [stepper_a..c]
  /// upper_arm_length, lower_arm_length, angle, position_endstop.
  [[nodiscard]] static std::span<const ParamKey<RotaryDelta>> keys();
  /// The arms turn: their drive trains are in radians.
  [[nodiscard]] static Unit unit_of(std::string_view key) {
    return key == "a" || key == "b" || key == "c" ? Unit::rad : Unit::mm;
  }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): The arms stepper_a, _b, _c.
  [[nodiscard]] bool owns_stepper(std::string_view key) const { return key == "a" || key == "b" || key == "c"; }
};

struct RotaryDeltaGeometry {
  double shoulder_radius_mm = 0.0, shoulder_height_mm = 0.0;
  std::array<double, 3> upper_arm_mm{}, lower_arm_mm{}, angle_rad{}, endstop_mm{};
  std::array<double, 3> endstop_angle_rad{};  ///< arm angle with the effector at (0, 0, endstop)
  double max_z_mm = 0.0;       ///< min of the endstops
  double min_z_mm = 0.0;       ///< minimum_z_position
  double limit_z_mm = 0.0;     ///< above: radius tapered to max_z - z
  double max_xy2_mm2 = 0.0;    ///< min(R + U, L - R)^2
  Vec3 home_position_mm{};
  /// Arm angle of arm i [rad]; NaN out of reach.
  [[nodiscard]] double arm_angle_rad(int arm, double x_mm, double y_mm, double z_mm) const;
  /// Elbow of arm i at arm angle `angle` [mm].
  [[nodiscard]] Vec3 elbow_mm(int arm, double angle_rad) const;
  /// Squared build radius at height z (rotary_delta.py check_move).
  [[nodiscard]] double limit_xy2_at(double z_mm) const;
};
[[nodiscard]] RotaryDeltaGeometry rotary_delta_geometry(const RotaryDelta& p);

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const RotaryDelta& p, const Context& ctx);

}  // namespace amctl::kinematics
