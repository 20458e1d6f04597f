// amctl's TOML machine description: reading (with file:line:col errors and did-you-mean) and
// `--set` overrides; writing is in toml_write.cpp. All of it is driven by the key table in
// schema.cpp; validation and the key listing are in validate.cpp.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "amctl/machine/effective.hpp"
#include "amctl/machine/loader.hpp"
#include "kinematics_keys.hpp"
#include "schema.hpp"

namespace amctl::machine {
namespace {

using detail::Bound;
using detail::Kind;
using detail::KeyDef;
using detail::StepperKeyDef;

SourceLocation location_of(const toml::source_region& r, const std::string& file) {
  SourceLocation loc;
  loc.file = file;
  loc.line = r.begin.line;
  loc.column = r.begin.column;
  return loc;
}

std::string_view type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    default: return "nothing";
  }
}

/// Reads a number from a TOML node (integers are accepted where floats are expected).
double number_of(const toml::node& v, const SourceLocation& where, std::string_view label,
                 std::string_view unit) {
  if (v.is_integer()) return static_cast<double>(*v.value<std::int64_t>());
  if (v.is_floating_point()) return *v.value<double>();
  throw Error(where, fmt::format("{}: expected a number{}, got {}", label,
                                 unit.empty() ? "" : fmt::format(" in {}", unit), type_name(v)));
}

double bounded_number(const toml::node& v, Bound b, const SourceLocation& where,
                      std::string_view label, std::string_view unit) {
  const double x = number_of(v, where, label, unit);
  detail::check_bound(b, x, where, label, unit);
  return x;
}

int integer_of(const toml::node& v, Bound b, const SourceLocation& where, std::string_view label) {
  double x = 0.0;
  if (v.is_integer()) {
    x = static_cast<double>(*v.value<std::int64_t>());
  } else if (v.is_floating_point() && std::isfinite(*v.value<double>()) &&
             *v.value<double>() == std::floor(*v.value<double>())) {
    x = *v.value<double>();
  } else {
    throw Error(where, fmt::format("{}: expected an integer, got {}", label, type_name(v)));
  }
  if (x > 1e9 || x < -1e9) {
    throw Error(where, fmt::format("{}: integer {} is out of range", label, x));
  }
  detail::check_bound(b, x, where, label, "");
  return static_cast<int>(x);
}

int enum_of(const toml::node& v, Kind kind, const SourceLocation& where, std::string_view label) {
  const auto names = detail::enum_names(kind);
  std::vector<std::string> options(names.begin(), names.end());
  const std::string listed = fmt::format("{}", fmt::join(options, ", "));
  if (!v.is_string()) {
    throw Error(where, fmt::format("{}: expected one of {} (a string), got {}", label, listed,
                                   type_name(v)));
  }
  const std::string text = *v.value<std::string>();
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == text) return static_cast<int>(i);
  }
  throw Error(where, fmt::format("{}: found '{}', expected one of {}{}", label, text, listed,
                                 detail::did_you_mean(text, options)));
}

std::array<double, 4> axes_of(const toml::node& v, Bound b, const SourceLocation& where,
                              std::string_view label, std::string_view unit,
                              const std::string& file) {
  const toml::array* arr = v.as_array();
  if (arr == nullptr || arr->size() != 4) {
    throw Error(where, fmt::format("{}: expected [x, y, z, e] (an array of 4 numbers{}), got {}",
                                   label, unit.empty() ? "" : fmt::format(" in {}", unit),
                                   arr ? fmt::format("an array of {}", arr->size())
                                       : std::string(type_name(v))));
  }
  std::array<double, 4> out{};
  static constexpr const char* kAxis[] = {"x", "y", "z", "e"};
  for (std::size_t i = 0; i < 4; ++i) {
    const toml::node& e = *arr->get(i);
    SourceLocation ew = e.source().begin.line ? location_of(e.source(), file) : where;
    out[i] = bounded_number(e, b, ew, fmt::format("{}.{}", label, kAxis[i]), unit);
  }
  return out;
}

