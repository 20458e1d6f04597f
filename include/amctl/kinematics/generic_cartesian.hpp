#pragma once
// generic_cartesian (klippy/kinematics/generic_cartesian.py with kinematic_stepper.py,
// chelper/kin_generic.c; read at 84104bbb, nothing copied): carriages (one per axis, plus
// extra and dual carriages) mapped to steppers by a linear combination per stepper
// (`carriages: carriage_x+carriage_y`).
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

/// A carriage (Klipper [carriage NAME], [extra_carriage NAME], [dual_carriage NAME]). A
/// primary carriage moves one axis and holds its range; an extra carriage moves with its
/// primary (a second belt or motor of the same axis); a dual carriage is the second carriage
/// of an IDEX axis, parked while the primary prints.
struct Carriage {
  enum class Type { primary, extra, dual };
  Type type = Type::primary;
  /// "x", "y" or "z" for a primary carriage; empty for extra and dual carriages (their
  /// primary's axis).
  std::string axis;
  /// Extra and dual carriages: the name of the primary carriage they belong to.
  std::string primary_carriage;
  /// Primary and dual carriages: position_min (default 0), position_max (required),
  /// position_endstop (required) [mm].
  std::optional<double> position_min_mm, position_max_mm, position_endstop_mm;
  /// Primary and dual carriages: homing_speed (Klipper's default 5 mm/s).
  double homing_speed_mm_s = 5.0;
  /// Dual carriages with a primary_carriage: safe_distance (unset: from the rails).
  std::optional<double> safe_distance_mm;
  bool operator==(const Carriage&) const = default;
};

struct GenericCartesian {
  static constexpr std::string_view kName = "generic_cartesian";
  /// The carriages by name (Klipper's section name without the [carriage ] prefix).
  std::map<std::string, Carriage> carriages;
  /// Each stepper's `carriages` expression, by the word after "stepper" (the drive-train
  /// key): "carriage_x+carriage_y", "carriage_u-carriage_y1", "1*carriage_y+0.5*carriage_z".
  std::map<std::string, std::string> stepper_carriages;
  bool operator==(const GenericCartesian&) const = default;

  /// printer.cfg: every [stepper NAME] (NAME letters, digits and _, not an extruder's name).
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  /// [carriage NAME] (axis: x, y or z, by default the name when it is one of them;
  /// position_endstop, position_min (0), position_max, homing_speed), [extra_carriage NAME]
  /// (primary_carriage), [dual_carriage NAME] (primary_carriage or axis, the range,
  /// safe_distance) and the steppers' carriages. The checks that need all of them together are
  /// generic_cartesian_geometry's.
  [[nodiscard]] static GenericCartesian from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options() { return {}; }
  /// TOML: the [carriage.NAME] tables and the steppers' carriages keys.
  [[nodiscard]] static std::span<const ParamKey<GenericCartesian>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): Every [stepper NAME] with carriages.
  [[nodiscard]] bool owns_stepper(std::string_view key) const { return stepper_carriages.count(std::string(key)) != 0; }
};

/// A generic_cartesian stepper's name: letters, digits and '_', not an extruder's (e, e1, ...).
[[nodiscard]] bool generic_stepper_name(std::string_view name);

/// One stepper: its position is coeffs . (X, Y, Z) [mm] with the dual carriages parked.
struct GenericStepper {
  std::string name;                 ///< drive-train key (Klipper [stepper NAME])
  std::array<double, 3> coeffs{};   ///< over X, Y, Z
};

struct GenericCartesianGeometry {
  /// [min, max] of X, Y, Z: the primary carriage of each axis.
  std::array<std::array<double, 2>, 3> limits_mm{};
  /// Every stepper, in key order.
  std::vector<GenericStepper> steppers;
};

/// Reads a `carriages` expression: terms separated by + or -, each `NAME` or `COEFF*NAME`,
/// NAME one of p.carriages. Returns the coefficient per axis of every carriage referenced,
/// dual carriages included (`with_dual` true) or left out (parked). Throws amctl::Error
/// naming `label` for an unknown carriage, a malformed term or an axis referenced twice.
[[nodiscard]] std::array<double, 3> parse_carriages(std::string_view expr, const GenericCartesian& p,
                                                    std::string_view label, bool with_dual);

/// Klipper's checks applied: one primary carriage per axis, extra and dual carriages naming a
/// primary one, each carriage referenced by a stepper, every stepper referencing one, and the
/// steppers moving all three axes independently with either carriage of a dual axis active.
[[nodiscard]] GenericCartesianGeometry generic_cartesian_geometry(const GenericCartesian& p);

/// Klipper's checks of SET_STEPPER_CARRIAGES STEPPER=`stepper` CARRIAGES=`expr` (see
/// Kinematics::stepper_carriages_error).
[[nodiscard]] std::string stepper_carriages_error(
    const GenericCartesian& p, const std::map<std::string, std::string, std::less<>>& now,
    const std::string& stepper, const std::string& expr, bool full);

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const GenericCartesian& p,
                                                          const Context& ctx);

}  // namespace amctl::kinematics
