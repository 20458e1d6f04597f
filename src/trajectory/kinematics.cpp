#include "amctl/trajectory/kinematics.hpp"

namespace amctl::trajectory {

std::array<double, 2> motor_row(machine::Kinematics k, int motor) {
  if (k == machine::Kinematics::corexy) {
    return motor == 0 ? std::array<double, 2>{1.0, 1.0} : std::array<double, 2>{1.0, -1.0};
  }
  return motor == 0 ? std::array<double, 2>{1.0, 0.0} : std::array<double, 2>{0.0, 1.0};
}

std::array<double, 2> to_motor(machine::Kinematics k, double x, double y) {
  if (k == machine::Kinematics::corexy) return {x + y, x - y};
  return {x, y};
}

std::array<double, 2> from_motor(machine::Kinematics k, double a, double b) {
  if (k == machine::Kinematics::corexy) return {0.5 * (a + b), 0.5 * (a - b)};
  return {a, b};
}

AxisState to_motor(machine::Kinematics k, const AxisState& s) {
  AxisState m = s;
  auto map = [k](std::array<double, kAxes>& v) {
    const auto ab = to_motor(k, v[0], v[1]);
    v[0] = ab[0];
    v[1] = ab[1];
  };
  map(m.pos_mm);
  map(m.vel_mm_s);
  map(m.acc_mm_s2);
  map(m.jerk_mm_s3);
  return m;
}

}  // namespace amctl::trajectory
