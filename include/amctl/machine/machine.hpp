#pragma once
// The machine description: everything the planner needs to know about a printer.
// Units: mm, s, mm/s, mm/s^2 throughout. A Machine is an immutable value; build it from a
// TOML file, a Klipper printer.cfg or a preset (see loader.hpp), then override fields.
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/config_section.hpp"

namespace amctl::machine {

/// How the printer maps motor positions to the tool position (Klipper's kinematics of the
/// same names, klippy/kinematics/*.py; docs/machine.md "Kinematics"). Cartesian, CoreXY,
/// CoreXZ and the hybrid (Markforged) gantries map linearly; delta does not. `none` has no
/// motors (Klipper's developer kinematics: no speed limit but the toolhead's). A winch (cable
/// robot) has 3 or 4 cables, each motor's position the cable length |tool - anchor|; Klipper
/// checks no limit on it either.
/// A deltesian has two towers (stepper_left, stepper_right) in the XZ plane and a cartesian Y.
/// generic_cartesian maps carriages (one per axis, plus extra and dual carriages) to steppers
/// by a linear combination per stepper (`carriages: carriage_x+carriage_y`). A polar printer
/// turns its bed (stepper_bed, an angle) under a radial arm (stepper_arm) with a cartesian Z.
/// A rotary delta swings three arms (stepper_a, _b, _c, angles) about shoulders on a
/// platform above the bed.
enum class Kinematics {
  cartesian, corexy, corexz, hybrid_corexy, hybrid_corexz, delta, none, winch, deltesian,
  generic_cartesian, polar, rotary_delta
};

/// Whose G-code semantics apply. Klipper ignores M201/M203/M205 and takes accel from
/// M204 S (or min(P, T)); Marlin applies M201-M205 as slicers emit them; RepRapFirmware
/// reads jerk from M566 (mm/min).
enum class Firmware { klipper, marlin, reprap };

/// How the speed through a corner between two moves is limited.
enum class JunctionPolicy {
  square_corner_velocity,  ///< Klipper: junction deviation derived from square_corner_velocity
  junction_deviation,      ///< Marlin JD (JUNCTION_DEVIATION_MM), with its small-segment limit
  classic_jerk             ///< Marlin/RRF classic jerk: max instantaneous per-axis speed change
};

/// Shape of each acceleration phase.
enum class VelocityProfile {
  trapezoid,   ///< constant acceleration (Klipper, Marlin default)
  scurve7,     ///< seven-segment jerk-limited S-curve (five phases when some vanish)
  bezier5      ///< Marlin S_CURVE_ACCELERATION: quintic Bezier velocity ramp
};

enum Axis : int { X = 0, Y = 1, Z = 2, E = 3 };

/// Extruder limits; Klipper [extruder] semantics.
struct Extruder {
  double nozzle_diameter_mm = 0.4;
  double filament_diameter_mm = 1.75;
  /// Extrude-only (and retract) move limits. Unset = Klipper's defaults derived from
  /// the toolhead limits times (4 d_nozzle^2) / filament area.
  std::optional<double> max_extrude_only_velocity_mm_s;
  std::optional<double> max_extrude_only_accel_mm_s2;
  double max_extrude_only_distance_mm = 50.0;
  /// Max instantaneous change of extruder speed at a junction (Klipper).
  double instantaneous_corner_velocity_mm_s = 1.0;
  /// Unset = 4 * nozzle_diameter^2 (Klipper's default).
  std::optional<double> max_extrude_cross_section_mm2;
  bool operator==(const Extruder&) const = default;
};

/// One stepper's drive train: distance per full motor revolution and stepping.
struct Stepper {
  double rotation_distance_mm = 40.0;
  int microsteps = 16;
  int full_steps_per_rotation = 200;
  /// Klipper [stepper_*] position_min / position_max / position_endstop (machine
  /// coordinates). Klipper refuses a move whose end lies outside [position_min,
  /// position_max] ("Move out of range"). Unset: no range known (presets, TOML without them).
  std::optional<double> position_min_mm, position_max_mm, position_endstop_mm;
  /// Delta towers (stepper_a, _b, _c): Klipper arm_length (diagonal rod, > delta radius) and
  /// angle of the tower around the centre [degrees]. Unset on b and c: a's arm length; the
  /// angles default to 210, 330, 90 (kinematics/delta.py).
  std::optional<double> arm_length_mm, angle_deg;
  /// Winch cables (stepper_a .. stepper_d): the anchor point of the cable [mm] (Klipper
  /// anchor_x, anchor_y, anchor_z; required for a winch).
  std::optional<double> anchor_x_mm, anchor_y_mm, anchor_z_mm;
  /// Deltesian towers (stepper_left, stepper_right): horizontal distance from the centre to the
  /// arm's joint on the carriage (Klipper arm_x_length; required on left, right defaults to it).
  std::optional<double> arm_x_length_mm;
  /// The motor, its driver and the drive train, for step-level physics (amctl stepper
  /// simulate, docs/closedloop.md); unset: the library defaults there (a 17HS4401-class
  /// NEMA17). run_current is RMS, as Klipper's [tmc* stepper_x] run_current.
  std::optional<double> run_current_a, supply_voltage_v, holding_torque_n_m, rated_current_a,
      phase_resistance_ohm, phase_inductance_h, rotor_inertia_kg_m2, detent_torque_n_m,
      backlash_mm;
  /// The motor by preset name (amctl/machine/motor_presets.hpp, e.g. "ldo-42sth48-2004mah");
  /// the numeric keys above override single values of it. Empty: the default preset.
  std::string motor;
  /// Rotary delta arms (stepper_a, _b, _c): upper arm (shoulder to elbow) and lower arm
  /// (elbow to effector) lengths (Klipper upper_arm_length, lower_arm_length; required on a,
  /// b and c default to a's).
  std::optional<double> upper_arm_length_mm, lower_arm_length_mm;
  /// generic_cartesian steppers: Klipper's `carriages` expression, the stepper's position as a
  /// linear combination of carriages, e.g. "carriage_x+carriage_y", "carriage_u-carriage_y1",
  /// "1*carriage_y+0.5*carriage_z". Empty for every other kinematics.
  std::string carriages;
  [[nodiscard]] double steps_per_mm() const {
    return microsteps * full_steps_per_rotation / rotation_distance_mm;
  }
  bool operator==(const Stepper&) const = default;
};

/// Arc (G2/G3) linearisation.
struct Arcs {
  /// G2/G3 (and G17-G19) are commands at all. Klipper registers them only with a
  /// [gcode_arcs] section (klippy/extras/gcode_arcs.py); without it they are "Unknown
  /// command" and skipped. A printer.cfg sets this from that section; TOML machines and
  /// presets default to true.
  bool enabled = true;
  /// Klipper [gcode_arcs] resolution / Marlin MM_PER_ARC_SEGMENT: target chord length.
  double mm_per_arc_segment = 1.0;
  /// Marlin MIN_ARC_SEGMENT_MM (0 = Klipper behaviour: no lower clamp).
  double min_arc_segment_mm = 0.0;
  /// Marlin MAX_ARC_SEGMENT_MM (0 = no upper clamp).
  double max_arc_segment_mm = 0.0;
  /// Marlin ARC_SEGMENTS_PER_SEC (0 = off): caps segments per second of motion.
  double segments_per_second = 0.0;
  /// Marlin MIN_CIRCLE_SEGMENTS / Prusa MIN_ARC_SEGMENTS (0 = off): at least this many
  /// segments per full circle, i.e. segment length <= 2 pi r / n (never below min_arc_segment_mm).
  int min_circle_segments = 0;
  bool operator==(const Arcs&) const = default;
};

/// G10/G11 firmware retraction (Klipper [firmware_retraction], Marlin FWRETRACT / M207 M208).
/// Defaults are Klipper's.
struct FirmwareRetraction {
  double retract_length_mm = 0.0;
  double retract_speed_mm_s = 20.0;
  double unretract_extra_length_mm = 0.0;
  double unretract_speed_mm_s = 10.0;
  double lift_z_mm = 0.0;  ///< Marlin RETRACT_ZRAISE (M207 Z); Klipper has none
  bool operator==(const FirmwareRetraction&) const = default;
};

/// Input shaping as configured on the printer: Klipper [input_shaper] (Marlin sets it with
/// M593 in the G-code instead). It does not change the plan or the print time; `amctl
/// simulate` applies it to the commanded motion (docs/dynamics.md, "Input shaping"). A
/// frequency of 0 leaves that axis unshaped (Klipper's default). Defaults are Klipper's
/// (input_shaper.py: type mzv, damping ratio 0.1).
struct InputShaper {
  std::string shaper_type_x = "mzv";  ///< a type as `amctl shaper show` accepts it
  std::string shaper_type_y = "mzv";
  double shaper_freq_x_hz = 0.0;
  double shaper_freq_y_hz = 0.0;
  double damping_ratio_x = 0.1;
  double damping_ratio_y = 0.1;
  /// true when any axis has a frequency > 0.
  [[nodiscard]] bool active() const { return shaper_freq_x_hz > 0.0 || shaper_freq_y_hz > 0.0; }
  bool operator==(const InputShaper&) const = default;
};

/// Linear delta geometry (Klipper [printer] delta_radius, print_radius, minimum_z_position);
/// the towers' arm lengths, angles and endstops are in stepper_a, _b, _c. Read only when
/// kinematics = delta; machine/delta.hpp derives the build volume and speed zones.
struct Delta {
  std::optional<double> radius_mm;              ///< delta_radius (required for a delta)
  std::optional<double> print_radius_mm;        ///< unset: delta_radius
  std::optional<double> minimum_z_position_mm;  ///< unset: 0 (delta and deltesian)
  /// Deltesian only (Klipper [printer] min_angle, print_width, slow_ratio): the arms' smallest
  /// angle with the horizontal (default 5 degrees), the printable width in X (unset: what
  /// the arms reach), and the tower-to-effector speed ratio beyond which moves slow down
  /// (default 3; 0 = never).
  std::optional<double> min_angle_deg, print_width_mm, slow_ratio;
  /// Rotary delta only (Klipper [printer] shoulder_radius, shoulder_height; both required):
  /// horizontal distance from the centre to each shoulder joint, and its height above z = 0.
  std::optional<double> shoulder_radius_mm, shoulder_height_mm;
  bool operator==(const Delta&) const = default;
};

/// A generic_cartesian carriage (Klipper [carriage NAME], [extra_carriage NAME],
/// [dual_carriage NAME]; klippy/kinematics/generic_cartesian.py). A primary carriage moves
/// one axis and holds its range; an extra carriage moves with its primary (a second belt or
/// motor of the same axis); a dual carriage is the second carriage of an IDEX axis, parked
/// while the primary prints (amctl does not model SET_DUAL_CARRIAGE).
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
  /// Primary and dual carriages: homing_speed (Klipper's default 5 mm/s); the lowest one of
  /// the dual-carriage rails is RESTORE_DUAL_CARRIAGE_STATE's speed.
  double homing_speed_mm_s = 5.0;
  /// Dual carriages with a primary_carriage: safe_distance (unset: from the rails, as Klipper).
  std::optional<double> safe_distance_mm;
  bool operator==(const Carriage&) const = default;
};

