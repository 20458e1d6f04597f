// Validation of a Machine, in one place: every bound of the key table (schema.cpp) and the
// cross-key rules. The loader calls it after reading and overrides; the planner calls it on
// the Machine it is given (a Machine built in code never went through the loader), so no
// other module repeats a check. Also the key listing of `amctl machine keys`.
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/quantity.hpp"
#include "amctl/machine/delta.hpp"
#include "amctl/machine/linkage.hpp"
#include "amctl/machine/loader.hpp"
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
    const bool generic_name = m.kinematics == Kinematics::generic_cartesian &&
                              detail::generic_stepper_name(name) && !s.carriages.empty();
    if (!detail::valid_stepper_name(name) && !generic_name) {
      throw Error(fmt::format("stepper '{}': expected a name like x, y, z, e, z1{}", name,
                              m.kinematics == Kinematics::generic_cartesian
                                  ? " (or any name with carriages, on a generic_cartesian)"
                                  : ""));
    }
    for (const StepperKeyDef& d : detail::stepper_keys()) {
      const std::string label = fmt::format("stepper_{}.{}", name, d.key);
      if (d.kind == Kind::number) check_bound(d.bound, d.number(s), {}, label, d.unit);
      if (d.kind == Kind::integer) check_bound(d.bound, d.integer(s), {}, label, d.unit);
      if (d.kind == Kind::optional_number && d.optional_number(s)) {
        check_bound(d.bound, *d.optional_number(s), {}, label, d.unit);
      }
    }
    if (s.position_min_mm && s.position_max_mm && *s.position_min_mm > *s.position_max_mm) {
      throw Error(fmt::format("stepper_{}.position_min ({} mm) must be <= position_max ({} mm)",
                              name, *s.position_min_mm, *s.position_max_mm));
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
  if (m.arcs.min_arc_segment_mm > 0.0 && m.arcs.max_arc_segment_mm > 0.0 &&
      m.arcs.min_arc_segment_mm > m.arcs.max_arc_segment_mm) {
    throw Error(fmt::format("arcs.min_segment ({} mm) must be <= arcs.max_segment ({} mm)",
                            m.arcs.min_arc_segment_mm, m.arcs.max_arc_segment_mm));
  }
  if (const DualCarriage& dc = m.dual_carriage; dc.present()) {
    if (dc.axis != "x" && dc.axis != "y") {
      throw Error(fmt::format("dual_carriage.axis must be \"x\", \"y\" or \"\" (none), got \"{}\"", dc.axis));
    }
    if (m.kinematics != Kinematics::cartesian && m.kinematics != Kinematics::hybrid_corexy &&
        m.kinematics != Kinematics::hybrid_corexz) {
      throw Error("dual_carriage: Klipper supports a dual carriage on cartesian, hybrid_corexy "
                  "and hybrid_corexz kinematics only");
    }
    if (!dc.position_max_mm || !dc.position_endstop_mm) {
      throw Error("dual_carriage: position_max and position_endstop are required with an axis");
    }
    const auto first = m.steppers.find(dc.axis);
    if (first == m.steppers.end() || !first->second.position_endstop_mm || !first->second.position_max_mm) {
      throw Error(fmt::format("dual_carriage: stepper_{} (the first carriage's rail) needs "
                              "position_endstop and position_max",
                              dc.axis));
    }
    const double lo = dc.position_min_mm.value_or(0.0);
    if (lo >= *dc.position_max_mm) {
      throw Error(fmt::format("dual_carriage.position_min ({} mm) must be < position_max ({} mm)", lo,
                              *dc.position_max_mm));
    }
    if (*dc.position_endstop_mm < lo || *dc.position_endstop_mm > *dc.position_max_mm) {
      throw Error(fmt::format("dual_carriage.position_endstop ({} mm) must lie in [position_min, "
                              "position_max] = [{}, {}] mm",
                              *dc.position_endstop_mm, lo, *dc.position_max_mm));
    }
  }
  // A delta's geometry must be complete and consistent (rods longer than the radius, ...).
  if (m.kinematics == Kinematics::delta) (void)delta_geometry(m);
  if (m.kinematics == Kinematics::deltesian) (void)deltesian_geometry(m);
  if (m.kinematics == Kinematics::generic_cartesian) (void)generic_cartesian_geometry(m);
  if (m.kinematics == Kinematics::polar) (void)polar_geometry(m);
  if (m.kinematics == Kinematics::rotary_delta) (void)rotary_delta_geometry(m);
  if (m.kinematics != Kinematics::generic_cartesian && !m.carriages.empty()) {
    throw Error(fmt::format("[carriage.{}] is a generic_cartesian section, expected none for "
                            "kinematics {}",
                            m.carriages.begin()->first, to_string(m.kinematics)));
  }
  if (m.kinematics == Kinematics::winch) {
    for (const char* cable : {"a", "b", "c", "d"}) {
      const auto it = m.steppers.find(cable);
      if (it == m.steppers.end()) {
        if (cable[0] == 'd') break;
        throw Error(fmt::format("a winch needs stepper_a, stepper_b and stepper_c; stepper_{} is "
                                "missing",
                                cable));
      }
      const Stepper& s = it->second;
      if (!s.anchor_x_mm || !s.anchor_y_mm || !s.anchor_z_mm) {
        throw Error(fmt::format("stepper_{}: a winch cable needs anchor_x, anchor_y and anchor_z",
                                cable));
      }
    }
  }
}

std::vector<KeyInfo> schema() {
  std::vector<KeyInfo> out;
  for (const KeyDef& d : detail::machine_keys()) {
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
  }
  for (const StepperKeyDef& d : detail::stepper_keys()) {
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
