// The extruder: [extruder] with Klipper's checks (extruder.py), the limits of its check_move,
// its motor.
#include "amctl/kinematics/extruder.hpp"

#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/process_ranges.hpp"

namespace amctl::kinematics {

Extruder Extruder::from_klipper(const KlipperConfig& cfg) {
  Extruder e;
  const KlipperSection ex = cfg.section("extruder");
  if (!ex.present()) {
    e.present = false;
    return e;
  }
  e.nozzle_diameter_mm = ex.require_float("nozzle_diameter", {.above = 0.0, .physical = kLengthRange});
  e.filament_diameter_mm = ex.require_float("filament_diameter", {.minval = e.nozzle_diameter_mm});
  e.max_extrude_cross_section_mm2 = ex.get_float("max_extrude_cross_section", {.above = 0.0});
  e.max_extrude_only_velocity_mm_s = ex.get_float("max_extrude_only_velocity", {.above = 0.0, .physical = kSpeedRange});
  e.max_extrude_only_accel_mm_s2 =
      ex.get_float("max_extrude_only_accel", {.above = 0.0, .physical = kAccelRange});
  e.max_extrude_only_distance_mm = ex.get_float("max_extrude_only_distance", 50.0, {.minval = 0.0});
  e.instantaneous_corner_velocity_mm_s =
      ex.get_float("instantaneous_corner_velocity", 1.0, {.minval = 0.0});
  // ExtruderStepper (extruder.py): pressure_advance (0, >= 0), pressure_advance_smooth_time
  // (0.040, (0, 0.2]); read only with a stepper, as Klipper does.
  if (ex.has("step_pin") || ex.has("dir_pin") || ex.has("rotation_distance")) {
    e.pressure_advance_s = ex.get_float("pressure_advance", 0.0, {.minval = 0.0, .maxval = kPressureAdvanceRange.max});
    e.pressure_advance_smooth_time_s = ex.get_float(
        "pressure_advance_smooth_time", 0.040, {.maxval = kMaxPressureAdvanceSmoothTimeS, .above = 0.0});
  }
  return e;
}

std::span<const ParamKey<Extruder>> Extruder::keys() {
  using E = Extruder;
  using Opt = std::optional<double>;
  static const std::vector<ParamKey<E>> keys = {
      {"extruder", "present", KeyBound::finite, "",
       "false: the printer has no extruder (a Klipper printer.cfg without [extruder]); a move "
       "that extrudes is then an error, as in Klipper. Written only when false.",
       nullptr, nullptr, nullptr, {}, nullptr, nullptr, nullptr,
       [](E& e, std::string_view, bool) -> bool* { return &e.present; }},
      {"extruder", "nozzle_diameter", KeyBound::positive, "mm", "Nozzle orifice diameter.", nullptr,
       [](E& e, std::string_view, bool) -> double* { return &e.nozzle_diameter_mm; }},
      {"extruder", "filament_diameter", KeyBound::positive, "mm",
       "Nominal filament diameter (>= nozzle_diameter).", nullptr,
       [](E& e, std::string_view, bool) -> double* { return &e.filament_diameter_mm; }},
      {"extruder", "max_extrude_only_velocity", KeyBound::positive, "mm/s",
       "Klipper: speed limit of retracts and extrude-only moves (filament mm/s). Unset = "
       "max_velocity * 4 nozzle_diameter^2 / filament_area.",
       [](E& e, std::string_view, bool) -> Opt* { return &e.max_extrude_only_velocity_mm_s; }},
      {"extruder", "max_extrude_only_accel", KeyBound::positive, "mm/s^2",
       "Klipper: acceleration of retracts and extrude-only moves. Unset = max_accel * 4 "
       "nozzle_diameter^2 / filament_area.",
       [](E& e, std::string_view, bool) -> Opt* { return &e.max_extrude_only_accel_mm_s2; }},
      {"extruder", "max_extrude_only_distance", KeyBound::non_negative, "mm",
       "Klipper: longest allowed extrude-only move (filament mm).", nullptr,
       [](E& e, std::string_view, bool) -> double* { return &e.max_extrude_only_distance_mm; }},
      {"extruder", "instantaneous_corner_velocity", KeyBound::non_negative, "mm/s",
       "Klipper: largest instantaneous extruder speed change at a junction.", nullptr,
       [](E& e, std::string_view, bool) -> double* { return &e.instantaneous_corner_velocity_mm_s; }},
      {"extruder", "max_extrude_cross_section", KeyBound::positive, "mm^2",
       "Klipper: largest extrusion cross-section (width x height). Unset = 4 "
       "nozzle_diameter^2.",
       [](E& e, std::string_view, bool) -> Opt* { return &e.max_extrude_cross_section_mm2; }},
      {"extruder", "pressure_advance", KeyBound::non_negative, "s",
       "Klipper pressure_advance: the extruder motor runs ahead of the filament position by this "
       "times the extrusion speed (mm of filament per mm/s), on moves that extrude in X or Y; "
       "0 = off (SET_PRESSURE_ADVANCE ADVANCE=). Step generation only (amctl steps).",
       nullptr, [](E& e, std::string_view, bool) -> double* { return &e.pressure_advance_s; },
       nullptr, {}, nullptr, nullptr, nullptr, nullptr, 0.0},
      {"extruder", "pressure_advance_smooth_time", KeyBound::positive, "s",
       "Klipper pressure_advance_smooth_time: the window of the triangular average of the "
       "advanced position, at most 0.2 s (SET_PRESSURE_ADVANCE SMOOTH_TIME=).",
       nullptr, [](E& e, std::string_view, bool) -> double* { return &e.pressure_advance_smooth_time_s; },
       nullptr, {}, nullptr, nullptr, nullptr, nullptr, 0.040},
  };
  return keys;
}

void Extruder::check() const {
  if (!(pressure_advance_smooth_time_s <= kMaxPressureAdvanceSmoothTimeS)) {
    throw Error(fmt::format("extruder.pressure_advance_smooth_time must be at most {} s (Klipper's "
                            "limit), got {}",
                            kMaxPressureAdvanceSmoothTimeS, pressure_advance_smooth_time_s));
  }
  if (!in_range(kPressureAdvanceRange, pressure_advance_s)) {
    throw Error(fmt::format("extruder.pressure_advance must be {}, got {}", describe(kPressureAdvanceRange),
                            pressure_advance_s));
  }
}

ExtruderLimits extruder_limits(const Extruder& ex, const Toolhead& th) {
  ExtruderLimits l;
  l.filament_area_mm2 = std::numbers::pi * 0.25 * ex.filament_diameter_mm * ex.filament_diameter_mm;
  const double def_ratio = 4.0 * ex.nozzle_diameter_mm * ex.nozzle_diameter_mm / l.filament_area_mm2;
  l.extrude_only_velocity_mm_s = ex.max_extrude_only_velocity_mm_s.value_or(th.max_velocity_mm_s * def_ratio);
  l.extrude_only_accel_mm_s2 = ex.max_extrude_only_accel_mm_s2.value_or(th.max_accel_mm_s2 * def_ratio);
  l.max_cross_section_mm2 =
      ex.max_extrude_cross_section_mm2.value_or(4.0 * ex.nozzle_diameter_mm * ex.nozzle_diameter_mm);
  l.max_extrude_ratio = l.max_cross_section_mm2 / l.filament_area_mm2;
  return l;
}

Motor extruder_motor() {
  Motor e;
  e.name = "extruder";
  e.key = "e";
  e.row = {0, 0, 0, 1};
  return e;
}

}  // namespace amctl::kinematics