/// State carried across the keys of one document.
struct Pending {
  std::optional<double> accel_to_decel;
  bool minimum_cruise_ratio_given = false;
  bool junction_given = false;
  bool name_given = false;
};

/// Sets one [section] key from a TOML value. `file` is used for element locations.
void assign(Machine& m, const KeyDef& d, const toml::node& v, const SourceLocation& where,
            const std::string& file, Pending& pending) {
  const std::string label = fmt::format("{}.{}", d.section, d.key);
  switch (d.kind) {
    case Kind::number:
      d.number(m) = bounded_number(v, d.bound, where, label, d.unit);
      if (d.key == "minimum_cruise_ratio") pending.minimum_cruise_ratio_given = true;
      return;
    case Kind::optional_number:
      d.optional_number(m) = bounded_number(v, d.bound, where, label, d.unit);
      return;
    case Kind::integer: d.integer(m) = integer_of(v, d.bound, where, label); return;
    case Kind::axes4: d.axes(m) = axes_of(v, d.bound, where, label, d.unit, file); return;
    case Kind::text:
      if (!v.is_string()) {
        throw Error(where, fmt::format("{}: expected a string, got {}", label, type_name(v)));
      }
      d.text(m) = *v.value<std::string>();
      if (d.section == "input_shaper") detail::check_shaper_type(d.text(m), where, label);
      if (d.key == "name") pending.name_given = true;
      return;
    case Kind::boolean:
      if (!v.is_boolean()) {
        throw Error(where, fmt::format("{}: expected true or false, got {}", label, type_name(v)));
      }
      d.boolean(m) = *v.value<bool>();
      return;
    case Kind::firmware:
    case Kind::kinematics:
    case Kind::profile:
      detail::set_enum(m, d.kind, enum_of(v, d.kind, where, label));
      return;
    case Kind::junction:
      detail::set_enum(m, d.kind, enum_of(v, d.kind, where, label));
      pending.junction_given = true;
      return;
    case Kind::accel_to_decel:
      pending.accel_to_decel = bounded_number(v, d.bound, where, label, d.unit);
      return;
    case Kind::gear_ratio: break;
  }
  AMCTL_CHECK(false, "unhandled key kind");
}

/// Sets one [stepper_*] key; gear ratios multiply into `gearing`.
void assign_stepper(Stepper& s, double& gearing, const StepperKeyDef& d, const toml::node& v,
                    const SourceLocation& where, const std::string& label) {
  switch (d.kind) {
    case Kind::number: d.number(s) = bounded_number(v, d.bound, where, label, d.unit); return;
    case Kind::integer: d.integer(s) = integer_of(v, d.bound, where, label); return;
    case Kind::optional_number:
      d.optional_number(s) = bounded_number(v, d.bound, where, label, d.unit);
      return;
    case Kind::text:
      if (!v.is_string()) {
        throw Error(where, fmt::format("{}: expected a string, got {}", label, type_name(v)));
      }
      d.text(s) = *v.value<std::string>();
      if (d.key == "motor") detail::check_motor_preset(d.text(s), where, label);
      return;
    case Kind::gear_ratio:
      if (v.is_string()) {
        gearing = detail::parse_gear_ratio(*v.value<std::string>(), where, label);
      } else {
        gearing = bounded_number(v, Bound::positive, where, label, "");
      }
      return;
    default: break;
  }
  AMCTL_CHECK(false, "unhandled stepper key kind");
}

JunctionPolicy default_junction(Firmware f) {
  switch (f) {
    case Firmware::klipper: return JunctionPolicy::square_corner_velocity;
    case Firmware::marlin: return JunctionPolicy::junction_deviation;
    case Firmware::reprap: return JunctionPolicy::classic_jerk;
  }
  return JunctionPolicy::square_corner_velocity;
}

