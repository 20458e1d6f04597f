#pragma once
// Kinematics: how a printer's motors move its toolhead, one kinematics per file as Klipper
// has them (klippy/kinematics/<name>.py with chelper/kin_<name>.c; read at commit 84104bbb,
// nothing of it is copied). docs/steppers.md section 1 and docs/machine.md "Kinematics".
//
// Each kinematics is a parameter value type (cartesian.hpp, delta.hpp, ...; the Machine holds
// one of them, params.hpp) and an implementation of the interface below, built from the
// parameters and a Context (the toolhead limits and the motors' step distances, which the
// machine description holds). The interface is what every user of a kinematics needs and
// nothing else: the motors (name, unit, position for a toolhead position, monotone pieces for
// the step solver), the planner's move checks (Klipper's check_move), where homing leaves
// the toolhead, and the linear motor map where one exists.
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/json.hpp"

namespace amctl::kinematics {

/// What a motor's position is measured in: mm (a carriage, a belt, a cable) or rad (a turning
/// bed or arm, Klipper's units_in_radians).
enum class Unit { mm, rad };
[[nodiscard]] std::string_view to_string(Unit u);

/// A motor's step distance with its unit.
struct StepDistance {
  double value = 0.0;
  Unit unit = Unit::mm;
  bool operator==(const StepDistance&) const = default;
};

using Vec3 = std::array<double, 3>;

/// A motor whose position is a non-linear function q(p) of the toolhead position p = (x, y, z)
/// (a delta tower, a winch cable, a polar bed or arm, a rotary delta arm). The step solver
/// finds the steps along a straight move on intervals where q is monotone.
class MotorCurve {
 public:
  virtual ~MotorCurve() = default;
  /// q(p) [the motor's unit]; NaN where the motor cannot reach p.
  [[nodiscard]] virtual double position(const Vec3& p) const = 0;
  /// q along the straight line p0 + u s (u a unit vector, s the path distance). The default
  /// is position(p0 + u s); a polar bed unwraps its angle from the line's start.
  [[nodiscard]] virtual double along(const Vec3& p0, const Vec3& u, double s) const;
  /// dq/ds at s on that line, 0 <= s <= s_end. The default is a central difference of
  /// along() with step 1e-6 mm, kept inside [0, s_end].
  [[nodiscard]] virtual double slope_along(const Vec3& p0, const Vec3& u, double s,
                                           double s_end) const;
  /// The points of (0, s_end) where q turns, ascending (q is monotone between them). The
  /// default samples the slope on `samples_` equal intervals and bisects each sign change to
  /// 1e-13 of the length: exact for a q with at most one turning point per interval.
  virtual void turning_points(const Vec3& p0, const Vec3& u, double s_end,
                              std::vector<double>& out) const;
  /// False when a move along the unit direction u leaves q where it is (a polar bed or arm
  /// on a Z-only move, a deltesian tower on a Y-only move): the step solver skips it.
  [[nodiscard]] virtual bool moves_along(const Vec3& u) const {
    return u[0] != 0.0 || u[1] != 0.0 || u[2] != 0.0;
  }
  /// The message for a toolhead position the motor cannot reach (a delta's rods, a rotary
  /// delta's arms), without the "line N: " the caller puts in front.
  [[nodiscard]] virtual std::string out_of_reach(const Vec3& p, std::string_view motor) const;

