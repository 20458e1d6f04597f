#include "schema.hpp"

#include "kinematics_keys.hpp"
#include "amctl/machine/motor_presets.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace amctl::machine::detail {
namespace {

#define AMCTL_NUM(expr) [](Machine& m) -> double& { return m.expr; }
#define AMCTL_OPT(expr) [](Machine& m) -> std::optional<double>& { return m.expr; }
#define AMCTL_INT(expr) [](Machine& m) -> int& { return m.expr; }
#define AMCTL_AXES(expr) [](Machine& m) -> std::array<double, 4>& { return m.expr; }

constexpr std::string_view kFirmwareNames[] = {"klipper", "marlin", "reprap"};
constexpr std::string_view kJunctionNames[] = {"square_corner_velocity", "junction_deviation",
                                               "classic_jerk"};
constexpr std::string_view kProfileNames[] = {"trapezoid", "scurve7", "bezier5"};

constexpr std::string_view kSections[] = {"printer", "marlin", "extruder", "arcs",
                                          "firmware_retraction", "input_shaper", "delta",
                                          "dual_carriage"};

const std::vector<KeyDef>& key_table() {
  static const std::vector<KeyDef> keys = [] {
    std::vector<KeyDef> k;
    auto add = [&k](KeyDef d) { k.push_back(d); };
    // ---- [printer] ----
    add({"printer", "name", Kind::text, Bound::finite, "", "Machine name shown in reports.",
         nullptr, nullptr, nullptr, nullptr, [](Machine& m) -> std::string& { return m.name; }});
    add({"printer", "firmware", Kind::firmware, Bound::finite, "",
         "Whose G-code semantics apply: klipper, marlin or reprap."});
    static const std::string kinematics_doc = [] {
      const auto names = kinematics::names();
      std::string list;
      for (std::size_t i = 0; i < names.size(); ++i) {
        list += i == 0 ? "" : i + 1 == names.size() ? " or " : ", ";
        list += names[i];
      }
      return list + " (Klipper's kinematics of those names, the limited_* ones Kalico's; per-axis limits apply to X, Y, Z, E "
                    "of the tool).";
    }();
    add({"printer", "kinematics", Kind::kinematics, Bound::finite, "", kinematics_doc});
    add({"printer", "junction", Kind::junction, Bound::finite, "",
         "Corner speed policy: square_corner_velocity (Klipper), junction_deviation (Marlin JD) "
         "or classic_jerk (Marlin/RRF jerk). Default: square_corner_velocity for klipper, "
         "junction_deviation for marlin, classic_jerk for reprap."});
    add({"printer", "profile", Kind::profile, Bound::finite, "",
         "Shape of each acceleration phase: trapezoid, scurve7 or bezier5."});
    add({"printer", "max_velocity", Kind::number, Bound::positive, "mm/s",
         "Klipper toolhead velocity limit (SET_VELOCITY_LIMIT VELOCITY).",
         AMCTL_NUM(max_velocity_mm_s)});
    add({"printer", "max_accel", Kind::number, Bound::positive, "mm/s^2",
         "Klipper toolhead acceleration (SET_VELOCITY_LIMIT ACCEL, M204).",
         AMCTL_NUM(max_accel_mm_s2)});
    add({"printer", "square_corner_velocity", Kind::number, Bound::non_negative, "mm/s",
         "Klipper: speed through a 90 degree corner; sets the junction deviation "
         "scv^2 (sqrt(2)-1) / max_accel.",
         AMCTL_NUM(square_corner_velocity_mm_s)});
    add({"printer", "minimum_cruise_ratio", Kind::number, Bound::ratio, "",
         "Klipper: fraction of each move that must be spent cruising (0 disables).",
         AMCTL_NUM(minimum_cruise_ratio)});
    add({"printer", "max_accel_to_decel", Kind::accel_to_decel, Bound::positive, "mm/s^2",
         "Read-only legacy Klipper key: sets minimum_cruise_ratio = 1 - min(1, value / "
         "max_accel) unless minimum_cruise_ratio is also given. Never written back."});
    add({"printer", "max_z_velocity", Kind::number, Bound::non_negative, "mm/s",
         "Klipper Z velocity limit; 0 = same as max_velocity.", AMCTL_NUM(max_z_velocity_mm_s)});
    add({"printer", "max_z_accel", Kind::number, Bound::non_negative, "mm/s^2",
         "Klipper Z acceleration limit; 0 = same as max_accel.", AMCTL_NUM(max_z_accel_mm_s2)});
    add({"printer", "max_jerk", Kind::number, Bound::positive, "mm/s^3",
         "Jerk limit of the jerk-limited profile (scurve7).", AMCTL_NUM(max_jerk_mm_s3)});
    // ---- [marlin] ----
    add({"marlin", "max_feedrate", Kind::axes4, Bound::positive, "mm/s",
         "Per-axis speed limits [x, y, z, e] (M203; DEFAULT_MAX_FEEDRATE).", nullptr, nullptr,
         nullptr, AMCTL_AXES(max_feedrate_mm_s)});
    add({"marlin", "max_accel", Kind::axes4, Bound::positive, "mm/s^2",
         "Per-axis acceleration limits [x, y, z, e] (M201; DEFAULT_MAX_ACCELERATION).", nullptr,
         nullptr, nullptr, AMCTL_AXES(max_axis_accel_mm_s2)});
    add({"marlin", "print_accel", Kind::number, Bound::positive, "mm/s^2",
         "Acceleration of printing moves (M204 P or S; DEFAULT_ACCELERATION).",
         AMCTL_NUM(print_accel_mm_s2)});
    add({"marlin", "retract_accel", Kind::number, Bound::positive, "mm/s^2",
         "Acceleration of E-only moves (M204 R; DEFAULT_RETRACT_ACCELERATION).",
         AMCTL_NUM(retract_accel_mm_s2)});
    add({"marlin", "travel_accel", Kind::number, Bound::positive, "mm/s^2",
         "Acceleration of non-extruding moves (M204 T; DEFAULT_TRAVEL_ACCELERATION).",
         AMCTL_NUM(travel_accel_mm_s2)});
    add({"marlin", "jerk", Kind::axes4, Bound::non_negative, "mm/s",
         "Classic jerk [x, y, z, e]: largest instantaneous speed change per axis (M205 X Y Z "
         "E; DEFAULT_XJERK...). Also RepRapFirmware M566 (given there in mm/min).",
         nullptr, nullptr, nullptr, AMCTL_AXES(jerk_mm_s)});
    add({"marlin", "junction_deviation", Kind::number, Bound::positive, "mm",
         "Marlin junction deviation (M205 J; JUNCTION_DEVIATION_MM).",
         AMCTL_NUM(junction_deviation_mm)});
    add({"marlin", "min_feedrate", Kind::number, Bound::non_negative, "mm/s",
         "Minimum speed of printing moves (M205 S; DEFAULT_MINIMUMFEEDRATE).",
         AMCTL_NUM(min_feedrate_mm_s)});
    add({"marlin", "min_travel_feedrate", Kind::number, Bound::non_negative, "mm/s",
         "Minimum speed of travel moves (M205 T; DEFAULT_MINTRAVELFEEDRATE).",
         AMCTL_NUM(min_travel_feedrate_mm_s)});
    add({"marlin", "min_segment_time", Kind::number, Bound::non_negative, "s",
         "Shortest time a move may take when the queue runs low (M205 B, given there in us; "
         "DEFAULT_MINSEGMENTTIME 20000 us = 0.02 s).",
         AMCTL_NUM(min_segment_time_s)});
    add({"marlin", "min_position_x", Kind::optional_number, Bound::finite, "mm",
         "Soft endstop: lowest X a move may reach; targets beyond are clamped (X_MIN_POS "
         "with MIN_SOFTWARE_ENDSTOPS; unset = no clamping).",
         nullptr, AMCTL_OPT(soft_min_position_mm[0])});
    add({"marlin", "min_position_y", Kind::optional_number, Bound::finite, "mm",
         "Soft endstop: lowest Y a move may reach; targets beyond are clamped (Y_MIN_POS "
         "with MIN_SOFTWARE_ENDSTOPS; unset = no clamping).",
         nullptr, AMCTL_OPT(soft_min_position_mm[1])});
    add({"marlin", "min_position_z", Kind::optional_number, Bound::finite, "mm",
         "Soft endstop: lowest Z a move may reach; targets beyond are clamped (Z_MIN_POS "
         "with MIN_SOFTWARE_ENDSTOPS; unset = no clamping).",
         nullptr, AMCTL_OPT(soft_min_position_mm[2])});
    add({"marlin", "max_position_x", Kind::optional_number, Bound::finite, "mm",
         "Soft endstop: highest X a move may reach; targets beyond are clamped (X_MAX_POS "
         "with MAX_SOFTWARE_ENDSTOPS; unset = no clamping).",
         nullptr, AMCTL_OPT(soft_max_position_mm[0])});
    add({"marlin", "max_position_y", Kind::optional_number, Bound::finite, "mm",
         "Soft endstop: highest Y a move may reach; targets beyond are clamped (Y_MAX_POS "
         "with MAX_SOFTWARE_ENDSTOPS; unset = no clamping).",
         nullptr, AMCTL_OPT(soft_max_position_mm[1])});
    add({"marlin", "max_position_z", Kind::optional_number, Bound::finite, "mm",
         "Soft endstop: highest Z a move may reach; targets beyond are clamped (Z_MAX_POS "
         "with MAX_SOFTWARE_ENDSTOPS; unset = no clamping).",
         nullptr, AMCTL_OPT(soft_max_position_mm[2])});
    add({"marlin", "block_buffer_size", Kind::integer, Bound::at_least_one, "moves",
         "Planner queue length (BLOCK_BUFFER_SIZE): how many moves the look-ahead sees.",
         nullptr, nullptr, AMCTL_INT(block_buffer_size)});
    add({"printer", "exclude_object", Kind::boolean, Bound::finite, "",
         "Klipper [exclude_object]: EXCLUDE_OBJECT_DEFINE/_START/_END and EXCLUDE_OBJECT are "
         "modelled (the moves of excluded objects are not made). false: they are counted as "
         "ignored commands (a printer.cfg without the section: unknown, as in Klipper).",
         nullptr, nullptr, nullptr, nullptr, nullptr,
         [](Machine& m) -> bool& { return m.exclude_object; }});
    // ---- [arcs] ----
    add({"arcs", "enabled", Kind::boolean, Bound::finite, "",
         "G2/G3 (and G17-G19) are commands: false = unknown commands, reported and skipped "
         "(Klipper without a [gcode_arcs] section).",
         nullptr, nullptr, nullptr, nullptr, nullptr,
         [](Machine& m) -> bool& { return m.arcs.enabled; }});
    add({"arcs", "resolution", Kind::number, Bound::positive, "mm",
         "Target chord length of G2/G3 segments (Klipper [gcode_arcs] resolution; Marlin "
         "MM_PER_ARC_SEGMENT / MAX_ARC_SEGMENT_MM).",
         AMCTL_NUM(arcs.mm_per_arc_segment)});
    add({"arcs", "min_segment", Kind::number, Bound::non_negative, "mm",
         "Marlin MIN_ARC_SEGMENT_MM: lower clamp of the segment length (0 = none).",
         AMCTL_NUM(arcs.min_arc_segment_mm)});
    add({"arcs", "max_segment", Kind::number, Bound::non_negative, "mm",
         "Marlin MAX_ARC_SEGMENT_MM: upper clamp of the segment length (0 = none).",
         AMCTL_NUM(arcs.max_arc_segment_mm)});
    add({"arcs", "min_circle_segments", Kind::integer, Bound::non_negative, "",
         "Marlin MIN_CIRCLE_SEGMENTS / Prusa MIN_ARC_SEGMENTS: at least this many segments per "
         "full circle (0 = off).",
         nullptr, nullptr, AMCTL_INT(arcs.min_circle_segments)});
    add({"arcs", "segments_per_second", Kind::number, Bound::non_negative, "1/s",
         "Marlin ARC_SEGMENTS_PER_SEC: segment length from feedrate (0 = off).",
         AMCTL_NUM(arcs.segments_per_second)});
    // ---- [firmware_retraction] ----
    add({"firmware_retraction", "retract_length", Kind::number, Bound::non_negative, "mm",
         "G10 retraction length (Klipper retract_length; Marlin M207 S / RETRACT_LENGTH).",
         AMCTL_NUM(firmware_retraction.retract_length_mm)});
    add({"firmware_retraction", "retract_speed", Kind::number, Bound::positive, "mm/s",
         "G10 retraction speed (Marlin M207 F / RETRACT_FEEDRATE).",
         AMCTL_NUM(firmware_retraction.retract_speed_mm_s)});
    add({"firmware_retraction", "unretract_extra_length", Kind::number, Bound::non_negative,
         "mm", "Extra filament pushed by G11 (Marlin M208 S / RETRACT_RECOVER_LENGTH).",
         AMCTL_NUM(firmware_retraction.unretract_extra_length_mm)});
    add({"firmware_retraction", "unretract_speed", Kind::number, Bound::positive, "mm/s",
         "G11 speed (Marlin M208 F / RETRACT_RECOVER_FEEDRATE).",
         AMCTL_NUM(firmware_retraction.unretract_speed_mm_s)});
    add({"firmware_retraction", "lift_z", Kind::number, Bound::non_negative, "mm",
         "Z hop of G10 (Marlin M207 Z / RETRACT_ZRAISE; Klipper has none).",
         AMCTL_NUM(firmware_retraction.lift_z_mm)});
    // ---- [input_shaper] ----
    add({"input_shaper", "shaper_type_x", Kind::text, Bound::finite, "",
         "Input shaper of X as `amctl shaper show --type` accepts it (Klipper shaper_type_x; "
         "shaper_type sets both). Used by `amctl simulate`.",
         nullptr, nullptr, nullptr, nullptr,
         [](Machine& m) -> std::string& { return m.input_shaper.shaper_type_x; }});
    add({"input_shaper", "shaper_type_y", Kind::text, Bound::finite, "",
         "Input shaper of Y (Klipper shaper_type_y).", nullptr, nullptr, nullptr, nullptr,
         [](Machine& m) -> std::string& { return m.input_shaper.shaper_type_y; }});
    add({"input_shaper", "shaper_freq_x", Kind::number, Bound::non_negative, "Hz",
         "Input shaper frequency of X; 0 = X not shaped (Klipper shaper_freq_x).",
         AMCTL_NUM(input_shaper.shaper_freq_x_hz)});
    add({"input_shaper", "shaper_freq_y", Kind::number, Bound::non_negative, "Hz",
         "Input shaper frequency of Y; 0 = Y not shaped (Klipper shaper_freq_y).",
         AMCTL_NUM(input_shaper.shaper_freq_y_hz)});
    add({"input_shaper", "damping_ratio_x", Kind::number, Bound::ratio, "",
         "Damping ratio the X shaper is designed for (Klipper damping_ratio_x).",
         AMCTL_NUM(input_shaper.damping_ratio_x)});
    add({"input_shaper", "damping_ratio_y", Kind::number, Bound::ratio, "",
         "Damping ratio the Y shaper is designed for (Klipper damping_ratio_y).",
         AMCTL_NUM(input_shaper.damping_ratio_y)});
    add({"input_shaper", "shaper_type_z", Kind::text, Bound::finite, "",
         "Input shaper of Z (Klipper shaper_type_z).", nullptr, nullptr, nullptr, nullptr,
         [](Machine& m) -> std::string& { return m.input_shaper.shaper_type_z; }});
    add({"input_shaper", "shaper_freq_z", Kind::number, Bound::non_negative, "Hz",
         "Input shaper frequency of Z; 0 = Z not shaped (Klipper shaper_freq_z).",
         AMCTL_NUM(input_shaper.shaper_freq_z_hz)});
    add({"input_shaper", "damping_ratio_z", Kind::number, Bound::ratio, "",
         "Damping ratio the Z shaper is designed for (Klipper damping_ratio_z).",
         AMCTL_NUM(input_shaper.damping_ratio_z)});
    return k;
  }();
  return keys;
}

const std::vector<StepperKeyDef>& stepper_table() {
  static const std::vector<StepperKeyDef> keys = {
      {"rotation_distance", Kind::number, Bound::positive, "mm",
       "Travel per full turn of the motor (Klipper rotation_distance; with gear_ratio, per turn "
       "of the final gear, folded into the per-motor value on reading).",
       [](Stepper& s) -> double& { return s.rotation_distance_mm; }},
      {"gear_ratio", Kind::gear_ratio, Bound::positive, "",
       "Klipper gear_ratio \"a:b, c:d\" (read-only: divides rotation_distance by a/b * c/d)."},
      {"microsteps", Kind::integer, Bound::at_least_one, "", "Driver microsteps per full step.",
       nullptr, [](Stepper& s) -> int& { return s.microsteps; }},
      {"full_steps_per_rotation", Kind::integer, Bound::at_least_one, "",
       "Full steps per motor turn (200 for 1.8 degree, 400 for 0.9 degree motors).", nullptr,
       [](Stepper& s) -> int& { return s.full_steps_per_rotation; }},
      {"run_current", Kind::optional_number, Bound::positive, "A",
       "Motor current, RMS (Klipper [tmc2209 stepper_x] run_current; the phase current "
       "amplitude is sqrt(2) times it). Step-level physics only (amctl stepper simulate).",
       nullptr, nullptr, [](Stepper& s) -> std::optional<double>& { return s.run_current_a; }},
      {"supply_voltage", Kind::optional_number, Bound::positive, "V",
       "Driver supply voltage (the pull-out torque falls with speed as the back-EMF uses it "
       "up). Step-level physics only.",
       nullptr, nullptr, [](Stepper& s) -> std::optional<double>& { return s.supply_voltage_v; }},
      {"holding_torque", Kind::optional_number, Bound::positive, "N m",
       "Motor datasheet: holding torque, two phases at the rated current. Step-level physics "
       "only.",
       nullptr, nullptr, [](Stepper& s) -> std::optional<double>& { return s.holding_torque_n_m; }},
      {"rated_current", Kind::optional_number, Bound::positive, "A",
       "Motor datasheet: rated current per phase (also the most a closed-loop drive boosts to). "
       "Step-level physics only.",
       nullptr, nullptr, [](Stepper& s) -> std::optional<double>& { return s.rated_current_a; }},
      {"phase_resistance", Kind::optional_number, Bound::positive, "ohm",
       "Motor datasheet: phase resistance. Step-level physics only.", nullptr, nullptr,
       [](Stepper& s) -> std::optional<double>& { return s.phase_resistance_ohm; }},
      {"phase_inductance", Kind::optional_number, Bound::positive, "H",
       "Motor datasheet: phase inductance. Step-level physics only.", nullptr, nullptr,
       [](Stepper& s) -> std::optional<double>& { return s.phase_inductance_h; }},
      {"rotor_inertia", Kind::optional_number, Bound::positive, "kg m^2",
       "Motor datasheet: rotor inertia (54 g cm^2 = 5.4e-6 kg m^2). Step-level physics only.",
       nullptr, nullptr, [](Stepper& s) -> std::optional<double>& { return s.rotor_inertia_kg_m2; }},
      {"detent_torque", Kind::optional_number, Bound::non_negative, "N m",
       "Motor datasheet: detent torque. Step-level physics only.", nullptr, nullptr,
       [](Stepper& s) -> std::optional<double>& { return s.detent_torque_n_m; }},
      {"backlash", Kind::optional_number, Bound::non_negative, "mm",
       "Lost motion between motor and carriage at a reversal of the belt force (pulley teeth, "
       "a loose set screw; Marlin's BACKLASH_DISTANCE_MM). Step-level physics only.",
       nullptr, nullptr, [](Stepper& s) -> std::optional<double>& { return s.backlash_mm; }},
      {"motor", Kind::text, Bound::finite, "",
       "The motor by preset name: 17hs4401, ldo-42sth48-2504ac, ldo-42sth48-2004mah (0.9 deg), "
       "ldo-42sth40-1004a (docs/machine.md, motor presets); the numeric motor keys override its "
       "values. Step-level physics only.",
       nullptr, nullptr, nullptr, [](Stepper& s) -> std::string& { return s.motor; }},
  };
  return keys;
}

#undef AMCTL_NUM
#undef AMCTL_OPT
#undef AMCTL_INT
#undef AMCTL_AXES

char lower(char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); }

}  // namespace

