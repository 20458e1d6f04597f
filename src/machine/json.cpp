#include "amctl/machine/json.hpp"
#include <algorithm>

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/quantity.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/machine/effective.hpp"
#include "amctl/machine/loader.hpp"
#include "kinematics_keys.hpp"

namespace amctl::machine {
namespace {

Json optional_number(const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); }

Json axes(const std::array<double, 4>& a) { return Json::array({a[0], a[1], a[2], a[3]}); }

}  // namespace

Json to_json(const Machine& m) {
  Json j;
  j["printer"] = {
      {"name", m.name},
      {"firmware", to_string(m.firmware)},
      {"kinematics", kinematics::name_of(m.kinematics)},
      {"junction", to_string(m.junction)},
      {"profile", to_string(m.profile)},
      {"max_velocity", m.max_velocity_mm_s},
      {"max_accel", m.max_accel_mm_s2},
      {"square_corner_velocity", m.square_corner_velocity_mm_s},
      {"minimum_cruise_ratio", m.minimum_cruise_ratio},
      {"max_z_velocity", m.max_z_velocity_mm_s},
      {"max_z_accel", m.max_z_accel_mm_s2},
      {"max_jerk", m.max_jerk_mm_s3},
  };
  j["marlin"] = {
      {"max_feedrate", axes(m.max_feedrate_mm_s)},
      {"max_accel", axes(m.max_axis_accel_mm_s2)},
      {"print_accel", m.print_accel_mm_s2},
      {"retract_accel", m.retract_accel_mm_s2},
      {"travel_accel", m.travel_accel_mm_s2},
      {"jerk", axes(m.jerk_mm_s)},
      {"junction_deviation", m.junction_deviation_mm},
      {"min_feedrate", m.min_feedrate_mm_s},
      {"min_travel_feedrate", m.min_travel_feedrate_mm_s},
      {"min_segment_time", m.min_segment_time_s},
      {"block_buffer_size", m.block_buffer_size},
  };
  for (std::size_t i = 0; i < 3; ++i) {  // soft endstops: only when set
    if (m.soft_min_position_mm[i]) j["marlin"][fmt::format("min_position_{}", "xyz"[i])] = *m.soft_min_position_mm[i];
    if (m.soft_max_position_mm[i]) j["marlin"][fmt::format("max_position_{}", "xyz"[i])] = *m.soft_max_position_mm[i];
  }
  j["extruder"] = {
      {"nozzle_diameter", m.extruder.nozzle_diameter_mm},
      {"filament_diameter", m.extruder.filament_diameter_mm},
      {"max_extrude_only_velocity", optional_number(m.extruder.max_extrude_only_velocity_mm_s)},
      {"max_extrude_only_accel", optional_number(m.extruder.max_extrude_only_accel_mm_s2)},
      {"max_extrude_only_distance", m.extruder.max_extrude_only_distance_mm},
      {"instantaneous_corner_velocity", m.extruder.instantaneous_corner_velocity_mm_s},
      {"max_extrude_cross_section", optional_number(m.extruder.max_extrude_cross_section_mm2)},
  };
  // Only when they say something: machines without them print as before.
  if (!m.extruder.present) j["extruder"]["present"] = false;
  if (m.extruder.pressure_advance_s != 0.0 ||
      m.extruder.pressure_advance_smooth_time_s != kinematics::Extruder{}.pressure_advance_smooth_time_s) {
    j["extruder"]["pressure_advance"] = m.extruder.pressure_advance_s;
    j["extruder"]["pressure_advance_smooth_time"] = m.extruder.pressure_advance_smooth_time_s;
  }
  j["arcs"] = {
      {"enabled", m.arcs.enabled},
      {"resolution", m.arcs.mm_per_arc_segment},
      {"min_segment", m.arcs.min_arc_segment_mm},
      {"max_segment", m.arcs.max_arc_segment_mm},
      {"min_circle_segments", m.arcs.min_circle_segments},
      {"segments_per_second", m.arcs.segments_per_second},
  };
  j["firmware_retraction"] = {
      {"retract_length", m.firmware_retraction.retract_length_mm},
      {"retract_speed", m.firmware_retraction.retract_speed_mm_s},
      {"unretract_extra_length", m.firmware_retraction.unretract_extra_length_mm},
      {"unretract_speed", m.firmware_retraction.unretract_speed_mm_s},
      {"lift_z", m.firmware_retraction.lift_z_mm},
  };
  if (!(m.input_shaper == InputShaper{})) {  // only when configured: the default is off
    j["input_shaper"] = {
        {"shaper_type_x", m.input_shaper.shaper_type_x},
        {"shaper_type_y", m.input_shaper.shaper_type_y},
        {"shaper_freq_x", m.input_shaper.shaper_freq_x_hz},
        {"shaper_freq_y", m.input_shaper.shaper_freq_y_hz},
        {"damping_ratio_x", m.input_shaper.damping_ratio_x},
        {"damping_ratio_y", m.input_shaper.damping_ratio_y},
    };
  }
  Json steppers = Json::object();
  Machine copy = m;  // the key tables' accessors take a mutable machine
  const std::vector<detail::BoundKey> bound = detail::bound_keys(copy);
  for (const auto& [name, s] : m.steppers) {
    if (detail::drive_train_unit(m, name) == kinematics::Unit::rad) {
      const double rd = s.rotation_distance_rad.value_or(0.0);
      steppers[name] = {{"rotation_distance", rd},
                        {"microsteps", s.microsteps},
                        {"full_steps_per_rotation", s.full_steps_per_rotation},
                        {"steps_per_rad", s.microsteps * s.full_steps_per_rotation / rd}};
    } else {
      steppers[name] = {{"rotation_distance", s.rotation_distance_mm},
                        {"microsteps", s.microsteps},
                        {"full_steps_per_rotation", s.full_steps_per_rotation},
                        {"steps_per_mm", s.steps_per_mm()}};
    }
    // The kinematics' keys of this stepper, only when set: machines without them print as
    // before.
    for (const detail::BoundKey& b : bound) {
      if (b.section != "stepper") continue;
      if (b.optional_number) {
        if (const auto* v = b.optional_number(name, false); v && *v) steppers[name][std::string(b.key)] = **v;
      } else if (b.text) {
        if (const auto* v = b.text(name, false); v && !v->empty()) steppers[name][std::string(b.key)] = *v;
      }
    }
    if (!s.motor.empty()) steppers[name]["motor"] = s.motor;
    // Motor, driver and drive-train keys (step-level physics), only when set.
    const std::pair<const char*, const std::optional<double>*> motor[] = {
        {"run_current", &s.run_current_a},       {"supply_voltage", &s.supply_voltage_v},
        {"holding_torque", &s.holding_torque_n_m}, {"rated_current", &s.rated_current_a},
        {"phase_resistance", &s.phase_resistance_ohm}, {"phase_inductance", &s.phase_inductance_h},
        {"rotor_inertia", &s.rotor_inertia_kg_m2}, {"detent_torque", &s.detent_torque_n_m},
        {"backlash", &s.backlash_mm}};
    for (const auto& [key, v] : motor) {
      if (*v) steppers[name][key] = **v;
    }
  }
  j["steppers"] = steppers;
  make_kinematics(m)->describe(j);
  if (m.firmware == Firmware::klipper) {
    j["effective"] = {
        {"limits_of", "klipper"},
        {"max_z_velocity", effective_max_z_velocity_mm_s(m)},
        {"max_z_accel", effective_max_z_accel_mm_s2(m)},
        {"max_extrude_only_velocity", effective_max_extrude_only_velocity_mm_s(m)},
        {"max_extrude_only_accel", effective_max_extrude_only_accel_mm_s2(m)},
        {"max_extrude_cross_section", effective_max_extrude_cross_section_mm2(m)},
        {"junction_deviation_at_max_accel",
         klipper_junction_deviation_mm(m.square_corner_velocity_mm_s, m.max_accel_mm_s2)},
    };
  } else {
    // Marlin and RepRapFirmware plan with their own limits: per-axis feed rates and
    // accelerations (M203/M201), the retract acceleration for extrude-only moves (M204 R, within
    // the E axis' M201), and the junction policy's own parameter; they do not check the
    // extrusion cross-section. The same keys, the firmware's values (null where none applies).
    j["effective"] = {
        {"limits_of", std::string(to_string(m.firmware))},
        {"max_z_velocity", m.max_feedrate_mm_s[2]},
        {"max_z_accel", m.max_axis_accel_mm_s2[2]},
        {"max_extrude_only_velocity", m.max_feedrate_mm_s[3]},
        {"max_extrude_only_accel", std::min(m.retract_accel_mm_s2, m.max_axis_accel_mm_s2[3])},
        {"max_extrude_cross_section", nullptr},
        {"junction_deviation_at_max_accel",
         m.junction == JunctionPolicy::junction_deviation ? Json(m.junction_deviation_mm) : Json(nullptr)},
    };
  }
  return j;
}


Json schema_json() {
  Json arr = Json::array();
  for (const auto& k : schema()) {
    Json key{{"section", k.section}, {"key", k.key}, {"type", k.type},
             {"unit", k.unit}, {"description", k.description}};
    // The physical range of the unit (core/quantity.hpp), where the key has one.
    if (const auto r = range_for_unit(k.unit)) key["range"] = Json::array({r->min, r->max});
    arr.push_back(std::move(key));
  }
  return Json{{"keys", arr}};
}

}  // namespace amctl::machine