/// Klipper [dual_carriage] (IDEX, klippy/kinematics/idex_modes.py): a second carriage on X or
/// Y with its own rail. The first carriage's rail is [stepper_x] (or _y) of `steppers`.
struct DualCarriage {
  std::string axis;  ///< "" = no dual carriage; "x" or "y"
  /// The second carriage's rail (machine coordinates); position_min defaults to 0 and
  /// position_endstop and position_max are required, as in Klipper.
  std::optional<double> position_min_mm, position_max_mm, position_endstop_mm;
  /// Klipper safe_distance (the closest the carriages may come); unset: the smaller
  /// difference of the rails' minima or maxima (0 = no collision check), as Klipper.
  std::optional<double> safe_distance_mm;
  /// homing_speed of the second rail and of the first one: RESTORE_DUAL_CARRIAGE_STATE moves
  /// at the lower of the two (Klipper's default is 5 mm/s).
  double homing_speed_mm_s = 5.0;
  double primary_homing_speed_mm_s = 5.0;
  [[nodiscard]] bool present() const { return !axis.empty(); }
  bool operator==(const DualCarriage&) const = default;
};

struct Machine {
  std::string name = "default";
  Firmware firmware = Firmware::klipper;
  Kinematics kinematics = Kinematics::cartesian;
  JunctionPolicy junction = JunctionPolicy::square_corner_velocity;
  VelocityProfile profile = VelocityProfile::trapezoid;

