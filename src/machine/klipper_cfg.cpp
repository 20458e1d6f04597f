// Klipper printer.cfg reader. Reads the file the way klippy/configfile.py does (Python
// configparser with strict=False, `#` stripped anywhere on a line, `;` comments, indented
// continuation lines, [include] at its position, the SAVE_CONFIG block whose options apply only
// where the regular config does not set them) and maps the sections the planner needs onto a
// Machine with Klipper's defaults and checks (klippy/toolhead.py, kinematics/cartesian.py,
// kinematics/corexy.py, kinematics/extruder.py, stepper.py, extras/gcode_arcs.py,
// extras/firmware_retraction.py).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/config_section.hpp"
#include "amctl/machine/effective.hpp"
#include "amctl/core/input.hpp"
#include "amctl/core/text_input.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/kinematics/klipper_config.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/machine/motor_presets.hpp"
#include "schema.hpp"

namespace amctl::machine {
namespace {

namespace fs = std::filesystem;

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string lowercase(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

using CfgValue = ConfigValue;
using CfgSection = ConfigSection;

struct CfgDoc {
  std::vector<CfgSection> sections;  // in order of first appearance

  CfgSection* find(std::string_view name) {
    for (CfgSection& s : sections) {
      if (s.name == name) return &s;
    }
    return nullptr;
  }
  CfgSection& get_or_add(const std::string& name, const SourceLocation& where) {
    if (CfgSection* s = find(name)) return *s;
    sections.push_back({name, where, {}});
    return sections.back();
  }
};

std::string read_file(const fs::path& path, const SourceLocation& where) {
  InputOptions o;
  o.what = "config file";
  o.max_bytes = kMaxMachineFileBytes;
  try {
    return read_whole_text(path.string(), std::move(o));
  } catch (const Error& e) {
    throw Error(where, fmt::format("include: {}", e.what()));
  }
}

bool has_glob_magic(std::string_view s) { return s.find_first_of("*?[") != std::string_view::npos; }

/// fnmatch-style match of `name` against `pattern` with * and ? (no character classes).
bool glob_match(std::string_view pattern, std::string_view name) {
  std::size_t p = 0, n = 0, star = std::string_view::npos, mark = 0;
  while (n < name.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == name[n])) {
      ++p;
      ++n;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      mark = n;
    } else if (star != std::string_view::npos) {
      p = star + 1;
      n = ++mark;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

class CfgReader {
 public:
  explicit CfgReader(CfgDoc& doc) : doc_(doc) {}

  /// Parses one file's text. `file` names it in messages and anchors its includes.
  /// `included_at` is the [include] line that pulled the file in (null for the main file).
  void parse(std::string_view text, const std::string& file,
             const SourceLocation* included_at = nullptr) {
    std::error_code ec;
    fs::path key = fs::absolute(fs::path(file), ec).lexically_normal();
    if (!visiting_.insert(key.string()).second) {
      throw Error(included_at ? *included_at : SourceLocation{file, 0, 0},
                  fmt::format("recursive include of config file '{}', expected each file to "
                              "be included at most once on any chain of includes",
                              file));
    }
    CfgSection* section = nullptr;
    std::string option;       // option being continued
    std::size_t indent = 0;   // indentation of the option line
    std::uint64_t line_no = 0;
    std::size_t pos = 0;
    while (pos <= text.size()) {
      const std::size_t nl = text.find('\n', pos);
      std::string_view line = text.substr(pos, nl == std::string_view::npos ? text.npos : nl - pos);
      pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
      ++line_no;
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      // Klipper strips everything after '#' before configparser sees the line.
      if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) {
        line = line.substr(0, hash);
      }
      // [include ...] is recognised only at the start of a line (configfile.py _parse_config).
      if (!line.empty() && line[0] == '[') {
        const std::size_t close = line.rfind(']');
        if (close != std::string_view::npos && close > 1) {
          const std::string_view header = line.substr(1, close - 1);
          if (header.rfind("include ", 0) == 0) {
            include(file, trim(header.substr(8)), SourceLocation{file, line_no, 1});
            section = nullptr;  // the text after an include starts a new configparser chunk
            option.clear();
            continue;
          }
        }
      }
      // configparser inline comment: ';' preceded by whitespace.
      for (std::size_t i = 1; i < line.size(); ++i) {
        if (line[i] == ';' && std::isspace(static_cast<unsigned char>(line[i - 1]))) {
          line = line.substr(0, i);
          break;
        }
      }
      const std::string_view stripped = trim(line);
      if (stripped.empty() || stripped[0] == ';') continue;  // blank or comment line
      const std::size_t cur_indent = line.find_first_not_of(" \t\f\v");
      if (section != nullptr && !option.empty() && cur_indent > indent) {
        CfgValue& v = section->options[option];
        v.text += '\n';
        v.text += stripped;
        v.lines.push_back(line_no);
        continue;
      }
      indent = cur_indent;
      const SourceLocation where{file, line_no, static_cast<std::uint32_t>(cur_indent + 1)};
      if (stripped[0] == '[') {
        const std::size_t close = stripped.rfind(']');
        if (close != std::string_view::npos && close > 1) {
          section = &doc_.get_or_add(std::string(stripped.substr(1, close - 1)), where);
          option.clear();
          continue;
        }
      }
      if (section == nullptr) {
        throw Error(where, fmt::format("expected a [section] header before '{}'", stripped));
      }
      const std::size_t delim = stripped.find_first_of(":=");
      if (delim == std::string_view::npos || trim(stripped.substr(0, delim)).empty()) {
        throw Error(where, fmt::format("expected 'option: value' in [{}], got '{}'",
                                       section->name, stripped));
      }
      option = lowercase(trim(stripped.substr(0, delim)));
      const std::string_view rest = stripped.substr(delim + 1);
      const std::string_view value = trim(rest);
      const std::size_t lead = rest.find_first_not_of(" \t");
      const std::size_t value_col =
          cur_indent + delim + 1 + (lead == std::string_view::npos ? rest.size() : lead) + 1;
      section->options[option] =
          CfgValue{std::string(value),
                   SourceLocation{file, line_no, static_cast<std::uint32_t>(value_col)},
                   {line_no}};
    }
    visiting_.erase(key.string());
  }

 private:
  void include(const std::string& from_file, std::string_view spec, const SourceLocation& where) {
    const fs::path base = fs::path(from_file).parent_path();
    const fs::path pattern = base / fs::path(std::string(spec));
    std::vector<fs::path> files;
    if (has_glob_magic(spec)) {
      if (has_glob_magic(pattern.parent_path().string())) {
        throw Error(where, fmt::format("include '{}': wildcards are supported in the file name "
                                       "only",
                                       spec));
      }
      std::error_code ec;
      const fs::path dir = pattern.parent_path().empty() ? fs::path(".") : pattern.parent_path();
      for (const auto& entry : fs::directory_iterator(dir, ec)) {
        std::error_code entry_ec;
        if (entry.is_regular_file(entry_ec) &&
            glob_match(pattern.filename().string(), entry.path().filename().string())) {
          files.push_back(pattern.parent_path() / entry.path().filename());
        }
      }
      std::sort(files.begin(), files.end());  // Klipper sorts glob results
    } else {
      std::error_code ec;
      if (!fs::is_regular_file(pattern, ec)) {
        throw Error(where, fmt::format("include file '{}' does not exist, expected a file (relative to the "
                                       "including file's directory)",
                                       pattern.string()));
      }
      files.push_back(pattern);
    }
    for (const fs::path& f : files) {
      std::string text = read_file(f, where);
      parse(text, f.string(), &where);
    }
  }

  CfgDoc& doc_;
  std::set<std::string> visiting_;
};

// Typed option access with Klipper's checks: the kinematics module's (they read their own
// sections with it).
using Limits = kinematics::Limits;
using Section = kinematics::KlipperSection;

/// A shaper type as Klipper's shaper_defs.get_shaper_cfg reads it: a name of INPUT_SHAPERS,
/// compared as written (84104bbb no longer lower-cases it), optionally with parameters in
/// parentheses, `ei(v_tol=0.02)`, `mzv(5, 0.6)` (Klipper's `(\w+)\s*\((.*)\)$`); the text is
/// kept as written for amctl's shaper parser. Anything else is "Unsupported shaper type".
std::string shaper_type(const Section& sh, std::string_view key, const std::string& def) {
  const CfgValue* v = sh.raw(key);
  if (v == nullptr) return def;
  const std::string text(trim(v->text));
  std::string_view name = text;
  if (const std::size_t paren = text.find('('); paren != std::string::npos && text.back() == ')') {
    name = trim(std::string_view(text).substr(0, paren));
  }
  static constexpr std::string_view kShapers[] = {"zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei"};
  for (std::string_view c : kShapers) {
    if (c == name) return text;
  }
  std::string hint;
  std::string low(name);
  for (char& c : low) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (std::string_view c : kShapers) {
    if (c == low) hint = fmt::format(" (Klipper compares the name as written: '{}')", c);
  }
  throw Error(v->where, fmt::format("[input_shaper] {}: found '{}', expected one of {}, "
                                    "optionally with parameters as ei(v_tol=0.02){}",
                                    key, text, fmt::join(kShapers, ", "), hint));
}

/// stepper.py parse_step_distance: rotation_distance (per final gear turn), microsteps,
/// full_steps_per_rotation (multiple of 4), gear_ratio. A stepper in radians (the polar bed,
/// the rotary delta's arms: units_in_radians) turns 2 pi per turn of its final gear, and its
/// gear_ratio is required.
Stepper read_stepper(const Section& s, bool radians = false) {
  Stepper st;
  if (radians && s.has("rotation_distance")) {
    throw Error(s.raw("rotation_distance")->where,
                fmt::format("[{}] rotation_distance: not an option of a stepper that turns (its "
                            "unit is the radian), expected gear_ratio instead",
                            s.name()));
  }
  if (radians && !s.has("gear_ratio")) (void)s.require_text("gear_ratio");  // throws: missing
  const double rotation =
      radians ? 2.0 * std::numbers::pi : s.require_float("rotation_distance", {.above = 0.0});
  st.microsteps = s.require_int("microsteps", {.minval = 1});
  st.full_steps_per_rotation = s.get_int("full_steps_per_rotation", {.minval = 1}).value_or(200);
  if (st.full_steps_per_rotation % 4 != 0) {
    throw Error(s.raw("full_steps_per_rotation")->where,
                fmt::format("[{}] full_steps_per_rotation: must be a multiple of 4, got {}",
                            s.name(), st.full_steps_per_rotation));
  }
  double gearing = 1.0;
  if (const CfgValue* g = s.raw("gear_ratio")) {
    gearing = detail::parse_gear_ratio(g->text, g->where, fmt::format("[{}] gear_ratio", s.name()));
  }
  st.rotation_distance_mm = rotation / gearing;
  // amctl's motor preset key (step-level physics; Klipper itself has no such option).
  if (const CfgValue* v = s.raw("motor")) {
    st.motor = std::string(trim(v->text));
    detail::check_motor_preset(st.motor, v->where, fmt::format("[{}] motor", s.name()));
  }
  return st;
}

// [printer] options of the cartesian/corexy toolhead. The last four are undocumented buffer
// settings older Klipper accepted (removed in bafb126a); they do not change the motion, so old
// configs that still carry them are read rather than rejected.
constexpr std::string_view kPrinterOptions[] = {
    "kinematics",      "max_velocity",      "max_accel",         "minimum_cruise_ratio",
    "max_accel_to_decel", "square_corner_velocity", "max_z_velocity", "max_z_accel",
    "buffer_time_low", "buffer_time_high",  "buffer_time_start", "move_flush_time"};

kinematics::Params read_kinematics(const Section& printer) {
  const std::string kin = printer.require_text("kinematics");
  const SourceLocation where = printer.raw("kinematics")->where;
  if (auto p = kinematics::params_named(kin)) return *p;
  const auto supported = kinematics::names();
  std::vector<std::string> all(supported.begin(), supported.end());
  throw Error(where, fmt::format("[printer] kinematics: found '{}', expected a Klipper kinematics{}", kin,
                                 detail::did_you_mean(kin, all)));
}

Machine to_machine(CfgDoc& doc, const std::string& source_name) {
  const SourceLocation file_loc{source_name, 0, 0};
  Machine m;
  m.name = fs::path(source_name).stem().string();
  if (m.name.empty()) m.name = "printer.cfg";
  m.firmware = Firmware::klipper;
  m.junction = JunctionPolicy::square_corner_velocity;
  m.profile = VelocityProfile::trapezoid;

  CfgSection* printer_section = doc.find("printer");
  if (printer_section == nullptr) {
    throw Error(file_loc, "found no [printer] section, expected a Klipper printer.cfg (which has one)");
  }
  const Section printer(printer_section, "printer", file_loc);
  m.kinematics = read_kinematics(printer);
  const kinematics::KlipperConfig cfg(doc.sections, file_loc);
  {
    // Klipper rejects any other [printer] option. amctl rejects the ones that look like a typo
    // of a known option (a misspelt square_corner_velocity would otherwise silently become
    // the default) and ignores the rest, so configs of Klipper forks with extra options load.
    std::vector<std::string> known(std::begin(kPrinterOptions), std::end(kPrinterOptions));
    std::visit(
        [&](const auto& k) {
          for (std::string_view o : std::decay_t<decltype(k)>::printer_options()) known.emplace_back(o);
        },
        m.kinematics);
    for (const auto& [key, value] : printer_section->options) {
      if (std::find(known.begin(), known.end(), key) != known.end()) continue;
      if (auto near = detail::closest(key, known)) {
        throw Error(value.where, fmt::format("option '{}' is not valid in section [printer]; did "
                                             "you mean '{}'?",
                                             key, *near));
      }
    }
  }
  m.max_velocity_mm_s = printer.require_float("max_velocity", {.above = 0.0, .physical = kSpeedRange});
  m.max_accel_mm_s2 = printer.require_float("max_accel", {.above = 0.0, .physical = kAccelRange});
  if (auto mcr = printer.get_float("minimum_cruise_ratio", {.minval = 0.0, .below = 1.0})) {
    m.minimum_cruise_ratio = *mcr;
  } else if (auto a2d = printer.get_float("max_accel_to_decel", {.above = 0.0, .physical = kAccelRange})) {
    // Older Klipper (before 2023-12): minimum_cruise_ratio = 1 - min(1, a2d / max_accel).
    m.minimum_cruise_ratio =
        minimum_cruise_ratio_from_accel_to_decel(*a2d, m.max_accel_mm_s2);
  } else {
    m.minimum_cruise_ratio = 0.5;
  }
  m.square_corner_velocity_mm_s =
      printer.get_float("square_corner_velocity", 5.0, {.minval = 0.0, .physical = kSpeedRange});
  // 0 = "same as max_velocity / max_accel", Klipper's default; an explicit value is kept so a
  // later --set printer.max_velocity does not move it.
  m.max_z_velocity_mm_s =
      printer.get_float("max_z_velocity", {.maxval = m.max_velocity_mm_s, .above = 0.0, .physical = kSpeedRange})
          .value_or(0.0);
  m.max_z_accel_mm_s2 =
      printer.get_float("max_z_accel", {.maxval = m.max_accel_mm_s2, .above = 0.0, .physical = kAccelRange})
          .value_or(0.0);

  // The extruder (extruder.py); a stepper is attached when step_pin, dir_pin or
  // rotation_distance is given.
  m.extruder = kinematics::Extruder::from_klipper(cfg);
  if (CfgSection* es = doc.find("extruder")) {
    const Section ex(es, "extruder", file_loc);
    if (ex.has("step_pin") || ex.has("dir_pin") || ex.has("rotation_distance")) {
      m.steppers["e"] = read_stepper(ex);
    }
  }
  // gcode_arcs.py registers G2/G3 (and G17-G19); without the section they are unknown.
  m.arcs.enabled = doc.find("gcode_arcs") != nullptr;
  if (CfgSection* as = doc.find("gcode_arcs")) {
    const Section arcs(as, "gcode_arcs", file_loc);
    m.arcs.mm_per_arc_segment = arcs.get_float("resolution", 1.0, {.above = 0.0});
  }
  if (CfgSection* rs = doc.find("firmware_retraction")) {
    const Section r(rs, "firmware_retraction", file_loc);
    FirmwareRetraction& fr = m.firmware_retraction;
    fr.retract_length_mm = r.get_float("retract_length", 0.0, {.minval = 0.0});
    fr.retract_speed_mm_s = r.get_float("retract_speed", 20.0, {.minval = 1.0});
    fr.unretract_extra_length_mm = r.get_float("unretract_extra_length", 0.0, {.minval = 0.0});
    fr.unretract_speed_mm_s = r.get_float("unretract_speed", 10.0, {.minval = 1.0});
  }
  if (CfgSection* is = doc.find("input_shaper")) {
    // input_shaper.py (84104bbb): shaper_type (mzv) is the default of shaper_type_x/_y/_z, taken
    // as written; damping_ratio_x/_y/_z 0.1 in [0, 1]; shaper_freq_x/_y/_z 0 (off), >= 0. amctl
    // also needs damping < 1 (a shaper is not defined at 1).
    const Section sh(is, "input_shaper", file_loc);
    InputShaper& in = m.input_shaper;
    const std::string both = shaper_type(sh, "shaper_type", "mzv");
    in.shaper_type_x = shaper_type(sh, "shaper_type_x", both);
    in.shaper_type_y = shaper_type(sh, "shaper_type_y", both);
    in.shaper_type_z = shaper_type(sh, "shaper_type_z", both);
    in.shaper_freq_x_hz = sh.get_float("shaper_freq_x", 0.0, {.minval = 0.0, .physical = kFrequencyRange});
    in.shaper_freq_y_hz = sh.get_float("shaper_freq_y", 0.0, {.minval = 0.0, .physical = kFrequencyRange});
    in.damping_ratio_x = sh.get_float("damping_ratio_x", 0.1, {.minval = 0.0, .below = 1.0});
    in.damping_ratio_y = sh.get_float("damping_ratio_y", 0.1, {.minval = 0.0, .below = 1.0});
    in.shaper_freq_z_hz = sh.get_float("shaper_freq_z", 0.0, {.minval = 0.0, .physical = kFrequencyRange});
    in.damping_ratio_z = sh.get_float("damping_ratio_z", 0.1, {.minval = 0.0, .below = 1.0});
  }
  // The kinematics' own options of [printer] and of its sections, then each of its motors'
  // drive train (stepper.py), in file order.
  std::visit(
      [&](auto& k) {
        using K = std::decay_t<decltype(k)>;
        k = K::from_klipper(cfg);
        for (const kinematics::KlipperStepper& st : K::klipper_steppers(cfg)) {
          const Section sec = cfg.section(st.section);
          Stepper drive = read_stepper(sec, st.radians);
          if (st.radians) {
            drive.rotation_distance_rad = drive.rotation_distance_mm;
            drive.rotation_distance_mm = Stepper{}.rotation_distance_mm;
          }
          m.steppers[st.key] = drive;
        }
      },
      m.kinematics);
  // Trinamic driver sections ([tmc2209 stepper_x], ... klippy/extras/tmc*.py): run_current
  // (RMS) of the stepper they drive, for step-level physics. Other options (hold_current,
  // sense_resistor, stealthchop_threshold, ...) change no motion amctl models.
  static constexpr std::string_view kTmc[] = {"tmc2130", "tmc2208", "tmc2209", "tmc2240",
                                              "tmc2660", "tmc5160"};
  for (CfgSection& s : doc.sections) {
    const std::size_t sp = s.name.find(' ');
    if (sp == std::string::npos) continue;
    const std::string_view driver = std::string_view(s.name).substr(0, sp);
    if (std::find(std::begin(kTmc), std::end(kTmc), driver) == std::end(kTmc)) continue;
    const std::string target(trim(std::string_view(s.name).substr(sp + 1)));
    std::string name;
    if (target.rfind("stepper_", 0) == 0) name = target.substr(8);
    else if (target == "extruder") name = "e";
    const auto it = m.steppers.find(name);
    if (it == m.steppers.end()) continue;
    it->second.run_current_a = Section(&s, s.name, file_loc).get_float("run_current", {.above = 0.0});
  }
  // klipper_tmc_autotune's [autotune_tmc stepper_x]: `motor` names the motor (an amctl preset,
  // or a [motor_constants NAME] section: resistance, inductance, holding_torque, max_current,
  // steps_per_revolution) and `voltage` the driver's supply. Step-level physics only.
  for (CfgSection& s : doc.sections) {
    if (s.name.rfind("autotune_tmc ", 0) != 0) continue;
    const std::string target(trim(std::string_view(s.name).substr(13)));
    const auto it = m.steppers.find(target.rfind("stepper_", 0) == 0 ? target.substr(8) : "");
    if (it == m.steppers.end()) continue;
    const Section at(&s, s.name, file_loc);
    Stepper& st = it->second;
    if (auto v = at.get_float("voltage", {.above = 0.0})) st.supply_voltage_v = v;
    const CfgValue* mv = at.raw("motor");
    if (mv == nullptr) continue;
    const std::string name(trim(mv->text));
    if (find_motor_preset(name) != nullptr) {
      st.motor = name;
      continue;
    }
    CfgSection* mc = doc.find("motor_constants " + name);
    if (mc == nullptr) {
      detail::check_motor_preset(name, mv->where, fmt::format("[{}] motor", s.name));  // throws
    }
    const Section c(mc, mc->name, file_loc);
    st.phase_resistance_ohm = c.require_float("resistance", {.above = 0.0});
    st.phase_inductance_h = c.require_float("inductance", {.above = 0.0});
    st.holding_torque_n_m = c.require_float("holding_torque", {.above = 0.0});
    st.rated_current_a = c.require_float("max_current", {.above = 0.0});
    if (auto steps = c.get_int("steps_per_revolution", {.minval = 1});
        steps && *steps != st.full_steps_per_rotation) {
      throw Error(c.raw("steps_per_revolution")->where,
                  fmt::format("[{}] steps_per_revolution: {} full steps, but [stepper_{}] "
                              "full_steps_per_rotation is {}",
                              mc->name, *steps, it->first, st.full_steps_per_rotation));
    }
  }
  // exclude_object.py is loaded by its section only; without it EXCLUDE_OBJECT* are unknown.
  m.exclude_object = doc.find("exclude_object") != nullptr;
  // Every section as written: Klipper's printer.configfile and the [gcode_macro] sections,
  // expanded by the macro module (docs/macros.md).
  m.klipper_config = doc.sections;
  return m;
}

constexpr std::string_view kAutosaveMarker =
    "#*# <---------------------- SAVE_CONFIG ---------------------->";

}  // namespace

Machine parse_klipper_cfg(std::string_view text, const std::string& source_name) {
  // Split off the SAVE_CONFIG block (configfile.py _find_autosave_data).
  std::string_view regular = text;
  std::string autosave;
  std::uint64_t autosave_first_line = 0;
  if (const std::size_t at = text.find(kAutosaveMarker);
      at != std::string_view::npos && (at == 0 || text[at - 1] == '\n')) {
    regular = text.substr(0, at);
    autosave_first_line =
        static_cast<std::uint64_t>(std::count(regular.begin(), regular.end(), '\n')) + 1;
    std::string_view rest = text.substr(at);
    std::size_t pos = 0;
    while (pos < rest.size()) {
      const std::size_t nl = rest.find('\n', pos);
      std::string_view line = rest.substr(pos, nl == std::string_view::npos ? rest.npos : nl - pos);
      pos = nl == std::string_view::npos ? rest.size() : nl + 1;
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      // "#*# " prefix removed; keep line numbering by emitting one line per input line. The
      // header's own lines (marker, "DO NOT EDIT ...") are not config.
      if (line.rfind(kAutosaveMarker, 0) == 0 || line.rfind("#*# DO NOT EDIT", 0) == 0) {
        // header
      } else if (line.rfind("#*# ", 0) == 0) {
        autosave += line.substr(4);
      } else if (line.rfind("#*#", 0) != 0 && !trim(line).empty()) {
        // Klipper ignores a corrupted block ("modifications after header") entirely.
        autosave.clear();
        break;
      }
      autosave += '\n';
    }
  }
  CfgDoc doc;
  CfgReader(doc).parse(regular, source_name);
  if (!autosave.empty()) {
    CfgDoc saved;
    // Blank lines in front keep the line numbers of the SAVE_CONFIG block right.
    std::string padded(autosave_first_line - 1, '\n');
    padded += autosave;
    CfgReader(saved).parse(padded, source_name);
    for (CfgSection& s : saved.sections) {
      // The block was read without each line's "#*# ": columns count it again.
      if (s.where.column > 0) s.where.column += 4;
      for (auto& [key, value] : s.options) {
        if (value.where.column > 0) value.where.column += 4;
      }
      CfgSection& target = doc.get_or_add(s.name, s.where);
      for (auto& [key, value] : s.options) target.options.emplace(key, value);  // regular wins
    }
  }
  Machine m = to_machine(doc, source_name);
  try {
    validate(m);
  } catch (const Error& e) {
    throw Error(SourceLocation{source_name, 0, 0}, e.detail());
  }
  return m;
}

}  // namespace amctl::machine