std::span<const KeyDef> machine_keys() { return key_table(); }
std::span<const StepperKeyDef> stepper_keys() { return stepper_table(); }
std::span<const std::string_view> machine_sections() {
  // The machine's tables, then those of the kinematics' keys ([delta], [dual_carriage]).
  static const std::vector<std::string_view> sections = [] {
    std::vector<std::string_view> out(std::begin(kSections), std::end(kSections));
    for (const BoundKey& b : all_kinematics_keys()) {
      if (b.section == "stepper" || b.section == "carriage") continue;
      if (std::find(out.begin(), out.end(), b.section) == out.end()) out.push_back(b.section);
    }
    return out;
  }();
  return sections;
}

const KeyDef* find_key(std::string_view section, std::string_view key) {
  for (const KeyDef& d : key_table()) {
    if (d.section == section && d.key == key) return &d;
  }
  return nullptr;
}

const StepperKeyDef* find_stepper_key(std::string_view key) {
  for (const StepperKeyDef& d : stepper_table()) {
    if (d.key == key) return &d;
  }
  return nullptr;
}

bool valid_stepper_name(std::string_view name) {
  if (name.empty()) return false;
  if (name[0] != 'x' && name[0] != 'y' && name[0] != 'z' && name[0] != 'e') return false;
  return std::all_of(name.begin() + 1, name.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

void check_shaper_type(std::string_view text, const SourceLocation& where, std::string_view label) {
  // The names of shaping::shaper_type_names() (the shaping module sits above this one).
  static constexpr std::string_view kShapers[] = {"zv",       "mzv",      "zvd",  "ei",
                                                  "2hump_ei", "3hump_ei", "zvdd", "zvddd"};
  std::string name(text);
  if (const std::size_t paren = name.find('('); paren != std::string::npos && name.back() == ')') {
    name.resize(paren);
  }
  while (!name.empty() && name.back() == ' ') name.pop_back();
  for (char& c : name) c = lower(c);
  if (std::find(std::begin(kShapers), std::end(kShapers), name) != std::end(kShapers)) return;
  throw Error(where, fmt::format("{}: found '{}', expected one of {}, optionally with parameters "
                                 "as mzv(n=4, t=0.9) or ei(v_tol=0.02)",
                                 label, text, fmt::join(kShapers, ", ")));
}

std::span<const std::string_view> enum_names(Kind kind) {
  switch (kind) {
    case Kind::firmware: return kFirmwareNames;
    case Kind::kinematics: return kinematics::names();
    case Kind::junction: return kJunctionNames;
    case Kind::profile: return kProfileNames;
    default: break;
  }
  AMCTL_CHECK(false, "enum_names called for a non-enum kind");
  return {};
}

int get_enum(const Machine& m, Kind kind) {
  switch (kind) {
    case Kind::firmware: return static_cast<int>(m.firmware);
    case Kind::kinematics: return static_cast<int>(m.kinematics.index());
    case Kind::junction: return static_cast<int>(m.junction);
    case Kind::profile: return static_cast<int>(m.profile);
    default: break;
  }
  AMCTL_CHECK(false, "get_enum called for a non-enum kind");
  return 0;
}

void set_enum(Machine& m, Kind kind, int index) {
  AMCTL_CHECK(index >= 0 && static_cast<std::size_t>(index) < enum_names(kind).size(),
              "enum index out of range");
  switch (kind) {
    case Kind::firmware: m.firmware = static_cast<Firmware>(index); return;
    case Kind::kinematics:
      m.kinematics = kinematics::convert(m.kinematics, static_cast<std::size_t>(index));
      return;
    case Kind::junction: m.junction = static_cast<JunctionPolicy>(index); return;
    case Kind::profile: m.profile = static_cast<VelocityProfile>(index); return;
    default: break;
  }
  AMCTL_CHECK(false, "set_enum called for a non-enum kind");
}

std::string_view bound_text(Bound b) {
  switch (b) {
    case Bound::finite: return "finite";
    case Bound::non_negative: return ">= 0";
    case Bound::positive: return "> 0";
    case Bound::ratio: return "in [0, 1)";
    case Bound::at_least_one: return ">= 1";
  }
  return "";
}

bool within(Bound b, double v) {
  if (!std::isfinite(v)) return false;
  switch (b) {
    case Bound::finite: return true;
    case Bound::non_negative: return v >= 0.0;
    case Bound::positive: return v > 0.0;
    case Bound::ratio: return v >= 0.0 && v < 1.0;
    case Bound::at_least_one: return v >= 1.0;
  }
  return false;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t subst = prev[j - 1] + (lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, subst});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::optional<std::string> closest(std::string_view word,
                                   const std::vector<std::string>& candidates) {
  // A typo is at most a third of the word's letters (two for short words).
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
  std::optional<std::string> best;
  std::size_t best_d = limit + 1;
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates) {
  if (auto c = closest(word, candidates)) return fmt::format("; did you mean '{}'?", *c);
  return {};
}

std::string format_number(double v) {
  // fmt's default is the shortest text that reads back to the same double.
  std::string s = fmt::format("{}", v);
  return s;
}

double parse_gear_ratio(std::string_view text, const SourceLocation& where,
                        std::string_view label) {
  double result = 1.0;
  std::size_t pairs = 0;
  auto trim = [](std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
  };
  auto number = [&](std::string_view s) {
    s = trim(s);
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v) ||
        v <= 0.0) {
      throw Error(where, fmt::format("{}: expected gear ratios like \"80:16\" or \"57:11, 2:1\" "
                                     "with numbers > 0, got \"{}\"",
                                     label, text));
    }
    return v;
  };
  std::string_view rest = text;
  while (true) {
    const std::size_t comma = rest.find(',');
    std::string_view part = trim(rest.substr(0, comma));
    if (!part.empty()) {
      const std::size_t colon = part.find(':');
      if (colon == std::string_view::npos) number("");  // throws
      result *= number(part.substr(0, colon)) / number(part.substr(colon + 1));
      ++pairs;
    }
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }
  if (pairs == 0) number("");  // throws
  return result;
}

void check_motor_preset(std::string_view name, const SourceLocation& where, std::string_view label) {
  if (machine::find_motor_preset(name) != nullptr) return;
  throw Error(where, fmt::format("{}: unknown motor '{}', expected one of {} (or leave it out and "
                                 "give the motor's datasheet keys)",
                                 label, name, machine::motor_preset_names()));
}

}  // namespace amctl::machine::detail
