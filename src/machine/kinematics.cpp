// The machine's side of its kinematics: the parameters gathered from the description, the
// drive trains attached to the motors.
#include "amctl/machine/kinematics.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"

namespace amctl::machine {
namespace {

namespace kin = amctl::kinematics;

kin::Rails rails_of(const Machine& m) {
  kin::Rails rails;
  for (const auto& [k, s] : m.steppers) {
    if (s.position_min_mm || s.position_max_mm || s.position_endstop_mm) {
      rails[k] = {s.position_min_mm, s.position_max_mm, s.position_endstop_mm};
    }
  }
  return rails;
}

std::optional<kin::DualCarriage> dual_of(const Machine& m) {
  const DualCarriage& d = m.dual_carriage;
  if (!d.present()) return std::nullopt;
  return kin::DualCarriage{d.axis, d.position_min_mm, d.position_max_mm, d.position_endstop_mm,
                           d.safe_distance_mm, d.homing_speed_mm_s, d.primary_homing_speed_mm_s};
}

}  // namespace

kin::Params kinematics_params(const Machine& m) {
  switch (m.kinematics) {
    case Kinematics::cartesian: return kin::Cartesian{rails_of(m), dual_of(m)};
    case Kinematics::corexy: return kin::CoreXY{rails_of(m)};
    case Kinematics::corexz: return kin::CoreXZ{rails_of(m)};
    case Kinematics::hybrid_corexy: return kin::HybridCoreXY{rails_of(m), dual_of(m)};
    case Kinematics::hybrid_corexz: return kin::HybridCoreXZ{rails_of(m), dual_of(m)};
    case Kinematics::none: return kin::None{};
    case Kinematics::delta: {
      kin::Delta d{m.delta.radius_mm, m.delta.print_radius_mm, m.delta.minimum_z_position_mm, {}};
      for (const auto& [k, s] : m.steppers) {
        if (k == "a" || k == "b" || k == "c") d.towers[k] = {s.arm_length_mm, s.angle_deg, s.position_endstop_mm};
      }
      return d;
    }
    case Kinematics::deltesian: {
      kin::Deltesian d{m.delta.min_angle_deg, m.delta.print_width_mm, m.delta.slow_ratio,
                       m.delta.minimum_z_position_mm, {}, {}};
      for (const auto& [k, s] : m.steppers) {
        if (k == "left" || k == "right") d.towers[k] = {s.arm_x_length_mm, s.arm_length_mm, s.position_endstop_mm};
      }
      d.rails = rails_of(m);
      return d;
    }
    case Kinematics::winch: {
      kin::Winch w;
      for (const auto& [k, s] : m.steppers) {
        if (s.anchor_x_mm || s.anchor_y_mm || s.anchor_z_mm) w.anchors[k] = {s.anchor_x_mm, s.anchor_y_mm, s.anchor_z_mm};
      }
      return w;
    }
    case Kinematics::polar: return kin::Polar{m.max_angular_velocity_rad_s, rails_of(m)};
    case Kinematics::rotary_delta: {
      kin::RotaryDelta r{m.delta.shoulder_radius_mm, m.delta.shoulder_height_mm,
                         m.delta.minimum_z_position_mm, {}};
      for (const auto& [k, s] : m.steppers) {
        if (k == "a" || k == "b" || k == "c") {
          r.arms[k] = {s.upper_arm_length_mm, s.lower_arm_length_mm, s.angle_deg, s.position_endstop_mm};
        }
      }
      return r;
    }
    case Kinematics::generic_cartesian: {
      kin::GenericCartesian g;
      for (const auto& [name, c] : m.carriages) {
        g.carriages[name] = {static_cast<kin::Carriage::Type>(c.type), c.axis, c.primary_carriage,
                             c.position_min_mm, c.position_max_mm, c.position_endstop_mm,
                             c.homing_speed_mm_s, c.safe_distance_mm};
      }
      for (const auto& [k, s] : m.steppers) {
        if (!s.carriages.empty()) g.stepper_carriages[k] = s.carriages;
      }
      return g;
    }
  }
  return kin::None{};
}

kin::Context kinematics_context(const Machine& m) {
  kin::Context c;
  c.toolhead = {m.max_velocity_mm_s, m.max_accel_mm_s2, m.max_z_velocity_mm_s, m.max_z_accel_mm_s2};
  for (const auto& [k, s] : m.steppers) {
    c.step_distance[k] =
        s.rotation_distance_mm / (static_cast<double>(s.full_steps_per_rotation) * s.microsteps);
  }
  c.machine_name = m.name;
  return c;
}

std::unique_ptr<const kin::Kinematics> make_kinematics(const Machine& m) {
  return kin::make(kinematics_params(m), kinematics_context(m));
}

double step_distance(const Stepper& s, const std::string& label) {
  if (!(std::isfinite(s.rotation_distance_mm) && s.rotation_distance_mm > 0.0)) {
    throw Error(fmt::format("{}.rotation_distance: must be a positive number of mm, got {}", label,
                            s.rotation_distance_mm));
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
  return s.rotation_distance_mm /
         (static_cast<double>(s.full_steps_per_rotation) * static_cast<double>(s.microsteps));
}

std::vector<kin::Motor> motors(const Machine& m) {
  std::vector<std::string> keys;
  for (const auto& [k, s] : m.steppers) keys.push_back(k);
  std::vector<std::string> missing;
  const auto kinematics = make_kinematics(m);
  std::vector<kin::Motor> out = kinematics->motors(keys, missing);
  if (m.steppers.count("e") != 0) {
    kin::Motor e;
    e.name = "extruder";
    e.key = "e";
    e.row = {0, 0, 0, 1};
    out.push_back(std::move(e));
  } else {
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
    motor.step_distance.value = step_distance(m.steppers.at(motor.key), motor.name);
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
                            "cartesian, corexy, corexz, hybrid_corexy, hybrid_corexz or "
                            "generic_cartesian machine; simulate it without --motor-space",
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