void finish(Machine& m, const Pending& p) {
  if (!p.junction_given) m.junction = default_junction(m.firmware);
  if (p.accel_to_decel && !p.minimum_cruise_ratio_given) {
    // klippy/toolhead.py (commit 0105aa33): 1 - min(1, max_accel_to_decel / max_accel).
    m.minimum_cruise_ratio =
        minimum_cruise_ratio_from_accel_to_decel(*p.accel_to_decel, m.max_accel_mm_s2);
  }
}

std::vector<std::string> section_candidates() {
  std::vector<std::string> out;
  for (std::string_view s : detail::machine_sections()) out.emplace_back(s);
  for (const char* s : {"stepper_x", "stepper_y", "stepper_z", "stepper_e"}) out.emplace_back(s);
  return out;
}

std::vector<std::string> keys_of(std::string_view section) {
  std::vector<std::string> out;
  for (const KeyDef& d : detail::machine_keys()) {
    if (d.section == section) out.emplace_back(d.key);
  }
  return out;
}

std::vector<std::string> stepper_key_names() {
  std::vector<std::string> out;
  for (const StepperKeyDef& d : detail::stepper_keys()) out.emplace_back(d.key);
  return out;
}

/// True when some kinematics owns [stepper_NAME] key `key` (a generic_cartesian's carriages).
bool is_kinematics_stepper_key(std::string_view key) {
  static const std::vector<detail::BoundKey> all = detail::all_kinematics_keys();
  return std::any_of(all.begin(), all.end(),
                     [&](const detail::BoundKey& b) { return b.section == "stepper" && b.key == key; });
}

/// "unknown key 'x' in [s]; did you mean 'y'?" or "...; 'x' belongs in [marlin]".
std::string unknown_key_message(std::string_view section, std::string_view key,
                                std::vector<std::string> candidates) {
  std::string msg = fmt::format("unknown key '{}' in [{}], expected a key that `amctl machine keys` lists", key, section);
  std::string hint;
  for (const KeyDef& d : detail::machine_keys()) {
    if (d.key == key && d.section != section) {
      hint = fmt::format("; '{}' belongs in [{}]", key, d.section);
      break;
    }
  }
  if (hint.empty()) hint = detail::did_you_mean(key, candidates);
  if (hint.empty()) hint = fmt::format(" (known keys: {})", fmt::join(candidates, ", "));
  return msg + hint;
}

/// Table entries in file order (toml++ keeps tables sorted by key).
std::vector<std::pair<const toml::key*, const toml::node*>> in_file_order(const toml::table& t) {
  std::vector<std::pair<const toml::key*, const toml::node*>> out;
  for (auto&& [k, v] : t) out.emplace_back(&k, &v);
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    const auto& ra = a.first->source().begin;
    const auto& rb = b.first->source().begin;
    return ra.line != rb.line ? ra.line < rb.line : ra.column < rb.column;
  });
  return out;
}


/// Sets one key the kinematics or the extruder owns from a TOML value.
void assign_bound(const detail::BoundKey& d, std::string_view instance, const toml::node& v,
                  const SourceLocation& where, const std::string& label) {
  using BK = detail::BoundKey::Kind;
  switch (d.kind) {
    case BK::number: *d.number(instance, true) = bounded_number(v, d.bound, where, label, d.unit); return;
    case BK::optional_number:
      *d.optional_number(instance, true) = bounded_number(v, d.bound, where, label, d.unit);
      return;
    case BK::boolean:
      if (!v.is_boolean()) {
        throw Error(where, fmt::format("{}: expected true or false, got {}", label, type_name(v)));
      }
      *d.boolean(instance, true) = *v.value<bool>();
      return;
    case BK::text:
    case BK::choice: {
      if (!v.is_string()) {
        throw Error(where, fmt::format("{}: expected a string, got {}", label, type_name(v)));
      }
      const std::string text = *v.value<std::string>();
      int index = -1;
      if (!d.choices.empty()) {
        const auto it = std::find(d.choices.begin(), d.choices.end(), text);
        if (it == d.choices.end()) {
          std::vector<std::string> shown;
          for (std::string_view c : d.choices) {
            if (!c.empty()) shown.emplace_back(c);
          }
          throw Error(where, fmt::format("{}: found '{}', expected one of {}", label, text,
                                         fmt::join(shown, ", ")));
        }
        index = static_cast<int>(it - d.choices.begin());
      }
      if (d.kind == BK::text) *d.text(instance, true) = text;
      else d.set_index(instance, index);
      return;
    }
  }
}

