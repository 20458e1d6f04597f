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
#include "amctl/kinematics/extruder.hpp"
#include "amctl/kinematics/params.hpp"

namespace amctl::machine {

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

/// Klipper [extruder] semantics, with pressure advance (kinematics/extruder.hpp).
using Extruder = kinematics::Extruder;

/// One stepper's drive train (distance per full motor revolution and stepping) and the motor
/// physics. What the motor moves is its kinematics' (kinematics/*.hpp).
struct Stepper {
  /// Travel per motor revolution [mm] of a motor that moves a carriage, a belt or a cable
  /// (Klipper rotation_distance; any gear_ratio is folded in).
  double rotation_distance_mm = 40.0;
  int microsteps = 16;
  int full_steps_per_rotation = 200;
  /// A motor that turns (a polar bed, a rotary delta's arms; Klipper's units_in_radians): its
  /// output's turn per motor revolution [rad], 2 pi / gear_ratio. Set for those motors only;
  /// rotation_distance_mm is then unused.
  std::optional<double> rotation_distance_rad;
  /// The motor, its driver and the drive train, for step-level physics (amctl stepper
  /// simulate, docs/closedloop.md); unset: the library defaults there (a 17HS4401-class
  /// NEMA17). run_current is RMS, as Klipper's [tmc* stepper_x] run_current.
  std::optional<double> run_current_a, supply_voltage_v, holding_torque_n_m, rated_current_a,
      phase_resistance_ohm, phase_inductance_h, rotor_inertia_kg_m2, detent_torque_n_m,
      backlash_mm;
  /// The motor by preset name (amctl/machine/motor_presets.hpp, e.g. "ldo-42sth48-2004mah");
  /// the numeric keys above override single values of it. Empty: the default preset.
  std::string motor;
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
  /// Z (Klipper's input_shaper.py shapes Z too: shaper_type_z, shaper_freq_z, damping_ratio_z).
  std::string shaper_type_z = "mzv";
  double shaper_freq_z_hz = 0.0;
  double damping_ratio_z = 0.1;
  /// true when any axis has a frequency > 0.
  [[nodiscard]] bool active() const {
    return shaper_freq_x_hz > 0.0 || shaper_freq_y_hz > 0.0 || shaper_freq_z_hz > 0.0;
  }
  bool operator==(const InputShaper&) const = default;
};

struct Machine {
  std::string name = "default";
  Firmware firmware = Firmware::klipper;
  /// How the motors move the toolhead: the kinematics and its parameters (Klipper's
  /// kinematics of the same names; docs/machine.md "Kinematics").
  kinematics::Params kinematics = kinematics::Cartesian{};
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
  /// Klipper [exclude_object]: EXCLUDE_OBJECT_* commands skip the moves of excluded objects
  /// (a printer.cfg without the section: they are unknown commands, as in Klipper).
  bool exclude_object = false;
  /// The motors' drive trains, keyed "x", "y", "z", "e" (plus "z1", "z2", ... for extra
  /// motors on one axis); a delta's towers are "a", "b", "c"; a polar printer's "bed", "arm",
  /// "z"; a generic_cartesian's by their names ([stepper NAME]).
  std::map<std::string, Stepper> steppers;
  /// A Klipper printer.cfg's sections as written (includes resolved, SAVE_CONFIG merged), in
  /// order of first appearance: Klipper's printer.configfile and the [gcode_macro] sections
  /// (docs/macros.md). Empty for TOML machines and presets; not written by to_toml.
  std::vector<ConfigSection> klipper_config;

  bool operator==(const Machine&) const = default;
};

}  // namespace amctl::machine
