// amctl's TOML machine description, written: to_toml (round-trips exactly through
// parse_machine_toml, toml_io.cpp), driven by the key table in schema.cpp.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

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

void append_toml_string(std::string& out, std::string_view s) {
  out += '"';
  for (char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
          out += fmt::format("\\u{:04X}", static_cast<unsigned>(static_cast<unsigned char>(c)));
        } else {
          out += c;
        }
    }
  }
  out += '"';
}

/// "# key is unset: ..." for an unset optional Klipper key, as firmware `fw` reads it.
std::string unset_comment(std::string_view key, Firmware fw) {
  return fw == Firmware::klipper
             ? fmt::format("# {} is unset: Klipper's derived default applies\n", key)
             : fmt::format("# {} is unset (a Klipper key, not read for {})\n", key, to_string(fw));
}

/// `key = value  # unit` of a bound key at `instance`; nothing when it does not apply or is
/// unset (`comment_unset`: unset_comment for an unset optional number instead).
void append_bound(std::string& out, const detail::BoundKey& d, std::string_view instance,
                  std::optional<Firmware> comment_unset) {
  using BK = detail::BoundKey::Kind;
  const std::string unit = d.unit.empty() ? std::string() : fmt::format("  # {}", d.unit);
  switch (d.kind) {
    case BK::number:
      if (const double* v = d.number(instance, false); v != nullptr && *v != d.unwritten_default) {
        out += fmt::format("{} = {}{}\n", d.key, detail::format_number(*v), unit);
      }
      return;
    case BK::optional_number:
      if (const std::optional<double>* v = d.optional_number(instance, false)) {
        if (*v) {
          out += fmt::format("{} = {}{}\n", d.key, detail::format_number(**v), unit);
        } else if (comment_unset) {
          out += unset_comment(d.key, *comment_unset);
        }
      }
      return;
    case BK::text:
      if (const std::string* v = d.text(instance, false); v != nullptr && !v->empty()) {
        out += fmt::format("{} = ", d.key);
        append_toml_string(out, *v);
        out += '\n';
      }
      return;
    case BK::choice:
      if (const int i = d.get_index(instance); i >= 0) {
        out += fmt::format("{} = \"{}\"\n", d.key, d.choices[static_cast<std::size_t>(i)]);
      }
      return;
    case BK::boolean:
      if (const bool* v = d.boolean(instance, false); v != nullptr && !*v) {
        out += fmt::format("{} = false\n", d.key);
      }
      return;
  }
}

/// True when a bound key applies at `instance` (its field exists).
bool applies(const detail::BoundKey& d, std::string_view instance) {
  using BK = detail::BoundKey::Kind;
  switch (d.kind) {
    case BK::number: return d.number(instance, false) != nullptr;
    case BK::optional_number: return d.optional_number(instance, false) != nullptr;
    case BK::text: return d.text(instance, false) != nullptr;
    case BK::choice: return d.get_index(instance) >= 0;
    case BK::boolean: return d.boolean(instance, false) != nullptr;
  }
  return false;
}

}  // namespace

