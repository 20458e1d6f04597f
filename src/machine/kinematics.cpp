// The machine's side of its kinematics: the parameters gathered from the description, the
// drive trains attached to the motors.
#include "amctl/machine/kinematics.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "kinematics_keys.hpp"

namespace amctl::machine {
namespace kin = amctl::kinematics;

kin::Context kinematics_context(const Machine& m) {
  kin::Context c;
  c.toolhead = {m.max_velocity_mm_s, m.max_accel_mm_s2, m.max_z_velocity_mm_s, m.max_z_accel_mm_s2};
  for (const auto& [k, s] : m.steppers) {
    const double rotation = detail::drive_train_unit(m, k) == kin::Unit::rad
                                ? s.rotation_distance_rad.value_or(0.0)
                                : s.rotation_distance_mm;
    c.step_distance[k] = rotation / (static_cast<double>(s.full_steps_per_rotation) * s.microsteps);
  }
  c.machine_name = m.name;
  return c;
}

std::unique_ptr<const kin::Kinematics> make_kinematics(const Machine& m) {
  return kin::make(m.kinematics, kinematics_context(m));
}

double step_distance(const Stepper& s, const std::string& label, kin::Unit unit) {
  const double rotation = unit == kin::Unit::rad ? s.rotation_distance_rad.value_or(0.0) : s.rotation_distance_mm;
  if (!(std::isfinite(rotation) && rotation > 0.0)) {
    throw Error(fmt::format("{}.rotation_distance: must be a positive number of {}, got {}", label,
                            kin::to_string(unit), rotation));
  }
  if (s.microsteps <= 0) {
    throw Error(fmt::format("{}.microsteps: must be at least 1, got {}", label, s.microsteps));
  }
  if (s.full_steps_per_rotation <= 0) {
    throw Error(fmt::format("{}.full_steps_per_rotation: must be at least 1, got {}", label,
                            s.full_steps_per_rotation));
  }
  // stepper.py: step_dist = rotation_distance / (full_steps * microsteps * gearing); the
  // machine holds rotation_distance / gearing already.
  return rotation / (static_cast<double>(s.full_steps_per_rotation) * static_cast<double>(s.microsteps));
}

std::vector<kin::Motor> motors(const Machine& m) {
  std::vector<std::string> keys;
  for (const auto& [k, s] : m.steppers) keys.push_back(k);
  std::vector<std::string> missing;
  const auto kinematics = make_kinematics(m);
  std::vector<kin::Motor> out = kinematics->motors(keys, missing);
  // A printer without [extruder] has no extruder motor (Klipper's DummyExtruder).
  if (m.steppers.count("e") != 0 && m.extruder.present) {
    out.push_back(kin::extruder_motor());
  } else if (m.extruder.present) {
    missing.push_back("extruder");
  }
  if (!missing.empty()) {
    throw Error(fmt::format(
        "machine '{}' has no stepper section for {}: step generation needs rotation_distance "
        "and microsteps of every motor (a Klipper printer.cfg has [stepper_x], [stepper_y], "
        "[stepper_z] ([stepper_a], [stepper_b], [stepper_c] on a delta), [extruder]; a machine "
        "TOML needs the same sections, the extruder as [stepper_e])",
        m.name, fmt::join(missing, ", ")));
  }
  for (kin::Motor& motor : out) {
    motor.step_distance.value =
        step_distance(m.steppers.at(motor.key), motor.name, motor.step_distance.unit);
  }
  return out;
}

}  // namespace amctl::machine

namespace amctl::machine {

MotorSpace motor_space(const Machine& m) {
  const auto kin = make_kinematics(m);
  const std::optional<kinematics::LinearMap> map = kin->linear_map();
  if (!map) {
    throw Error(fmt::format("--motor-space: the {} kinematics of machine '{}' has no linear motor "
                            "map (its motors' positions are curves of X, Y, Z), expected a "
                            "kinematics whose motors move linearly with X, Y, Z (cartesian, corexy, "
                            "...); simulate it without --motor-space",
                            kin->name(), m.name));
  }
  MotorSpace out;
  std::size_t found = 0;
  for (std::size_t i = 0; i < map->rows.size() && found < 2; ++i) {
    const auto& r = map->rows[i];
    if (r[0] == 0.0 && r[1] == 0.0) continue;
    if (found == 1) {
      const auto& f = out.rows[0];
      if (f[0] * r[1] - f[1] * r[0] == 0.0) continue;  // moves X, Y as the first does
    }
    out.motors[found] = map->motors[i];
    out.rows[found] = r;
    ++found;
  }
  if (found < 2) {
    throw Error(fmt::format("--motor-space: the motors of machine '{}' ({} kinematics) do not move "
                            "X and Y independently",
                            m.name, kin->name()));
  }
  return out;
}

}  // namespace amctl::machine
