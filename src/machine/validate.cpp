// Validation of a Machine, in one place: every bound of the key table (schema.cpp) and the
// cross-key rules. The loader calls it after reading and overrides; the planner calls it on
// the Machine it is given (a Machine built in code never went through the loader), so no
// other module repeats a check. Also the key listing of `amctl machine keys`.
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/quantity.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/machine/loader.hpp"
#include "kinematics_keys.hpp"
#include "schema.hpp"

namespace amctl::machine {

namespace detail {

void check_bound(Bound b, double v, const SourceLocation& where, std::string_view label,
                 std::string_view unit) {
  if (!within(b, v)) {
    throw Error(where, fmt::format("{} must be a finite number {}{}, got {}", label,
                                   bound_text(b), unit.empty() ? std::string() : fmt::format(" {}", unit), v));
  }
  // A positive speed, acceleration, jerk or length must also be one a machine can have
  // (core/quantity.hpp): 1e-300 passes "> 0" but makes every move take for ever.
  if ((b == Bound::positive || b == Bound::non_negative) && v != 0.0) {
    if (const auto r = range_for_unit(unit); r && !in_range(*r, v)) {
      throw Error(where, fmt::format("{} must be {}{}, got {}", label, describe(*r),
                                     b == Bound::non_negative ? " (or 0)" : "", v));
    }
  }
}

}  // namespace detail

namespace {

using detail::Kind;
using detail::KeyDef;
using detail::StepperKeyDef;
using detail::check_bound;

void check_bounds_for_validate(Machine& m) {
  for (const KeyDef& d : detail::machine_keys()) {
    const std::string label = fmt::format("{}.{}", d.section, d.key);
    const SourceLocation none;
    switch (d.kind) {
      case Kind::number: check_bound(d.bound, d.number(m), none, label, d.unit); break;
      case Kind::optional_number:
        if (d.optional_number(m)) check_bound(d.bound, *d.optional_number(m), none, label, d.unit);
        break;
      case Kind::integer:
        check_bound(d.bound, d.integer(m), none, label, d.unit);
        break;
      case Kind::axes4: {
        static constexpr const char* kAxis[] = {"x", "y", "z", "e"};
        for (std::size_t i = 0; i < 4; ++i) {
          check_bound(d.bound, d.axes(m)[i], none, fmt::format("{}.{}", label, kAxis[i]), d.unit);
        }
        break;
      }
      default: break;
    }
  }
  for (auto& [name, s] : m.steppers) {
    if (!detail::valid_stepper_name(name) && !detail::owned_stepper(m, name)) {
      throw Error(fmt::format("stepper '{}': expected a name like x, y, z, e, z1 or a motor of the "
                              "{} kinematics",
                              name, kinematics::name_of(m.kinematics)));
    }
    for (const StepperKeyDef& d : detail::stepper_keys()) {
      const std::string label = fmt::format("stepper_{}.{}", name, d.key);
      if (d.kind == Kind::number) check_bound(d.bound, d.number(s), {}, label, d.unit);
      if (d.kind == Kind::integer) check_bound(d.bound, d.integer(s), {}, label, d.unit);
      if (d.kind == Kind::optional_number && d.optional_number(s)) {
        check_bound(d.bound, *d.optional_number(s), {}, label, d.unit);
      }
    }
    const bool radians = detail::drive_train_unit(m, name) == kinematics::Unit::rad;
    if (radians != s.rotation_distance_rad.has_value()) {
      throw Error(fmt::format("stepper_{}.rotation_distance: {}", name,
                              radians ? "the motor turns (its unit is the radian), expected its "
                                        "turn per motor revolution in radians"
                                      : "given in radians for a motor that moves a carriage, "
                                        "expected mm"));
    }
    if (radians) check_bound(detail::Bound::positive, *s.rotation_distance_rad, {}, fmt::format("stepper_{}.rotation_distance", name), "rad");
  }
  // The keys the extruder and the kinematics own: their bounds.
  for (const detail::BoundKey& b : detail::bound_keys(m)) {
    auto check = [&](std::string_view instance, const std::string& label) {
      if (b.number) {
        if (const double* v = b.number(instance, false)) check_bound(b.bound, *v, {}, label, b.unit);
      } else if (b.optional_number) {
        if (const auto* v = b.optional_number(instance, false); v && *v) check_bound(b.bound, **v, {}, label, b.unit);
      }
    };
    if (b.section == "stepper") {
      for (const auto& [name, s] : m.steppers) check(name, fmt::format("stepper_{}.{}", name, b.key));
    } else if (b.section == "carriage") {
      if (b.instances) {
        for (const std::string& c : b.instances()) check(c, fmt::format("carriage.{}.{}", c, b.key));
      }
    } else {
      check("", fmt::format("{}.{}", b.section, b.key));
    }
  }
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& lo = m.soft_min_position_mm[i];
    const auto& hi = m.soft_max_position_mm[i];
    if (lo && hi && *lo > *hi) {
      throw Error(fmt::format("marlin.min_position_{0} ({1} mm) must be <= marlin.max_position_{0} ({2} mm)",
                              "xyz"[i], *lo, *hi));
    }
  }
}

}  // namespace