std::string to_toml(const Machine& machine) {
  Machine m = machine;  // the key table's accessors take a mutable Machine
  const std::vector<detail::BoundKey> bound = detail::bound_keys(m);
  std::string out =
      "# amctl machine description. Units: mm, s, mm/s, mm/s^2; every key is documented in\n"
      "# docs/machine.md.\n";
  for (std::string_view section : detail::machine_sections()) {
    // [input_shaper] is written only when it says something (Klipper's defaults: off).
    if (section == "input_shaper" && m.input_shaper == InputShaper{}) continue;
    std::string body;
    bool any = false;
    const bool klipper = m.firmware == Firmware::klipper;
    if (section == "printer" && !klipper) {
      body += fmt::format(
          "# firmware = {0}: its limits are the [marlin] section's (M201/M203/M204/M205); the\n"
          "# Klipper toolhead keys here (max_velocity, max_accel, square_corner_velocity,\n"
          "# minimum_cruise_ratio, max_z_velocity, max_z_accel) are not read for {0}\n",
          to_string(m.firmware));
    }
    for (const KeyDef& d : detail::machine_keys()) {
      if (d.section != section) continue;
      any = true;
      const std::string unit = d.unit.empty() ? std::string() : fmt::format("  # {}", d.unit);
      switch (d.kind) {
        case Kind::number:
          body += fmt::format("{} = {}{}\n", d.key, detail::format_number(d.number(m)), unit);
          break;
        case Kind::optional_number:
          if (d.optional_number(m)) {
            body += fmt::format("{} = {}{}\n", d.key,
                                detail::format_number(*d.optional_number(m)), unit);
          } else if (d.section != "marlin") {  // unset soft endstops: nothing written
            body += unset_comment(d.key, m.firmware);
          }
          break;
        case Kind::integer:
          body += fmt::format("{} = {}{}\n", d.key, d.integer(m), unit);
          break;
        case Kind::axes4: {
          const auto& a = d.axes(m);
          body += fmt::format("{} = [{}, {}, {}, {}]{}  [x, y, z, e]\n", d.key,
                              detail::format_number(a[0]), detail::format_number(a[1]),
                              detail::format_number(a[2]), detail::format_number(a[3]),
                              unit.empty() ? "  #" : unit);
          break;
        }
        case Kind::text:
          body += fmt::format("{} = ", d.key);
          append_toml_string(body, d.text(m));
          body += '\n';
          break;
        case Kind::boolean:
          body += fmt::format("{} = {}\n", d.key, d.boolean(m) ? "true" : "false");
          break;
        case Kind::firmware:
        case Kind::kinematics:
        case Kind::junction:
        case Kind::profile:
          body += fmt::format("{} = \"{}\"\n", d.key,
                              detail::enum_names(d.kind)[static_cast<std::size_t>(
                                  detail::get_enum(m, d.kind))]);
          break;
        case Kind::accel_to_decel:
        case Kind::gear_ratio: break;  // read-only aliases
      }
    }
    // The extruder's and the kinematics' keys of this table (an extruder's unset limit gets
    // the comment the derived defaults get; a kinematics' unset key nothing).
    for (const detail::BoundKey& d : bound) {
      if (d.section != section || !applies(d, "")) continue;
      any = true;
      append_bound(body, d, "", d.extruder ? std::optional(m.firmware) : std::nullopt);
    }
    if (any) out += fmt::format("\n[{}]\n{}", section, body);
  }
  for (auto& [name, s] : m.steppers) {
    out += fmt::format("\n[stepper_{}]\n", name);
    const bool radians = detail::drive_train_unit(m, name) == kinematics::Unit::rad;
    bool kinematics_written = false;
    for (const StepperKeyDef& d : detail::stepper_keys()) {
      // The kinematics' keys of the stepper after its drive train, before the motor physics.
      if (!kinematics_written && d.key == "run_current") {
        kinematics_written = true;
        for (const detail::BoundKey& b : bound) {
          if (b.section == "stepper") append_bound(out, b, name, std::nullopt);
        }
      }
      const std::string unit = d.unit.empty() ? std::string() : fmt::format("  # {}", d.unit);
      if (d.kind == Kind::number) {
        if (d.key == "rotation_distance" && radians) {
          out += fmt::format("{} = {}  # rad\n", d.key,
                             detail::format_number(s.rotation_distance_rad.value_or(0.0)));
        } else {
          out += fmt::format("{} = {}{}\n", d.key, detail::format_number(d.number(s)), unit);
        }
      } else if (d.kind == Kind::integer) {
        out += fmt::format("{} = {}{}\n", d.key, d.integer(s), unit);
      } else if (d.kind == Kind::optional_number && d.optional_number(s)) {
        out += fmt::format("{} = {}{}\n", d.key, detail::format_number(*d.optional_number(s)), unit);
      } else if (d.kind == Kind::text && d.text != nullptr && !d.text(s).empty()) {
        out += fmt::format("{} = ", d.key);
        append_toml_string(out, d.text(s));
        out += '\n';
      }
    }
  }
  // [carriage.NAME] tables.
  for (const detail::BoundKey& d : bound) {
    if (d.section != "carriage" || !d.instances) continue;
    for (const std::string& name : d.instances()) {
      out += fmt::format("\n[carriage.{}]\n", name);
      for (const detail::BoundKey& k : bound) {
        if (k.section != "carriage") continue;
        // homing_speed at Klipper's default is left out.
        if (k.key == "homing_speed" && k.number && *k.number(name, false) == 5.0) continue;
        append_bound(out, k, name, std::nullopt);
      }
    }
    break;
  }
  return out;
}

}  // namespace amctl::machine