/// The keys a section holds (machine and bound ones), for hints.
std::vector<std::string> keys_in(std::string_view section, const std::vector<detail::BoundKey>& bound) {
  std::vector<std::string> out = keys_of(section);
  for (const detail::BoundKey& b : bound) {
    if (b.section == section && std::find(out.begin(), out.end(), b.key) == out.end()) out.emplace_back(b.key);
  }
  return out;
}

/// "[delta] is a delta, deltesian, rotary_delta section, expected none for kinematics cartesian".
std::string foreign_section(std::string_view shown, std::string_view section, const Machine& m) {
  const auto owners = detail::kinematics_with_section(section);
  return fmt::format("[{}] is a {} section, expected none for kinematics {}", shown,
                     fmt::join(owners, ", "), kinematics::name_of(m.kinematics));
}

}  // namespace

std::string_view to_string(Firmware f) {
  return detail::enum_names(Kind::firmware)[static_cast<std::size_t>(f)];
}
std::string_view to_string(JunctionPolicy j) {
  return detail::enum_names(Kind::junction)[static_cast<std::size_t>(j)];
}
std::string_view to_string(VelocityProfile p) {
  return detail::enum_names(Kind::profile)[static_cast<std::size_t>(p)];
}

Machine parse_machine_toml(std::string_view text, const std::string& source_name) {
  toml::table root;
  try {
    root = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    throw Error(location_of(e.source(), source_name),
                fmt::format("invalid TOML ({}), expected a machine description in TOML", e.description()));
  }
  Machine m;
  Pending pending;
  // The kinematics first: the other tables hold its keys.
  if (const toml::table* printer = root["printer"].as_table()) {
    if (const toml::node* k = printer->get("kinematics")) {
      const KeyDef* d = detail::find_key("printer", "kinematics");
      assign(m, *d, *k, location_of(k->source(), source_name), source_name, pending);
    }
  }
  std::vector<detail::BoundKey> bound = detail::bound_keys(m);
  for (const auto& [kp, np] : in_file_order(root)) {
    const std::string section(kp->str());
    const SourceLocation section_where = location_of(kp->source(), source_name);
    const toml::table* table = np->as_table();
    if (table == nullptr) {
      throw Error(section_where,
                  fmt::format("unexpected top-level key '{}': every key belongs in a section "
                              "such as [printer]{}",
                              section, detail::did_you_mean(section, section_candidates())));
    }
    const bool is_machine_section =
        std::find(detail::machine_sections().begin(), detail::machine_sections().end(),
                  section) != detail::machine_sections().end();
    if (is_machine_section) {
      const std::vector<std::string> candidates = keys_in(section, bound);
      if (candidates.empty()) throw Error(section_where, foreign_section(section, section, m));
      for (const auto& [k, v] : in_file_order(*table)) {
        const std::string key(k->str());
        const SourceLocation where = location_of(v->source(), source_name);
        if (section == "printer" && key == "kinematics") continue;  // read first
        if (const KeyDef* d = detail::find_key(section, key)) {
          assign(m, *d, *v, where, source_name, pending);
        } else if (const detail::BoundKey* b = detail::find_bound(bound, section, key, "")) {
          assign_bound(*b, "", *v, where, fmt::format("{}.{}", section, key));
          if (b->extruder) {
            // The extruder's checks beyond a key's bound (Klipper's smooth-time limit), here
            // where the key's line is known.
            try {
              m.extruder.check();
            } catch (const Error& e) {
              throw Error(where, e.detail());
            }
          }
        } else {
          throw Error(location_of(k->source(), source_name),
                      unknown_key_message(section, key, candidates));
        }
      }
    } else if (section == "carriage") {
      // [carriage.NAME] tables: generic_cartesian carriages.
      const std::vector<std::string> keys = keys_in("carriage", bound);
      for (const auto& [k, v] : in_file_order(*table)) {
        const std::string name(k->str());
        const SourceLocation cw = location_of(k->source(), source_name);
        const toml::table* ct = v->as_table();
        if (ct == nullptr || name.empty()) {
          throw Error(cw, fmt::format("carriage.{}: expected a table [carriage.NAME], got {}", name,
                                      type_name(*v)));
        }
        if (keys.empty()) throw Error(cw, foreign_section("carriage." + name, "carriage", m));
        for (const auto& [ck, cv] : in_file_order(*ct)) {
          const std::string key(ck->str());
          const detail::BoundKey* b = detail::find_bound(bound, "carriage", key, name);
          if (b == nullptr) {
            throw Error(location_of(ck->source(), source_name),
                        fmt::format("unknown key '{}' in [carriage.{}], expected one of {}{}", key,
                                    name, fmt::join(keys, ", "), detail::did_you_mean(key, keys)));
          }
          assign_bound(*b, name, *cv, location_of(cv->source(), source_name),
                       fmt::format("carriage.{}.{}", name, key));
        }
      }
    } else if (section.rfind("stepper_", 0) == 0 &&
               (detail::valid_stepper_name(section.substr(8)) ||
                detail::owned_stepper(m, section.substr(8)) ||
                std::any_of(table->begin(), table->end(), [&](auto&& kv) {
                  // A stepper a kinematics names by one of its keys (a generic_cartesian
                  // stepper by its carriages); on another kinematics the key is refused below.
                  return is_kinematics_stepper_key(kv.first.str());
                }))) {
      const std::string name = section.substr(8);
      const bool radians = detail::drive_train_unit(m, name) == kinematics::Unit::rad;
      Stepper s;
      double gearing = 1.0;
      std::optional<double> rotation;
      for (const auto& [k, v] : in_file_order(*table)) {
        const std::string key(k->str());
        const SourceLocation where = location_of(v->source(), source_name);
        const std::string label = fmt::format("{}.{}", section, key);
        if (const StepperKeyDef* d = detail::find_stepper_key(key)) {
          assign_stepper(s, gearing, *d, *v, where, label);
          if (key == "rotation_distance") rotation = s.rotation_distance_mm;
        } else if (const detail::BoundKey* b = detail::find_bound(bound, "stepper", key, name)) {
          assign_bound(*b, name, *v, where, label);
        } else {
          std::vector<std::string> candidates = stepper_key_names();
          for (const detail::BoundKey& bk : bound) {
            if (bk.section == "stepper") candidates.emplace_back(bk.key);
          }
          throw Error(location_of(k->source(), source_name),
                      fmt::format("unknown key '{}' in [{}], expected a stepper key{}", key, section,
                                  detail::did_you_mean(key, candidates)));
        }
      }
      if (radians) {
        // A turning motor: rotation_distance is in radians (its output's turn per motor turn).
        s.rotation_distance_rad = rotation.value_or(2.0 * std::numbers::pi) / gearing;
        s.rotation_distance_mm = Stepper{}.rotation_distance_mm;
      } else {
        s.rotation_distance_mm /= gearing;
      }
      m.steppers[name] = s;
    } else {
      std::string hint = detail::did_you_mean(section, section_candidates());
      if (hint.empty() && section.rfind("stepper_", 0) == 0) {
        hint = " (stepper sections are stepper_x, stepper_y, stepper_z, stepper_e, optionally "
               "numbered: stepper_z1; a generic_cartesian stepper of any name has a carriages "
               "key)";
      }
      if (hint.empty()) {
        hint = fmt::format(" (sections: {}, stepper_<x|y|z|e>)",
                           fmt::join(detail::machine_sections(), ", "));
      }
      if (auto c = detail::closest(section, section_candidates())) {
        hint = fmt::format("; did you mean [{}]?", *c);
      }
      throw Error(section_where, fmt::format("unknown section [{}], expected a section that `amctl machine keys` lists{}", section, hint));
    }
  }
  finish(m, pending);
  if (!pending.name_given) {
    // A file without a name is called after itself ("my-printer.toml" -> "my-printer").
    const std::size_t slash = source_name.find_last_of("/\\");
    std::string stem = source_name.substr(slash == std::string::npos ? 0 : slash + 1);
    if (const std::size_t dot = stem.rfind('.'); dot != std::string::npos && dot > 0) {
      stem.resize(dot);
    }
    if (!stem.empty()) m.name = stem;
  }
  try {
    validate(m);
  } catch (const Error& e) {
    throw Error(SourceLocation{source_name, 0, 0}, e.detail());
  }
  return m;
}

