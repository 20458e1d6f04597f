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
#include "amctl/core/quantity.hpp"
#include "amctl/machine/loader.hpp"
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
    return read_whole_input(path.string(), std::move(o));
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

// ---- typed option access with Klipper's checks (configfile.py ConfigWrapper) ----

struct Limits {
  std::optional<double> minval = std::nullopt;
  std::optional<double> maxval = std::nullopt;
  std::optional<double> above = std::nullopt;
  std::optional<double> below = std::nullopt;
  /// amctl's physical range of the quantity (core/quantity.hpp), for a value other than 0.
  std::optional<PhysicalRange> physical = std::nullopt;
};

class Section {
 public:
  Section(CfgSection* s, std::string name, SourceLocation fallback)
      : s_(s), name_(std::move(name)), fallback_(std::move(fallback)) {}

  bool present() const { return s_ != nullptr; }
  bool has(std::string_view key) const {
    return s_ != nullptr && s_->options.count(std::string(key)) != 0;
  }
  const CfgValue* raw(std::string_view key) const {
    if (s_ == nullptr) return nullptr;
    auto it = s_->options.find(std::string(key));
    return it == s_->options.end() ? nullptr : &it->second;
  }

  std::optional<double> get_float(std::string_view key, const Limits& lim = {}) const {
    const CfgValue* v = raw(key);
    if (v == nullptr) return std::nullopt;
    const std::string_view text = trim(v->text);
    double x = 0.0;
    const char* first = text.data();
    if (!text.empty() && text.front() == '+') ++first;
    const auto [ptr, ec] = std::from_chars(first, text.data() + text.size(), x);
    if (text.empty() || ec != std::errc() || ptr != text.data() + text.size()) {
      throw Error(v->where, fmt::format("[{}] {}: expected a number, got '{}'", name_, key, text));
    }
    if (!std::isfinite(x)) {
      throw Error(v->where, fmt::format("[{}] {}: must be a finite number, got '{}'", name_, key,
                                        text));
    }
    check(v->where, key, x, lim);
    return x;
  }
  double get_float(std::string_view key, double def, const Limits& lim = {}) const {
    if (auto x = get_float(key, lim)) return *x;
    if (s_ != nullptr) {
      // Klipper's configfile.settings holds the defaults its modules read: the value as Python
      // prints a float (repr), for the macros that read it.
      std::string text = fmt::format("{}", def);
      if (text.find_first_of(".en") == std::string::npos) text += ".0";
      s_->defaults.emplace(std::string(key), std::move(text));
    }
    return def;
  }
  double require_float(std::string_view key, const Limits& lim = {}) const {
    if (auto x = get_float(key, lim)) return *x;
    throw missing(key);
  }

  std::optional<int> get_int(std::string_view key, const Limits& lim = {}) const {
    const CfgValue* v = raw(key);
    if (v == nullptr) return std::nullopt;
    const std::string_view text = trim(v->text);
    long long x = 0;
    const char* first = text.data();
    if (!text.empty() && text.front() == '+') ++first;
    const auto [ptr, ec] = std::from_chars(first, text.data() + text.size(), x);
    if (text.empty() || ec != std::errc() || ptr != text.data() + text.size() || x > 1000000000 ||
        x < -1000000000) {
      throw Error(v->where, fmt::format("[{}] {}: expected an integer, got '{}'", name_, key, text));
    }
    check(v->where, key, static_cast<double>(x), lim);
    return static_cast<int>(x);
  }
  int require_int(std::string_view key, const Limits& lim = {}) const {
    if (auto x = get_int(key, lim)) return *x;
    throw missing(key);
  }

  /// Klipper's choice options: the value, lower-cased, must be one of `choices`; `def` when
  /// the option is absent.
  std::string get_choice(std::string_view key, std::string_view def,
                         std::initializer_list<std::string_view> choices) const {
    const CfgValue* v = raw(key);
    if (v == nullptr) return std::string(def);
    std::string t(trim(v->text));
    for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    for (std::string_view c : choices) {
      if (c == t) return t;
    }
    throw Error(v->where, fmt::format("[{}] {}: found '{}', expected one of {}", name_, key,
                                      trim(v->text), fmt::join(choices, ", ")));
  }

  std::string require_text(std::string_view key) const {
    if (const CfgValue* v = raw(key)) return std::string(trim(v->text));
    throw missing(key);
  }

  const std::string& name() const { return name_; }
  const CfgSection* section() const { return s_; }