  // --- Toolhead limits (Klipper [printer]) ---
  double max_velocity_mm_s = 300.0;
  double max_accel_mm_s2 = 3000.0;
  double square_corner_velocity_mm_s = 5.0;
  /// Klipper minimum_cruise_ratio (0 <= r < 1). The older max_accel_to_decel A maps to
  /// 1 - A / max_accel.
  double minimum_cruise_ratio = 0.5;
  double max_z_velocity_mm_s = 0.0;   ///< 0 = same as max_velocity
  double max_z_accel_mm_s2 = 0.0;     ///< 0 = same as max_accel
  /// Polar only (Klipper max_angular_velocity; unset or 0 = no limit): moves passing within d
  /// of the bed's centre at speed v are slowed when v / d exceeds it [rad/s].
  std::optional<double> max_angular_velocity_rad_s;

  // --- Marlin-style per-axis limits (X, Y, Z, E); used when firmware = marlin/reprap ---
  std::array<double, 4> max_feedrate_mm_s{500, 500, 12, 120};     ///< M203
  std::array<double, 4> max_axis_accel_mm_s2{9000, 9000, 500, 10000};  ///< M201
  double print_accel_mm_s2 = 1250;    ///< M204 P (or S)
  double retract_accel_mm_s2 = 1250;  ///< M204 R
  double travel_accel_mm_s2 = 1250;   ///< M204 T
  std::array<double, 4> jerk_mm_s{8, 8, 0.4, 5};  ///< M205 X Y Z E (classic jerk)
  double junction_deviation_mm = 0.013;         ///< M205 J
  double min_feedrate_mm_s = 0.0;               ///< M205 S
  double min_travel_feedrate_mm_s = 0.0;        ///< M205 T
  double min_segment_time_s = 0.0;              ///< M205 B (us in G-code; s here)
  /// Marlin BLOCK_BUFFER_SIZE: moves the look-ahead can see (bounds how far ahead it plans).
  int block_buffer_size = 16;
  /// Marlin soft endstops (MIN_SOFTWARE_ENDSTOPS / MAX_SOFTWARE_ENDSTOPS with X_MIN_POS ...
  /// X_MAX_POS): targets are clamped into [min, max] per axis X, Y, Z. Unset: no clamping.
  std::array<std::optional<double>, 3> soft_min_position_mm{}, soft_max_position_mm{};

