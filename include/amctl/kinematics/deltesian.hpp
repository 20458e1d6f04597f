#pragma once
// Deltesian (klippy/kinematics/deltesian.py, chelper/kin_deltesian.c; read at 84104bbb,
// nothing copied): two towers in the XZ plane at x = -arm_x_left and x = +arm_x_right whose
// carriages hold arms of length L to the effector, and a cartesian Y. Carriage height of the
// left tower c = z + sqrt(L^2 - (x + ax)^2), the right one c = z + sqrt(L^2 - (x - ax)^2).
#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

/// A tower (stepper_left, stepper_right): horizontal distance from the centre to the arm's
/// joint on the carriage (arm_x_length; required on left, right defaults to it), arm length
/// (> arm_x_length) and endstop (right defaults to left's).
struct DeltesianTower {
  std::optional<double> arm_x_length_mm, arm_length_mm, position_endstop_mm;
  bool operator==(const DeltesianTower&) const = default;
};

struct Deltesian {
  static constexpr std::string_view kName = "deltesian";
  /// [printer] min_angle (the arms' smallest angle with the horizontal, default 5 degrees),
  /// print_width (the printable width in X; unset: what the arms reach), slow_ratio (the
  /// tower-to-effector speed ratio beyond which moves slow down, default 3; 0 = never),
  /// minimum_z_position (0).
  std::optional<double> min_angle_deg, print_width_mm, slow_ratio, minimum_z_position_mm;
  std::map<std::string, DeltesianTower> towers;  ///< left, right
  Rails rails;                                   ///< y
  bool operator==(const Deltesian&) const = default;

  /// printer.cfg: [stepper_left], [stepper_right], [stepper_y] (required).
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  /// [printer] min_angle ([0, 90]), print_width (>= 0), slow_ratio (>= 0), minimum_z_position;
  /// the towers' arm_x_length, arm_length (> 0; required on left) and position_endstop
  /// (required on left); stepper_y's rail.
  [[nodiscard]] static Deltesian from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options();
  /// TOML: [delta] min_angle, print_width, slow_ratio, minimum_z_position; [stepper_left],
  /// [stepper_right] arm_x_length, arm_length, position_endstop; the rails' ranges.
  [[nodiscard]] static std::span<const ParamKey<Deltesian>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): The towers stepper_left, stepper_right.
  [[nodiscard]] bool owns_stepper(std::string_view key) const { return key == "left" || key == "right"; }
  static Rail* rail(Deltesian& k, std::string_view key, bool create) {
    if (key == "left" || key == "right") return nullptr;
    return detail::rail_of(k.rails, key, create);
  }
};

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
/// slow_ratio 3, minimum_z_position 0). Throws amctl::Error naming the missing or
/// inconsistent key.
[[nodiscard]] DeltesianGeometry deltesian_geometry(const Deltesian& p);

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const Deltesian& p, const Context& ctx);

}  // namespace amctl::kinematics