 protected:
  /// Sampling intervals of the default turning_points.
  int samples_ = 1;
};

/// One motor as its kinematics allocates it.
struct Motor {
  std::string name;   ///< Klipper's name: stepper_x, stepper_z1, stepper_a, "stepper NAME", extruder
  std::string key;    ///< the machine's drive-train key: x, z1, a, NAME, e
  /// The unit comes from the kinematics; the value from the machine's drive train
  /// (machine::motors), 0 until then.
  StepDistance step_distance;
  /// A linear motor: q = row . (x, y, z, e). Unused when `curve` is set.
  std::array<double, 4> row{};
  /// A non-linear motor (null for a linear one).
  std::shared_ptr<const MotorCurve> curve;
  [[nodiscard]] bool linear() const { return curve == nullptr; }
};

/// The toolhead limits a kinematics reads at start-up (Klipper [printer]).
struct Toolhead {
  double max_velocity_mm_s = 0.0;
  double max_accel_mm_s2 = 0.0;
  double max_z_velocity_mm_s = 0.0;  ///< 0 = max_velocity
  double max_z_accel_mm_s2 = 0.0;    ///< 0 = max_accel
};

/// What a kinematics is built from besides its own parameters.
struct Context {
  Toolhead toolhead;
  /// Step distance of every motor the machine has a drive train for, by drive-train key, in
  /// the unit the kinematics gives that motor (motor_units()).
  std::map<std::string, double> step_distance;
  /// Name of the machine, for messages.
  std::string machine_name;
};

/// A move as Klipper's check_move sees it: the toolhead from `start` to `end` (machine
/// coordinates), its displacement `d` and length [mm].
struct MoveGeometry {
  std::array<double, 4> start{}, end{}, d{};
  double distance_mm = 0.0;
  /// The toolhead's limits in force (Klipper's toolhead.get_max_velocity(): max_velocity and
  /// max_accel as SET_VELOCITY_LIMIT and M204 left them).
  double toolhead_velocity_mm_s = 0.0, toolhead_accel_mm_s2 = 0.0;
};

/// The first place a move leaves the build volume (Klipper: "Move out of range").
struct RangeViolation {
  char axis = 'x';            ///< 'x', 'y', 'z'; 'r' for a radius sqrt(x^2 + y^2)
  double position_mm = 0.0;   ///< the move's end on that axis
  double limit_mm = 0.0;      ///< the limit it passes
};

/// The parts of check_move every cartesian-like kinematics shares, as plain data the planner
/// applies inline (the hot path), plus a flag for the ones that need the kinematics itself.
struct MoveRules {
  /// Z limits scaled to the move (|d_z| / distance): Klipper's max_z_velocity, max_z_accel;
  /// unset: no Z limit (none, winch, rotary delta).
  std::optional<double> z_velocity_mm_s, z_accel_mm_s2;
  /// Per-axis ranges an axis that moves must end in (position_min / position_max).
  std::array<std::optional<double>, 3> range_min_mm{}, range_max_mm{};
  /// The kinematics checks moves itself (check_range, limit_move): delta, deltesian, polar,
  /// rotary delta.
  bool special = false;
  /// The kinematics lowers each kinematic move's velocity and accel itself (limit_move) while
  /// its ranges stay the inline ones above: the per-axis limits of the limited kinematics.
  bool limits_speed = false;
};

/// Where G28 leaves the toolhead.
struct Homing {
  /// The toolhead position after homing each axis; unset: amctl's 0 (Marlin-style).
  std::array<std::optional<double>, 3> position_mm{};
  /// Klipper homes all axes together whatever G28 names (delta, deltesian, rotary delta).
  bool all_axes = false;
  /// The position holds on Klipper only (the cartesian family: a Marlin machine homes to 0).
  bool klipper_only = false;
};

/// An IDEX pair: a second carriage on X or Y with its own rail (Klipper [dual_carriage],
/// idex_modes.py; generic_cartesian's [dual_carriage NAME] with a primary_carriage).
struct IdexPair {
  int axis = 0;                        ///< 0 = X, 1 = Y
  std::array<std::string, 2> names{};  ///< carriage names (empty on cartesian/hybrid: 0 and 1)
  std::array<double, 2> position_min_mm{}, position_max_mm{}, position_endstop_mm{};
  std::optional<double> safe_distance_mm;
  std::array<double, 2> homing_speed_mm_s{5.0, 5.0};
};

/// The linear motor map of a kinematics: motor i's position = rows[i] . (x, y, z). Only
/// kinematics whose every motor is linear have one.
struct LinearMap {
  std::vector<std::string> motors;      ///< Klipper's names, as Motor::name
  std::vector<std::array<double, 3>> rows;
};

class Kinematics {
 public:
  virtual ~Kinematics() = default;
  /// Klipper's name: "cartesian", "corexy", ...
  [[nodiscard]] virtual std::string_view name() const = 0;
  /// The motors in Klipper's order (stepper_x, stepper_y, stepper_z, stepper_z1, ...), then the
  /// extruder: those of `drive_train_keys` this kinematics moves. `missing` gets the Klipper
  /// names of required motors without a drive train.
  [[nodiscard]] virtual std::vector<Motor> motors(const std::vector<std::string>& drive_train_keys,
                                                  std::vector<std::string>& missing) const = 0;
  /// The planner's inline rules.
  [[nodiscard]] virtual MoveRules move_rules() const = 0;
  /// check_move's build volume (MoveRules::special): the first violation of a kinematic move.
  [[nodiscard]] virtual std::optional<RangeViolation> check_range(const MoveGeometry& m) const;
  /// check_move's speed limits (MoveRules::special): lowers velocity and accel.
  virtual void limit_move(const MoveGeometry& m, double& velocity_mm_s, double& accel_mm_s2) const;
  [[nodiscard]] virtual Homing homing() const { return {}; }
  [[nodiscard]] virtual std::vector<IdexPair> idex_pairs() const { return {}; }
  /// generic_cartesian: the steppers' carriages expressions (SET_STEPPER_CARRIAGES).
  [[nodiscard]] virtual std::map<std::string, std::string, std::less<>> stepper_carriages() const {
    return {};
  }
  /// generic_cartesian: Klipper's checks of SET_STEPPER_CARRIAGES; empty when accepted.
  [[nodiscard]] virtual std::string stepper_carriages_error(
      const std::map<std::string, std::string, std::less<>>& now, const std::string& stepper,
      const std::string& expr, bool full) const;
  /// The linear motor map; unset for a non-linear kinematics.
  [[nodiscard]] virtual std::optional<LinearMap> linear_map() const { return std::nullopt; }
  /// What the kinematics derives at start-up, for `amctl machine show --json` (delta: build
  /// radius, speed zones; ...): entries added to `machine`.
  virtual void describe(Json& machine) const { (void)machine; }
};

/// Klipper's names of the extra motors of an axis: "z" -> z, z1, z2, ... among `keys`, in
/// numeric order.
[[nodiscard]] std::vector<std::string> axis_motor_keys(const std::vector<std::string>& keys,
                                                       std::string_view axis);
/// "stepper_" + key.
[[nodiscard]] std::string stepper_name(std::string_view key);

}  // namespace amctl::kinematics