 private:
  Error missing(std::string_view key) const {
    return Error(s_ ? s_->where : fallback_,
                 fmt::format("option '{}' in section [{}] must be specified", key, name_));
  }
  void check(const SourceLocation& where, std::string_view key, double x, const Limits& lim) const {
    auto fail = [&](std::string_view rule, double bound) {
      return Error(where, fmt::format("[{}] {}: must be {} {}, got {}", name_, key, rule,
                                      detail::format_number(bound), detail::format_number(x)));
    };
    if (lim.minval && x < *lim.minval) throw fail("at least", *lim.minval);
    if (lim.maxval && x > *lim.maxval) throw fail("at most", *lim.maxval);
    if (lim.above && x <= *lim.above) throw fail("above", *lim.above);
    if (lim.below && x >= *lim.below) throw fail("below", *lim.below);
    if (lim.physical && x != 0.0 && !in_range(*lim.physical, x)) {
      throw Error(where, fmt::format("[{}] {}: must be {}, got {}", name_, key, describe(*lim.physical),
                                     detail::format_number(x)));
    }
  }

  CfgSection* s_;
  std::string name_;
  SourceLocation fallback_;
};

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
  return st;
}

// [printer] options of the cartesian/corexy toolhead. The last four are undocumented buffer
// settings older Klipper accepted (removed in bafb126a); they do not change the motion, so old
// configs that still carry them are read rather than rejected.
constexpr std::string_view kPrinterOptions[] = {
    "kinematics",      "max_velocity",      "max_accel",         "minimum_cruise_ratio",
    "max_accel_to_decel", "square_corner_velocity", "max_z_velocity", "max_z_accel",
    "buffer_time_low", "buffer_time_high",  "buffer_time_start", "move_flush_time"};

// [printer] options of a linear delta (kinematics/delta.py) and a deltesian (deltesian.py).
constexpr std::string_view kDeltaPrinterOptions[] = {"delta_radius", "print_radius",
                                                     "minimum_z_position"};
constexpr std::string_view kDeltesianPrinterOptions[] = {"min_angle", "print_width", "slow_ratio",
                                                         "minimum_z_position"};
// polar.py, rotary_delta.py.
constexpr std::string_view kPolarPrinterOptions[] = {"max_angular_velocity"};
constexpr std::string_view kRotaryDeltaPrinterOptions[] = {"shoulder_radius", "shoulder_height",
                                                           "minimum_z_position"};

Kinematics read_kinematics(const Section& printer) {
  const std::string kin = printer.require_text("kinematics");
  const SourceLocation where = printer.raw("kinematics")->where;
  const auto supported = detail::enum_names(detail::Kind::kinematics);
  for (std::size_t i = 0; i < supported.size(); ++i) {
    if (supported[i] == kin) return static_cast<Kinematics>(i);
  }
  std::vector<std::string> all(supported.begin(), supported.end());
  throw Error(where, fmt::format("[printer] kinematics: found '{}', expected a Klipper kinematics{}", kin,
                                 detail::did_you_mean(kin, all)));
}

