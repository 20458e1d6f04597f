#pragma once
// Internal to the kinematics module: pieces two kinematics share.
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>

#include "amctl/kinematics/kinematics.hpp"

namespace amctl::kinematics::detail {

/// A tower carriage's height along a line (delta.cpp): z + sqrt(L^2 - (x - tx)^2 - (y - ty)^2);
/// `planar` drops the y term (a deltesian tower). `what` names the build volume in messages.
std::shared_ptr<const MotorCurve> tower_curve(double arm2_mm2, double tower_x_mm, double tower_y_mm,
                                              bool planar, const char* what);

// delta.py and rotary_delta.py check_move: a kinematic move must end inside the build volume:
// z in [min_z, max_z] and the radius within max_xy2, tapered above limit_z. A move to the
// home position (homing) is allowed.
template <class G>
std::optional<RangeViolation> tower_volume(const G& g, const MoveGeometry& m) {
  const double dx = m.end[0] - m.start[0], dy = m.end[1] - m.start[1], dz = m.end[2] - m.start[2];
  if (std::sqrt(dx * dx + dy * dy + dz * dz) < 1e-9) return std::nullopt;
  const double x = m.end[0], y = m.end[1], z = m.end[2];
  const double xy2 = x * x + y * y;
  const double limit_xy2 = g.limit_xy2_at(z);
  if (xy2 <= limit_xy2 && z <= g.max_z_mm && z >= g.min_z_mm) return std::nullopt;
  if (x == g.home_position_mm[0] && y == g.home_position_mm[1] && z >= g.min_z_mm &&
      z <= g.home_position_mm[2]) {
    return std::nullopt;
  }
  RangeViolation e;
  if (z > g.max_z_mm || z < g.min_z_mm) {
    e.axis = 'z';
    e.position_mm = z;
    e.limit_mm = z > g.max_z_mm ? g.max_z_mm : g.min_z_mm;
  } else {
    e.axis = 'r';
    e.position_mm = std::sqrt(xy2);
    e.limit_mm = std::sqrt(std::max(0.0, limit_xy2));
  }
  return e;
}

}  // namespace amctl::kinematics::detail
