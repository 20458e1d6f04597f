#pragma once
// Re-timing a trapezoid plan with another velocity profile, for side-by-side comparisons
// (`amctl simulate --profile`). The trapezoid plan's junction and cruise speeds are kept as
// upper bounds; a backward then a forward pass lowers junction speeds until every move can
// join them under the profile's limits (plan::max_reachable_speed_mm_s, exact for each
// profile), then every move is timed with plan::time_move. For bezier5 (same ramp distances
// as the trapezoid) nothing but the shape changes.
#include <vector>

#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/velocity_profile.hpp"

namespace amctl::trajectory {

struct ProfileFigures {
  double motion_time_s = 0.0;
  double peak_accel_mm_s2 = 0.0;  ///< largest path acceleration of any ramp
  double peak_jerk_mm_s3 = 0.0;   ///< largest path jerk inside ramps (trapezoid: 0, steps only)
};

/// Returns the moves re-timed with `profile` (jerk used by scurve7), start times chained
/// from the first move's start, dwell gaps preserved.
[[nodiscard]] std::vector<plan::PlannedMove> retime(const std::vector<plan::PlannedMove>& moves,
                                                    plan::VelocityProfile profile,
                                                    double jerk_mm_s3);

/// Print time and peak path acceleration / jerk of a plan.
[[nodiscard]] ProfileFigures profile_figures(const std::vector<plan::PlannedMove>& moves);

}  // namespace amctl::trajectory
