#include "timeline.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/plan/velocity_profile.hpp"

namespace amctl::plan::detail {

void Timeline::emit_jerk_limited(PlannedMove& o, double start_v2, double cruise_v2, double end_v2) {
  // Jerk-limited ramps (velocity_profile.hpp): durations from the S-curve, the cruise takes
  // what the two ramps leave of the distance. The look-ahead chose the speeds with the
  // S-curve's own reach and peak, so the ramps must fit.
  const double j = o.jerk_mm_s3, a = o.accel_mm_s2, D = o.distance_mm;
  o.start_v_mm_s = std::sqrt(start_v2);
  o.cruise_v_mm_s = std::sqrt(cruise_v2);
  o.end_v_mm_s = std::sqrt(end_v2);
  o.accel_t_s = ramp_duration_s(VelocityProfile::scurve7, o.start_v_mm_s, o.cruise_v_mm_s, a, j);
  o.decel_t_s = ramp_duration_s(VelocityProfile::scurve7, o.cruise_v_mm_s, o.end_v_mm_s, a, j);
  const double ramps_d = 0.5 * (o.start_v_mm_s + o.cruise_v_mm_s) * o.accel_t_s +
                         0.5 * (o.cruise_v_mm_s + o.end_v_mm_s) * o.decel_t_s;
  AMCTL_CHECK(ramps_d <= D * (1.0 + 1e-9) + 1e-12,
              fmt::format("line {}: S-curve ramps {} -> {} -> {} mm/s need {} mm, move is {} mm",
                          o.line, o.start_v_mm_s, o.cruise_v_mm_s, o.end_v_mm_s, ramps_d, D));
  const double cruise_d = D - ramps_d;
  o.cruise_t_s = cruise_d > 0.0 && o.cruise_v_mm_s > 0.0 ? cruise_d / o.cruise_v_mm_s : 0.0;
}

void Timeline::emit(Move& m, double start_v2, double cruise_v2, double end_v2) {
  PlannedMove& o = m.out;
  if (jerk_limited_) {
    emit_jerk_limited(o, start_v2, cruise_v2, end_v2);
  } else {
    const double a = o.accel_mm_s2;
    // 0.5 / a changes only with the limits: reuse the last quotient (the same double).
    if (a != last_a_) {
      last_a_ = a;
      last_half_inv_a_ = 0.5 / a;
    }
    const double half_inv_a = last_half_inv_a_;
    const double accel_d = (cruise_v2 - start_v2) * half_inv_a;
    const double decel_d = (cruise_v2 - end_v2) * half_inv_a;
    const double cruise_d = std::max(0.0, o.distance_mm - accel_d - decel_d);
    // Most moves start at the speed the previous one ended at, and a cruising move has all
    // three speeds equal: each square root is taken once (sqrt is exact, so nothing changes).
    const double start_v = start_v2 == last_end_v2_ ? last_end_v_ : std::sqrt(start_v2);
    const double cruise_v = cruise_v2 == start_v2 ? start_v : std::sqrt(cruise_v2);
    const double end_v = end_v2 == cruise_v2 ? cruise_v : std::sqrt(end_v2);
    last_end_v2_ = end_v2;
    last_end_v_ = end_v;
    o.start_v_mm_s = start_v;
    o.cruise_v_mm_s = cruise_v;
    o.end_v_mm_s = end_v;
    // Time is distance over mean speed (well conditioned when speeds are close).
    o.accel_t_s = accel_d > 0 ? accel_d / ((start_v + cruise_v) * 0.5) : 0.0;
    o.cruise_t_s = cruise_d > 0 ? cruise_d / cruise_v : 0.0;
    o.decel_t_s = decel_d > 0 ? decel_d / ((end_v + cruise_v) * 0.5) : 0.0;
  }
  o.start_time_s = print_time_s_;
  print_time_s_ += o.accel_t_s + o.cruise_t_s + o.decel_t_s;
  sink_.on_planned(o);
  if (!events_.empty()) events_.release(m.seq, print_time_s_, sink_);
}

void Timeline::dwell(double duration_s, std::uint64_t line) {
  sink_.on_dwell(print_time_s_, duration_s, line);
  print_time_s_ += std::max(0.0, duration_s);
}

}  // namespace amctl::plan::detail
