// The pieces the cartesian-like kinematics share (cartesian.py, corexy.py, corexz.py,
// hybrid_corexy.py, hybrid_corexz.py all build their rails with stepper.py's PrinterRail).
#include "amctl/kinematics/rails.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::kinematics::detail {

MoveRules cartesian_move_rules(const Rails& rails, const Toolhead& th) {
  MoveRules r;
  r.z_velocity_mm_s = th.max_z_velocity_mm_s > 0 ? th.max_z_velocity_mm_s : th.max_velocity_mm_s;
  r.z_accel_mm_s2 = th.max_z_accel_mm_s2 > 0 ? th.max_z_accel_mm_s2 : th.max_accel_mm_s2;
  for (std::size_t i = 0; i < 3; ++i) {
    const auto it = rails.find(std::string(1, "xyz"[i]));
    if (it != rails.end() && it->second.position_min_mm && it->second.position_max_mm) {
      r.range_min_mm[i] = it->second.position_min_mm;
      r.range_max_mm[i] = it->second.position_max_mm;
    }
  }
  return r;
}

Homing cartesian_homing(const Rails& rails) {
  // Klipper's homing (homing.py home_rails via cartesian.py, corexy.py, ...): a homed axis
  // ends at its rail's position_endstop, in toolhead coordinates on every one of these.
  Homing h;
  h.klipper_only = true;
  for (std::size_t a = 0; a < 3; ++a) {
    const auto it = rails.find(std::string(1, "xyz"[a]));
    if (it != rails.end() && it->second.position_endstop_mm) {
      h.position_mm[a] = *it->second.position_endstop_mm;
    }
  }
  return h;
}

IdexPair idex_pair(const Rails& rails, const DualCarriage& dc) {
  IdexPair d;
  d.axis = dc.axis == "y" ? 1 : 0;
  const auto it = rails.find(dc.axis);
  if (it == rails.end() || !it->second.position_max_mm || !it->second.position_endstop_mm) {
    throw Error(fmt::format("dual_carriage: stepper_{} needs position_endstop and position_max "
                            "(the first carriage's rail)",
                            dc.axis));
  }
  const Rail& first = it->second;
  d.position_min_mm = {first.position_min_mm.value_or(0.0), dc.position_min_mm.value_or(0.0)};
  d.position_max_mm = {*first.position_max_mm, *dc.position_max_mm};
  d.position_endstop_mm = {*first.position_endstop_mm, *dc.position_endstop_mm};
  d.safe_distance_mm = dc.safe_distance_mm;
  d.homing_speed_mm_s = {dc.primary_homing_speed_mm_s, dc.homing_speed_mm_s};
  return d;
}

std::vector<Motor> cartesian_motors(const std::vector<std::string>& keys,
                                    const std::array<double, 4>& row_x,
                                    const std::array<double, 4>& row_y,
                                    const std::array<double, 4>& row_z,
                                    std::vector<std::string>& missing) {
  std::vector<Motor> out;
  const std::array<double, 4>* rows[3] = {&row_x, &row_y, &row_z};
  for (std::size_t a = 0; a < 3; ++a) {
    const std::string axis(1, "xyz"[a]);
    const auto motors = axis_motor_keys(keys, axis);
    if (motors.empty() || motors.front() != axis) missing.push_back(stepper_name(axis));
    for (const std::string& k : motors) {
      Motor m;
      m.name = stepper_name(k);
      m.key = k;
      m.row = *rows[a];
      out.push_back(std::move(m));
    }
  }
  return out;
}

LinearMap linear_map_of(const std::vector<Motor>& motors) {
  LinearMap map;
  for (const Motor& m : motors) {
    map.motors.push_back(m.name);
    map.rows.push_back({m.row[0], m.row[1], m.row[2]});
  }
  return map;
}

}  // namespace amctl::kinematics::detail

namespace amctl::kinematics::detail {

std::vector<KlipperStepper> axis_steppers(const KlipperConfig& cfg, std::string_view axes) {
  std::vector<KlipperStepper> out;
  for (const ConfigSection& s : cfg.sections()) {
    if (s.name.size() < 9 || s.name.compare(0, 8, "stepper_") != 0) continue;
    const std::string key = s.name.substr(8);
    if (axes.find(key[0]) == std::string_view::npos) continue;
    if (!std::all_of(key.begin() + 1, key.end(), [](char c) { return c >= '0' && c <= '9'; })) continue;
    out.push_back({s.name, key, false});
  }
  return out;
}

void read_rail(const KlipperSection& sec, Rails& rails, const std::string& key) {
  if ((key == "x" || key == "y" || key == "z") && sec.has("position_max")) {
    Rail& r = rails[key];
    r.position_min_mm = sec.get_float("position_min", 0.0);
    r.position_max_mm = sec.get_float("position_max", {.above = *r.position_min_mm});
    r.position_endstop_mm = sec.get_float("position_endstop");
  }
}

std::optional<DualCarriage> read_dual_carriage(const KlipperConfig& cfg) {
  const KlipperSection d = cfg.section("dual_carriage");
  if (!d.present()) return std::nullopt;
  DualCarriage dc;
  dc.axis = d.get_choice("axis", "", {"x", "y"});
  if (dc.axis.empty()) throw Error(d.where(), "[dual_carriage] axis: must be specified (x or y)");
  dc.position_endstop_mm = d.require_float("position_endstop");
  dc.position_min_mm = d.get_float("position_min", 0.0);
  dc.position_max_mm = d.get_float("position_max", {.above = *dc.position_min_mm});
  if (!dc.position_max_mm) throw Error(d.where(), "[dual_carriage] position_max: must be specified");
  dc.safe_distance_mm = d.get_float("safe_distance", {.minval = 0.0});
  dc.homing_speed_mm_s = d.get_float("homing_speed", 5.0, {.above = 0.0});
  const KlipperSection first = cfg.section("stepper_" + dc.axis);
  if (first.present()) dc.primary_homing_speed_mm_s = first.get_float("homing_speed", 5.0, {.above = 0.0});
  return dc;
}

void refuse_dual_carriage(const KlipperConfig& cfg) {
  const KlipperSection d = cfg.section("dual_carriage");
  if (d.present()) {
    throw Error(d.where(), "[dual_carriage]: amctl models a dual carriage on cartesian, "
                           "hybrid_corexy and hybrid_corexz kinematics only (as Klipper)");
  }
}

}  // namespace amctl::kinematics::detail

namespace amctl::kinematics::detail {

void check_rails(const Rails& rails) {
  for (const auto& [name, r] : rails) {
    if (r.position_min_mm && r.position_max_mm && *r.position_min_mm > *r.position_max_mm) {
      throw Error(fmt::format("stepper_{}.position_min ({} mm) must be <= position_max ({} mm)",
                              name, *r.position_min_mm, *r.position_max_mm));
    }
  }
}

void check_dual_carriage(const Rails& rails, const std::optional<DualCarriage>& d) {
  if (!d || d->axis.empty()) return;
  const DualCarriage& dc = *d;
  if (dc.axis != "x" && dc.axis != "y") {
    throw Error(fmt::format("dual_carriage.axis must be \"x\", \"y\" or \"\" (none), got \"{}\"", dc.axis));
  }
  if (!dc.position_max_mm || !dc.position_endstop_mm) {
    throw Error("dual_carriage: position_max and position_endstop are required with an axis");
  }
  const auto first = rails.find(dc.axis);
  if (first == rails.end() || !first->second.position_endstop_mm || !first->second.position_max_mm) {
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

}  // namespace amctl::kinematics::detail
