#pragma once
// A machine's kinematics: its parameters (kinematics/params.hpp) with the toolhead limits and
// the motors' drive trains that the machine description holds (docs/machine.md,
// "Kinematics"; docs/steppers.md section 1).
#include <memory>
#include <string>
#include <vector>

#include "amctl/kinematics/params.hpp"
#include "amctl/machine/machine.hpp"

namespace amctl::machine {

/// What the kinematics of m is built from besides its parameters.
[[nodiscard]] kinematics::Context kinematics_context(const Machine& m);

/// The kinematics of m, built and checked (throws amctl::Error naming the missing or
/// inconsistent key).
[[nodiscard]] std::unique_ptr<const kinematics::Kinematics> make_kinematics(const Machine& m);

/// Klipper stepper.py: rotation_distance / (full_steps_per_rotation * microsteps), the gear
/// ratio already folded in by the loaders, in `unit` (rotation_distance_rad for a motor that
/// turns). Throws amctl::Error naming `label`.rotation_distance / .microsteps /
/// .full_steps_per_rotation when one is not positive.
[[nodiscard]] double step_distance(const Stepper& s, const std::string& label,
                                   kinematics::Unit unit = kinematics::Unit::mm);

/// Every motor of m with its step distance, in the order stepper_x, stepper_y, stepper_z,
/// stepper_z1, ..., extruder (a delta: stepper_a, _b, _c, extruder; ...), as Klipper's
/// kinematics allocate them. Throws amctl::Error naming every missing drive train (a Klipper
/// printer.cfg's [stepper_*] and [extruder], a TOML's [stepper_*] with the extruder as
/// [stepper_e]) or a bad one. Extra extruders (e1, ...) are not included (amctl plans one E
/// axis).
[[nodiscard]] std::vector<kinematics::Motor> motors(const Machine& m);

}  // namespace amctl::machine

namespace amctl::machine {

/// The two motors a motor-space simulation (`amctl simulate --motor-space`) puts the belt
/// models on: of the kinematics' linear map, the first motor that moves X or Y and the next
/// one whose X, Y part is independent of it (cartesian stepper_x, stepper_y; CoreXY A = X + Y,
/// B = X - Y; CoreXZ X + Z, Y; hybrid CoreXY X - Y, Y; ...). Throws amctl::Error naming
/// --motor-space for a kinematics whose motors are not linear (delta, polar, ...).
struct MotorSpace {
  std::array<std::string, 2> motors;
  std::array<std::array<double, 3>, 2> rows{};
};
[[nodiscard]] MotorSpace motor_space(const Machine& m);

}  // namespace amctl::machine
