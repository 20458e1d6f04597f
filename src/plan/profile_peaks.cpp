#include "amctl/plan/profile_peaks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "amctl/plan/velocity_profile.hpp"

namespace amctl::plan {

void ProfilePeaks::add(const PlannedMove& mv) {
  if (mv.extrude_only || mv.accel_mm_s2 <= 0.0) return;
  for (const auto& [v0, v1] : {std::pair{mv.start_v_mm_s, mv.cruise_v_mm_s},
                               std::pair{mv.cruise_v_mm_s, mv.end_v_mm_s}}) {
    if (std::abs(v1 - v0) <= 1e-9 * std::max({1.0, v0, v1})) continue;
    const Ramp r = make_ramp(mv.profile, v0, v1, mv.accel_mm_s2, mv.jerk_mm_s3);
    peak_accel_mm_s2 = std::max(peak_accel_mm_s2, r.peak_accel_mm_s2);
    const double jerk = mv.profile == machine::VelocityProfile::trapezoid
                            ? std::numeric_limits<double>::infinity()
                            : r.peak_jerk_mm_s3;
    peak_jerk_mm_s3 = std::max(peak_jerk_mm_s3, jerk);
    ++ramps;
  }
}

}  // namespace amctl::plan
