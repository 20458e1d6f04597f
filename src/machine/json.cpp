#include "amctl/machine/json.hpp"
#include <algorithm>

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/quantity.hpp"
#include "amctl/machine/delta.hpp"
#include "amctl/machine/linkage.hpp"
#include "amctl/machine/effective.hpp"
#include "amctl/machine/loader.hpp"

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
      {"kinematics", to_string(m.kinematics)},
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
  for (const auto& [name, s] : m.steppers) {
    steppers[name] = {{"rotation_distance", s.rotation_distance_mm},
                      {"microsteps", s.microsteps},
                      {"full_steps_per_rotation", s.full_steps_per_rotation},
                      {"steps_per_mm", s.steps_per_mm()}};
    // Range keys only when set: machines without them print as before.
    if (s.position_min_mm) steppers[name]["position_min"] = *s.position_min_mm;
    if (s.position_max_mm) steppers[name]["position_max"] = *s.position_max_mm;
    if (s.position_endstop_mm) steppers[name]["position_endstop"] = *s.position_endstop_mm;
    if (s.arm_length_mm) steppers[name]["arm_length"] = *s.arm_length_mm;
    if (s.angle_deg) steppers[name]["angle"] = *s.angle_deg;
    if (s.anchor_x_mm) steppers[name]["anchor_x"] = *s.anchor_x_mm;
    if (s.anchor_y_mm) steppers[name]["anchor_y"] = *s.anchor_y_mm;
    if (s.anchor_z_mm) steppers[name]["anchor_z"] = *s.anchor_z_mm;
    if (s.upper_arm_length_mm) steppers[name]["upper_arm_length"] = *s.upper_arm_length_mm;
    if (s.lower_arm_length_mm) steppers[name]["lower_arm_length"] = *s.lower_arm_length_mm;
    if (!s.carriages.empty()) steppers[name]["carriages"] = s.carriages;
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
  if (m.kinematics == Kinematics::generic_cartesian) {
    // The carriages as given, and each stepper's row over X, Y, Z (dual carriages parked).
    Json carriages = Json::object();
    static constexpr const char* kTypes[] = {"carriage", "extra_carriage", "dual_carriage"};
    for (const auto& [name, c] : m.carriages) {
      Json cj = {{"type", kTypes[static_cast<std::size_t>(c.type)]}};
      if (!c.axis.empty()) cj["axis"] = c.axis;
      if (!c.primary_carriage.empty()) cj["primary_carriage"] = c.primary_carriage;
      if (c.position_min_mm) cj["position_min"] = *c.position_min_mm;
      if (c.position_max_mm) cj["position_max"] = *c.position_max_mm;
      if (c.position_endstop_mm) cj["position_endstop"] = *c.position_endstop_mm;
      carriages[name] = cj;
    }
    j["carriages"] = carriages;
    Json rows = Json::object();
    for (const GenericStepper& gs : generic_cartesian_geometry(m).steppers) {
      rows[gs.name] = {gs.coeffs[0], gs.coeffs[1], gs.coeffs[2]};
    }
    j["stepper_rows_xyz"] = rows;
  }
  if (m.kinematics == Kinematics::rotary_delta) {
    const RotaryDeltaGeometry g = rotary_delta_geometry(m);
    j["rotary_delta"] = {{"shoulder_radius", g.shoulder_radius_mm},
                         {"shoulder_height", g.shoulder_height_mm},
                         {"build_radius", std::sqrt(g.max_xy2_mm2)},
                         {"max_z", g.max_z_mm},
                         {"min_z", g.min_z_mm},
                         {"taper_start_z", g.limit_z_mm},
                         {"home_position", {g.home_position_mm[0], g.home_position_mm[1],
                                            g.home_position_mm[2]}}};
  }
  if (m.max_angular_velocity_rad_s) j["printer"]["max_angular_velocity"] = *m.max_angular_velocity_rad_s;
  if (m.kinematics == Kinematics::delta) {
    // The keys as given, and what Klipper derives from them (machine/delta.hpp).
    const DeltaGeometry g = delta_geometry(m);
    j["delta"] = {{"radius", g.radius_mm},
                  {"print_radius", optional_number(m.delta.print_radius_mm)},
                  {"minimum_z_position", optional_number(m.delta.minimum_z_position_mm)},
                  {"build_radius", std::sqrt(g.max_xy2_mm2)},
                  {"slow_radius", std::sqrt(g.slow_xy2_mm2)},
                  {"very_slow_radius", std::sqrt(g.very_slow_xy2_mm2)},
                  {"max_z", g.max_z_mm},
                  {"cone_start_z", g.limit_z_mm}};
  }
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