/// generic_cartesian.py and kinematic_stepper.py: [carriage NAME] (axis: x, y or z, by default
/// the name when it is one of them; position_endstop, position_min (0), position_max),
/// [extra_carriage NAME] (primary_carriage), [dual_carriage NAME] (primary_carriage, the
/// range), and [stepper NAME] (carriages, the stepping). The checks that need all of them
/// together are machine::generic_cartesian_geometry's.
void read_generic_cartesian(CfgDoc& doc, Machine& m, const SourceLocation& file_loc,
                            const SourceLocation& printer_where) {
  auto name_after = [](const std::string& section, std::string_view prefix) -> std::string {
    if (section.rfind(prefix, 0) != 0) return {};
    std::string rest(trim(std::string_view(section).substr(prefix.size())));
    const std::size_t space = rest.find_last_of(" \t");
    return space == std::string::npos ? rest : rest.substr(space + 1);
  };
  for (CfgSection& s : doc.sections) {
    Carriage c;
    std::string name;
    if (!(name = name_after(s.name, "carriage ")).empty()) {
      c.type = Carriage::Type::primary;
    } else if (!(name = name_after(s.name, "extra_carriage ")).empty()) {
      c.type = Carriage::Type::extra;
    } else if (!(name = name_after(s.name, "dual_carriage ")).empty()) {
      c.type = Carriage::Type::dual;
    } else if (!(name = name_after(s.name, "stepper ")).empty()) {
      const Section sec(&s, s.name, file_loc);
      if (!detail::generic_stepper_name(name)) {
        throw Error(s.where, fmt::format("[{}]: amctl names a generic_cartesian stepper by the "
                                         "word after 'stepper', expected letters, digits and _ "
                                         "other than e, e1, ... (the extruders'), got '{}'",
                                         s.name, name));
      }
      Stepper st = read_stepper(sec);
      st.carriages = sec.require_text("carriages");
      m.steppers[name] = st;
      continue;
    } else {
      continue;
    }
    const Section sec(&s, s.name, file_loc);
    if (c.type == Carriage::Type::primary) {
      const bool named_axis = name == "x" || name == "y" || name == "z";
      c.axis = named_axis ? sec.get_choice("axis", name, {"x", "y", "z"})
                          : sec.get_choice("axis", "", {"x", "y", "z"});
      if (c.axis.empty()) (void)sec.require_text("axis");  // throws: missing
    } else if (c.type == Carriage::Type::extra) {
      c.primary_carriage = sec.require_text("primary_carriage");
    } else {
      // A dual carriage names its primary_carriage (axis optional, must match it) or, without
      // one, its own axis (generic_cartesian.py DualCarriage).
      if (sec.has("primary_carriage")) {
        c.primary_carriage = sec.require_text("primary_carriage");
        c.axis = sec.get_choice("axis", "", {"x", "y", "z"});
      } else {
        c.axis = sec.get_choice("axis", "", {"x", "y", "z"});
        if (c.axis.empty()) (void)sec.require_text("axis");  // throws: missing
      }
    }
    if (c.type != Carriage::Type::extra) {
      c.position_endstop_mm = sec.require_float("position_endstop");
      c.position_min_mm = sec.get_float("position_min", 0.0);
      c.position_max_mm = sec.require_float("position_max", {.above = *c.position_min_mm});
      c.homing_speed_mm_s = sec.get_float("homing_speed", 5.0, {.above = 0.0});
    }
    if (c.type == Carriage::Type::dual && !c.primary_carriage.empty()) {
      c.safe_distance_mm = sec.get_float("safe_distance", {.minval = 0.0});
    }
    if (m.carriages.count(name) != 0) {
      throw Error(s.where, fmt::format("[{}]: carriage '{}' is defined twice, expected one section "
                                       "per carriage name",
                                       s.name, name));
    }
    m.carriages[name] = c;
  }
  if (m.carriages.empty()) {
    throw Error(printer_where, "a generic_cartesian printer needs [carriage NAME] sections (one "
                               "per axis x, y, z) and [stepper NAME] sections with carriages");
  }
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
    throw Error(file_loc, "no [printer] section: not a Klipper printer.cfg");
  }
  const Section printer(printer_section, "printer", file_loc);
  m.kinematics = read_kinematics(printer);
  {
    // Klipper rejects any other [printer] option. amctl rejects the ones that look like a typo
    // of a known option (a misspelt square_corner_velocity would otherwise silently become
    // the default) and ignores the rest, so configs of Klipper forks with extra options load.
    std::vector<std::string> known(std::begin(kPrinterOptions), std::end(kPrinterOptions));
    if (m.kinematics == Kinematics::delta) {
      known.insert(known.end(), std::begin(kDeltaPrinterOptions), std::end(kDeltaPrinterOptions));
    }
    if (m.kinematics == Kinematics::deltesian) {
      known.insert(known.end(), std::begin(kDeltesianPrinterOptions),
                   std::end(kDeltesianPrinterOptions));
    }
    if (m.kinematics == Kinematics::polar) {
      known.insert(known.end(), std::begin(kPolarPrinterOptions), std::end(kPolarPrinterOptions));
    }
    if (m.kinematics == Kinematics::rotary_delta) {
      known.insert(known.end(), std::begin(kRotaryDeltaPrinterOptions),
                   std::end(kRotaryDeltaPrinterOptions));
    }
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

  if (CfgSection* es = doc.find("extruder")) {
    const Section ex(es, "extruder", file_loc);
    Extruder& e = m.extruder;
    e.nozzle_diameter_mm = ex.require_float("nozzle_diameter", {.above = 0.0, .physical = kLengthRange});
    e.filament_diameter_mm =
        ex.require_float("filament_diameter", {.minval = e.nozzle_diameter_mm});
    e.max_extrude_cross_section_mm2 = ex.get_float("max_extrude_cross_section", {.above = 0.0});
    e.max_extrude_only_velocity_mm_s =
        ex.get_float("max_extrude_only_velocity", {.above = 0.0, .physical = kSpeedRange});
    e.max_extrude_only_accel_mm_s2 =
        ex.get_float("max_extrude_only_accel", {.above = 0.0, .physical = kAccelRange});
    e.max_extrude_only_distance_mm =
        ex.get_float("max_extrude_only_distance", 50.0, {.minval = 0.0});
    e.instantaneous_corner_velocity_mm_s =
        ex.get_float("instantaneous_corner_velocity", 1.0, {.minval = 0.0});
    // extruder.py: a stepper is attached when step_pin, dir_pin or rotation_distance is given.
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
    // input_shaper.py (84104bbb): shaper_type (mzv) is the default of shaper_type_x/_y, taken
    // as written; damping_ratio_x/_y 0.1 in [0, 1]; shaper_freq_x/_y 0 (off), >= 0. amctl
    // also needs damping < 1 (a shaper is not defined at 1).
    const Section sh(is, "input_shaper", file_loc);
    InputShaper& in = m.input_shaper;
    const std::string both = shaper_type(sh, "shaper_type", "mzv");
    in.shaper_type_x = shaper_type(sh, "shaper_type_x", both);
    in.shaper_type_y = shaper_type(sh, "shaper_type_y", both);
    in.shaper_freq_x_hz = sh.get_float("shaper_freq_x", 0.0, {.minval = 0.0});
    in.shaper_freq_y_hz = sh.get_float("shaper_freq_y", 0.0, {.minval = 0.0});
    in.damping_ratio_x = sh.get_float("damping_ratio_x", 0.1, {.minval = 0.0, .below = 1.0});
    in.damping_ratio_y = sh.get_float("damping_ratio_y", 0.1, {.minval = 0.0, .below = 1.0});
  }
  const bool delta = m.kinematics == Kinematics::delta;
  if (delta) {
    // kinematics/delta.py: delta_radius (required, > 0), print_radius (> 0, default the
    // radius), minimum_z_position (default 0, at most the lowest endstop: delta_geometry).
    m.delta.radius_mm = printer.require_float("delta_radius", {.above = 0.0});
    m.delta.print_radius_mm = printer.get_float("print_radius", {.above = 0.0});
    m.delta.minimum_z_position_mm = printer.get_float("minimum_z_position");
    for (const char* tower : {"stepper_a", "stepper_b", "stepper_c"}) {
      if (doc.find(tower) == nullptr) {
        throw Error(printer_section->where,
                    fmt::format("a delta needs [{}] (towers stepper_a, stepper_b, stepper_c)", tower));
      }
    }
  }
  const bool deltesian = m.kinematics == Kinematics::deltesian;
  if (deltesian) {
    // deltesian.py: min_angle (5, [0, 90]), print_width (>= 0, at most the arms' reach:
    // deltesian_geometry), slow_ratio (3, >= 0), minimum_z_position (0).
    m.delta.min_angle_deg = printer.get_float("min_angle", {.minval = 0.0, .maxval = 90.0});
    m.delta.print_width_mm = printer.get_float("print_width", {.minval = 0.0});
    m.delta.slow_ratio = printer.get_float("slow_ratio", {.minval = 0.0});
    m.delta.minimum_z_position_mm = printer.get_float("minimum_z_position");
    for (const char* tower : {"stepper_left", "stepper_right", "stepper_y"}) {
      if (doc.find(tower) == nullptr) {
        throw Error(printer_section->where,
                    fmt::format("a deltesian needs [{}] (stepper_left, stepper_right, stepper_y)",
                                tower));
      }
    }
  }
  const bool polar = m.kinematics == Kinematics::polar;
  if (polar) {
    // polar.py: max_angular_velocity (> 0, default 0 = off); stepper_bed (radians),
    // stepper_arm (position_max: the reach), stepper_z (+ z1, ...).
    if (printer.has("max_angular_velocity")) {
      m.max_angular_velocity_rad_s = printer.get_float("max_angular_velocity", {.above = 0.0});
    }
    for (const char* s : {"stepper_bed", "stepper_arm", "stepper_z"}) {
      if (doc.find(s) == nullptr) {
        throw Error(printer_section->where,
                    fmt::format("a polar printer needs [{}] (stepper_bed, stepper_arm, stepper_z)", s));
      }
    }
  }
  const bool rotary = m.kinematics == Kinematics::rotary_delta;
  if (rotary) {
    // rotary_delta.py: shoulder_radius, shoulder_height (required, > 0), minimum_z_position
    // (0, at most the lowest endstop: rotary_delta_geometry); max_z_accel is not an option.
    m.delta.shoulder_radius_mm = printer.require_float("shoulder_radius", {.above = 0.0});
    m.delta.shoulder_height_mm = printer.require_float("shoulder_height", {.above = 0.0});
    m.delta.minimum_z_position_mm = printer.get_float("minimum_z_position");
    if (printer.has("max_z_accel")) {
      throw Error(printer.raw("max_z_accel")->where,
                  "[printer] max_z_accel: not an option of a rotary delta (rotary_delta.py caps "
                  "only the speed of moves with Z), expected no max_z_accel");
    }
    for (const char* arm : {"stepper_a", "stepper_b", "stepper_c"}) {
      if (doc.find(arm) == nullptr) {
        throw Error(printer_section->where,
                    fmt::format("a rotary delta needs [{}] (arms stepper_a, stepper_b, stepper_c)", arm));
      }
    }
  }
  const bool generic = m.kinematics == Kinematics::generic_cartesian;
  if (generic) read_generic_cartesian(doc, m, file_loc, printer_section->where);
  const bool winch = m.kinematics == Kinematics::winch;
  if (winch) {
    // winch.py: stepper_a, _b, _c required, more (d, e, ...) while present; each with
    // anchor_x, anchor_y, anchor_z. amctl takes up to four (stepper_e would be the extruder's
    // name in amctl's TOML form).
    for (const char* cable : {"stepper_a", "stepper_b", "stepper_c"}) {
      if (doc.find(cable) == nullptr) {
        throw Error(printer_section->where,
                    fmt::format("a winch needs [{}] (cables stepper_a, stepper_b, stepper_c)", cable));
      }
    }
    if (doc.find("stepper_d") != nullptr && doc.find("stepper_e") != nullptr) {
      throw Error(doc.find("stepper_e")->where,
                  "amctl supports winches of 3 or 4 cables (stepper_a .. stepper_d)");
    }
  }
  for (CfgSection& s : doc.sections) {
    if (generic) break;  // its steppers are [stepper NAME] (read_generic_cartesian)
    if (s.name.rfind("stepper_", 0) != 0) continue;
    const std::string name = s.name.substr(8);
    if (!detail::valid_stepper_name(name)) continue;  // e.g. stepper_left of a deltesian
    const bool lettered = name == "a" || name == "b" || name == "c" || name == "d";
    if (lettered != (delta || winch || rotary) || ((delta || rotary) && name == "d")) continue;
    if ((name == "bed" || name == "arm") != polar && (name == "bed" || name == "arm")) continue;
    if (polar && (name[0] == 'x' || name[0] == 'y')) continue;  // polar has no X/Y rails
    if (rotary) {
      // rotary_delta.py: arms in radians (gear_ratio); upper_arm_length, lower_arm_length and
      // position_endstop required on a, b and c default to a's; angle 30/150/270.
      const Section sec(&s, s.name, file_loc);
      Stepper st = read_stepper(sec, true);
      const bool is_a = name == "a";
      st.upper_arm_length_mm = is_a ? std::optional(sec.require_float("upper_arm_length", {.above = 0.0}))
                                    : sec.get_float("upper_arm_length", {.above = 0.0});
      st.lower_arm_length_mm = is_a ? std::optional(sec.require_float("lower_arm_length", {.above = 0.0}))
                                    : sec.get_float("lower_arm_length", {.above = 0.0});
      st.angle_deg = sec.get_float("angle");
      st.position_endstop_mm = is_a ? std::optional(sec.require_float("position_endstop"))
                                    : sec.get_float("position_endstop");
      m.steppers[name] = st;
      continue;
    }
    if (polar && (name == "bed" || name == "arm")) {
      const Section sec(&s, s.name, file_loc);
      Stepper st = read_stepper(sec, name == "bed");
      if (name == "arm") {
        st.position_endstop_mm = sec.require_float("position_endstop");
        st.position_min_mm = sec.get_float("position_min", 0.0);
        st.position_max_mm = sec.require_float("position_max", {.above = *st.position_min_mm});
      }
      m.steppers[name] = st;
      continue;
    }
    if (winch) {
      Stepper st = read_stepper(Section(&s, s.name, file_loc));
      const Section sec(&s, s.name, file_loc);
      st.anchor_x_mm = sec.require_float("anchor_x");
      st.anchor_y_mm = sec.require_float("anchor_y");
      st.anchor_z_mm = sec.require_float("anchor_z");
      m.steppers[name] = st;
      continue;
    }
    if ((name == "left" || name == "right") != deltesian && (name == "left" || name == "right")) {
      continue;
    }
    if (deltesian && (name == "left" || name == "right")) {
      // deltesian.py: arm_x_length (> 0) and arm_length (> arm_x_length) required on left,
      // right defaults to left's; position_endstop required on left.
      const Section sec(&s, s.name, file_loc);
      Stepper st = read_stepper(sec);
      const bool is_left = name == "left";
      st.arm_x_length_mm = is_left ? std::optional(sec.require_float("arm_x_length", {.above = 0.0}))
                                   : sec.get_float("arm_x_length", {.above = 0.0});
      st.arm_length_mm = is_left ? std::optional(sec.require_float("arm_length", {.above = 0.0}))
                                 : sec.get_float("arm_length", {.above = 0.0});
      st.position_endstop_mm = is_left ? std::optional(sec.require_float("position_endstop"))
                                       : sec.get_float("position_endstop");
      m.steppers[name] = st;
      continue;
    }
    const bool tower = lettered;
    const Section sec(&s, s.name, file_loc);
    Stepper st = read_stepper(sec);
    if (tower) {
      // delta.py: arm_length required on stepper_a, > delta_radius; b and c default to a's
      // (delta_geometry applies those defaults); angle 210/330/90; position_endstop required
      // on a, b and c default to a's.
      const Limits arm{.above = *m.delta.radius_mm};
      st.arm_length_mm = name == "a" ? std::optional(sec.require_float("arm_length", arm))
                                     : sec.get_float("arm_length", arm);
      st.angle_deg = sec.get_float("angle");
      st.position_endstop_mm = name == "a" ? std::optional(sec.require_float("position_endstop"))
                                           : sec.get_float("position_endstop");
      m.steppers[name] = st;
      continue;
    }
    // stepper.py PrinterRail: the rail's first stepper (stepper_x, _y, _z) holds the range;
    // position_min defaults to 0, position_max must lie above it.
    if ((name == "x" || name == "y" || name == "z") && sec.has("position_max")) {
      st.position_min_mm = sec.get_float("position_min", 0.0);
      st.position_max_mm = sec.get_float("position_max", {.above = *st.position_min_mm});
      st.position_endstop_mm = sec.get_float("position_endstop");
    }
    m.steppers[name] = st;
  }
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
  // exclude_object.py is loaded by its section only; without it EXCLUDE_OBJECT* are unknown.
  m.exclude_object = doc.find("exclude_object") != nullptr;
  // cartesian.py / hybrid_corexy.py / hybrid_corexz.py: [dual_carriage] adds a second rail on
  // X or Y (idex_modes.py); stepper.py's rail rules (position_min 0, endstop and max required).
  if (CfgSection* ds = doc.find("dual_carriage")) {
    const Section d(ds, "dual_carriage", file_loc);
    if (m.kinematics != Kinematics::cartesian && m.kinematics != Kinematics::hybrid_corexy &&
        m.kinematics != Kinematics::hybrid_corexz) {
      throw Error(ds->where, "[dual_carriage]: amctl models a dual carriage on cartesian, "
                             "hybrid_corexy and hybrid_corexz kinematics only (as Klipper)");
    }
    DualCarriage& dc = m.dual_carriage;
    dc.axis = d.get_choice("axis", "", {"x", "y"});
    if (dc.axis.empty()) throw Error(ds->where, "[dual_carriage] axis: must be specified (x or y)");
    dc.position_endstop_mm = d.require_float("position_endstop");
    dc.position_min_mm = d.get_float("position_min", 0.0);
    dc.position_max_mm = d.get_float("position_max", {.above = *dc.position_min_mm});
    if (!dc.position_max_mm) throw Error(ds->where, "[dual_carriage] position_max: must be specified");
    dc.safe_distance_mm = d.get_float("safe_distance", {.minval = 0.0});
    dc.homing_speed_mm_s = d.get_float("homing_speed", 5.0, {.above = 0.0});
    if (CfgSection* ps = doc.find(std::string("stepper_") + dc.axis)) {
      dc.primary_homing_speed_mm_s = Section(ps, ps->name, file_loc).get_float("homing_speed", 5.0, {.above = 0.0});
    }
  }
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