void validate(const Machine& machine) {
  Machine m = machine;
  check_bounds_for_validate(m);
  if (m.extruder.filament_diameter_mm < m.extruder.nozzle_diameter_mm) {
    throw Error(fmt::format("extruder.filament_diameter ({} mm) must be >= "
                            "extruder.nozzle_diameter ({} mm)",
                            m.extruder.filament_diameter_mm, m.extruder.nozzle_diameter_mm));
  }
  m.extruder.check();
  if (m.arcs.min_arc_segment_mm > 0.0 && m.arcs.max_arc_segment_mm > 0.0 &&
      m.arcs.min_arc_segment_mm > m.arcs.max_arc_segment_mm) {
    throw Error(fmt::format("arcs.min_segment ({} mm) must be <= arcs.max_segment ({} mm)",
                            m.arcs.min_arc_segment_mm, m.arcs.max_arc_segment_mm));
  }
  // The kinematics must be complete and consistent (a delta's rods longer than its radius, a
  // generic_cartesian's steppers moving X, Y and Z, ...): built, and its motors allocated.
  {
    const auto kin = make_kinematics(m);
    std::vector<std::string> keys, missing;
    for (const auto& [k, s] : m.steppers) keys.push_back(k);
    (void)kin->motors(keys, missing);
  }
}

std::vector<KeyInfo> schema() {
  std::vector<KeyInfo> out;
  const std::vector<detail::BoundKey> owned = detail::all_kinematics_keys();
  auto bound_type = [](const detail::BoundKey& b) -> std::string {
    switch (b.kind) {
      case detail::BoundKey::Kind::number: return "number";
      case detail::BoundKey::Kind::optional_number: return "number (optional)";
      case detail::BoundKey::Kind::text:
      case detail::BoundKey::Kind::choice: return "text";
      case detail::BoundKey::Kind::boolean: return "true | false";
    }
    return "text";
  };
  auto add_owned = [&](std::string_view section, auto&& keep) {
    for (const detail::BoundKey& b : owned) {
      if (b.section != section || !keep(b)) continue;
      out.push_back({section == "stepper" ? "stepper_*" : section == "carriage" ? "carriage.*" : std::string(section), std::string(b.key),
                     bound_type(b), std::string(b.unit), std::string(b.description)});
    }
  };
  auto any = [](const detail::BoundKey&) { return true; };
  bool extruder_listed = false, marlin_seen = false;
  for (const KeyDef& d : detail::machine_keys()) {
    // The extruder's keys where the [extruder] table stands in the file, after [marlin].
    marlin_seen = marlin_seen || d.section == "marlin";
    if (!extruder_listed && marlin_seen && d.section != "marlin") {
      extruder_listed = true;
      add_owned("extruder", any);
    }
    std::string type;
    switch (d.kind) {
      case Kind::number:
      case Kind::accel_to_decel: type = "number"; break;
      case Kind::optional_number: type = "number (optional)"; break;
      case Kind::integer: type = "integer"; break;
      case Kind::axes4: type = "[x, y, z, e]"; break;
      case Kind::text: type = "text"; break;
      case Kind::boolean: type = "true | false"; break;
      default: {
        const auto names = detail::enum_names(d.kind);
        type = fmt::format("{}", fmt::join(names, " | "));
      }
    }
    out.push_back({std::string(d.section), std::string(d.key), type, std::string(d.unit),
                   std::string(d.description)});
    // The kinematics' [printer] keys after the toolhead's Z limits.
    if (d.section == "printer" && d.key == "max_z_accel") add_owned("printer", any);
  }
  add_owned("dual_carriage", any);
  add_owned("delta", any);
  add_owned("carriage", any);
  // Drive train, the kinematics' stepper keys, the motor physics.
  bool kinematics_listed = false;
  for (const StepperKeyDef& d : detail::stepper_keys()) {
    if (!kinematics_listed && d.key == "run_current") {
      kinematics_listed = true;
      add_owned("stepper", any);
    }
    out.push_back({"stepper_*", std::string(d.key),
                   d.kind == Kind::integer      ? "integer"
                   : d.kind == Kind::gear_ratio ? "text or number"
                   : d.kind == Kind::optional_number ? "number (optional)"
                                                : "number",
                   std::string(d.unit), std::string(d.description)});
  }
  return out;
}

}  // namespace amctl::machine