  /// Jerk for the jerk-limited profiles (scurve7). [mm/s^3]
  double max_jerk_mm_s3 = 1.0e6;

  Extruder extruder;
  Arcs arcs;
  FirmwareRetraction firmware_retraction;
  InputShaper input_shaper;
  Delta delta;
  DualCarriage dual_carriage;
  /// Klipper [exclude_object]: EXCLUDE_OBJECT_* commands skip the moves of excluded objects
  /// (a printer.cfg without the section: they are unknown commands, as in Klipper).
  bool exclude_object = false;
  /// Keyed "x", "y", "z", "e" (plus "z1", "z2", ... for extra motors on one axis); a delta's
  /// towers are "a", "b", "c"; a polar printer's "bed", "arm", "z"; a generic_cartesian's by
  /// their names. The polar bed and the rotary delta's arms turn: their rotation_distance is
  /// in radians (2 pi / gear ratio, Klipper's units_in_radians).
  /// rotation_distance_mm is per motor revolution (any gear_ratio is folded in).
  std::map<std::string, Stepper> steppers;
  /// generic_cartesian only: the carriages by name (Klipper's section name without the
  /// [carriage ] prefix). The steppers are then keyed by their own names ([stepper NAME]).
  std::map<std::string, Carriage> carriages;
  /// A Klipper printer.cfg's sections as written (includes resolved, SAVE_CONFIG merged), in
  /// order of first appearance: Klipper's printer.configfile and the [gcode_macro] sections
  /// (docs/macros.md). Empty for TOML machines and presets; not written by to_toml.
  std::vector<ConfigSection> klipper_config;

  bool operator==(const Machine&) const = default;
};

}  // namespace amctl::machine
