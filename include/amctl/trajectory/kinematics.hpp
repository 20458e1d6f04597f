#pragma once
// Motor space of the XY gantry. Cartesian: motors follow X and Y. CoreXY: A = X + Y,
// B = X - Y (so X = (A + B)/2, Y = (A - B)/2). The map is linear, so it applies unchanged to
// velocities, accelerations and jerks, and a polynomial trajectory stays polynomial.
#include <array>

#include "amctl/machine/machine.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::trajectory {

/// (x, y) -> motor (a, b).
[[nodiscard]] std::array<double, 2> to_motor(machine::Kinematics k, double x_mm, double y_mm);
/// motor (a, b) -> (x, y).
[[nodiscard]] std::array<double, 2> from_motor(machine::Kinematics k, double a_mm, double b_mm);
/// Whole state in motor space: entries 0, 1 become A, B (or X, Y); Z and E unchanged.
[[nodiscard]] AxisState to_motor(machine::Kinematics k, const AxisState& s);
/// Row of the motor map: motor m position = row[0] * x + row[1] * y.
[[nodiscard]] std::array<double, 2> motor_row(machine::Kinematics k, int motor);

}  // namespace amctl::trajectory