void apply_override(Machine& m, std::string_view assignment) {
  // Messages read "--set printer.max_accel=abc: printer.max_accel: expected a number ...".
  const SourceLocation where{fmt::format("--set {}", assignment), 0, 0};
  const std::size_t eq = assignment.find('=');
  auto trim = [](std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
  };
  if (eq == std::string_view::npos) {
    throw Error(where, "expected section.key=value, e.g. printer.max_accel=5000");
  }
  const std::string path(trim(assignment.substr(0, eq)));
  const std::string value_text(trim(assignment.substr(eq + 1)));
  std::vector<std::string> parts;
  for (std::size_t start = 0;;) {
    const std::size_t dot = path.find('.', start);
    parts.push_back(path.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  if (parts.size() < 2 || parts.size() > 3 || parts[0].empty() || parts[1].empty()) {
    throw Error(where, "expected section.key=value, e.g. printer.max_accel=5000");
  }
  const std::vector<detail::BoundKey> bound = detail::bound_keys(m);
  // All known "section.key" names, for hints.
  std::vector<std::string> all;
  for (const KeyDef& d : detail::machine_keys()) all.push_back(fmt::format("{}.{}", d.section, d.key));
  for (const detail::BoundKey& d : bound) {
    if (d.section != "stepper" && d.section != "carriage") all.push_back(fmt::format("{}.{}", d.section, d.key));
  }
  for (const StepperKeyDef& d : detail::stepper_keys()) all.push_back(fmt::format("stepper_x.{}", d.key));
  const std::string dotted = parts[0] + "." + parts[1];

  // Parse the value as TOML; bare words become strings.
  toml::table parsed;
  bool parsed_ok = true;
  try {
    const std::string doc = "v = " + value_text;
    parsed = toml::parse(std::string_view(doc), std::string_view("--set"));
  } catch (const toml::parse_error&) {
    parsed_ok = false;
  }
  toml::value<std::string> bare(value_text);
  const toml::node* value = parsed_ok ? parsed.get("v") : nullptr;
  if (value == nullptr) value = &bare;
  const std::string label = path;

  if (parts[0].rfind("stepper_", 0) == 0) {
    const std::string name = parts[0].substr(8);
    const bool known_stepper = m.steppers.find(name) != m.steppers.end();
    if ((!detail::valid_stepper_name(name) && !detail::owned_stepper(m, name) && !known_stepper) ||
        parts.size() != 2) {
      throw Error(where, fmt::format("unknown key '{}', expected a stepper section stepper_x, "
                                     "stepper_y, stepper_z, stepper_e, stepper_z1, ...",
                                     path));
    }
    if (const StepperKeyDef* d = detail::find_stepper_key(parts[1])) {
      const auto it = m.steppers.find(name);
      Stepper s = it == m.steppers.end() ? Stepper{} : it->second;
      double gearing = 1.0;
      assign_stepper(s, gearing, *d, *value, where, label);
      if (detail::drive_train_unit(m, name) == kinematics::Unit::rad) {
        if (parts[1] == "rotation_distance") {
          s.rotation_distance_rad = s.rotation_distance_mm;
          s.rotation_distance_mm = it == m.steppers.end() ? Stepper{}.rotation_distance_mm
                                                          : it->second.rotation_distance_mm;
        }
        if (s.rotation_distance_rad) *s.rotation_distance_rad /= gearing;
      } else {
        s.rotation_distance_mm /= gearing;
      }
      m.steppers[name] = s;  // only once the value is known to be good
      return;
    }
    Machine changed = m;  // the value is checked before m changes
    const std::vector<detail::BoundKey> changed_keys = detail::bound_keys(changed);
    const detail::BoundKey* b = detail::find_bound(changed_keys, "stepper", parts[1], name);
    if (b == nullptr) {
      std::vector<std::string> candidates = stepper_key_names();
      for (const detail::BoundKey& bk : bound) {
        if (bk.section == "stepper") candidates.emplace_back(bk.key);
      }
      throw Error(where, fmt::format("unknown key '{}', expected a key that `amctl machine keys` lists{}", path,
                                     detail::did_you_mean(parts[1], candidates)));
    }
    assign_bound(*b, name, *value, where, label);
    m = std::move(changed);
    return;
  }
  const KeyDef* d = detail::find_key(parts[0], parts[1]);
  if (d == nullptr) {
    Machine changed = m;
    const std::vector<detail::BoundKey> changed_keys = detail::bound_keys(changed);
    const std::string instance = parts[0] == "carriage" && parts.size() == 3 ? parts[1] : "";
    const std::string& key = parts[0] == "carriage" && parts.size() == 3 ? parts[2] : parts[1];
    if (parts.size() == 2 || !instance.empty()) {
      if (const detail::BoundKey* b = detail::find_bound(changed_keys, parts[0], key, instance)) {
        assign_bound(*b, instance, *value, where, label);
        m = std::move(changed);
        return;
      }
    }
    // The key spelled right in another section is the likeliest meaning; then a near miss.
    std::string hint;
    for (const KeyDef& k : detail::machine_keys()) {
      if (k.key == parts[1]) {
        hint = fmt::format("; did you mean '{}.{}'?", k.section, k.key);
        break;
      }
    }
    if (hint.empty()) hint = detail::did_you_mean(dotted, all);
    throw Error(where, fmt::format("unknown key '{}', expected a key that `amctl machine keys` lists{}", dotted, hint));
  }
  if (parts.size() == 3) {
    static constexpr std::string_view kAxis[] = {"x", "y", "z", "e"};
    const auto it = std::find(std::begin(kAxis), std::end(kAxis), parts[2]);
    if (d->kind != Kind::axes4 || it == std::end(kAxis)) {
      throw Error(where, fmt::format("unknown key '{}', expected a key that `amctl machine keys` lists{}", path,
                                     d->kind == Kind::axes4
                                         ? " (the element must be x, y, z or e)"
                                         : fmt::format(" ('{}' has no elements)", dotted)));
    }
    d->axes(m)[static_cast<std::size_t>(it - std::begin(kAxis))] =
        bounded_number(*value, d->bound, where, label, d->unit);
    return;
  }
  Pending pending;
  pending.junction_given = true;  // an override changes only the key it names
  assign(m, *d, *value, where, "--set", pending);
  if (pending.accel_to_decel) {
    m.minimum_cruise_ratio =
        minimum_cruise_ratio_from_accel_to_decel(*pending.accel_to_decel, m.max_accel_mm_s2);
  }
}

}  // namespace amctl::machine
