#include "amctl/trajectory/retime.hpp"

#include <algorithm>
#include <cmath>

namespace amctl::trajectory {

std::vector<plan::PlannedMove> retime(const std::vector<plan::PlannedMove>& in,
                                      plan::VelocityProfile profile, double jerk) {
  std::vector<plan::PlannedMove> out = in;
  const std::size_t n = out.size();
  if (n == 0) return out;
  // Junction speeds v[i] between move i-1 and i; v[0] = start of the first, v[n] = end.
  std::vector<double> v(n + 1);
  v[0] = in[0].start_v_mm_s;
  for (std::size_t i = 0; i < n; ++i) v[i + 1] = in[i].end_v_mm_s;
  // A gap (dwell) or a discontinuity means the toolhead is at rest there: keep as is.
  auto reach = [&](double from, const plan::PlannedMove& m) {
    if (m.accel_mm_s2 <= 0.0) return from;
    return plan::max_reachable_speed_mm_s(profile, from, m.distance_mm, m.accel_mm_s2, jerk);
  };
  for (std::size_t i = n; i-- > 0;) v[i] = std::min(v[i], reach(v[i + 1], in[i]));
  for (std::size_t i = 0; i < n; ++i) v[i + 1] = std::min(v[i + 1], reach(v[i], in[i]));
  double t = in[0].start_time_s;
  for (std::size_t i = 0; i < n; ++i) {
    plan::PlannedMove& m = out[i];
    if (i > 0) {
      const double gap = in[i].start_time_s - in[i - 1].end_time_s();
      if (gap > 1e-9) t += gap;
    }
    m.start_time_s = t;
    m.profile = profile;
    m.jerk_mm_s3 = profile == plan::VelocityProfile::scurve7 ? jerk : 0.0;
    if (m.accel_mm_s2 > 0.0 && m.distance_mm > 0.0) {
      const double cap = std::max({in[i].cruise_v_mm_s, v[i], v[i + 1]});
      const plan::MoveTiming mt =
          plan::time_move(profile, m.distance_mm, v[i], cap, v[i + 1], m.accel_mm_s2, jerk);
      m.start_v_mm_s = mt.start_v_mm_s;
      m.cruise_v_mm_s = mt.cruise_v_mm_s;
      m.end_v_mm_s = mt.end_v_mm_s;
      m.accel_t_s = mt.accel_t_s;
      m.cruise_t_s = mt.cruise_t_s;
      m.decel_t_s = mt.decel_t_s;
    }
    t += m.duration_s();
  }
  return out;
}

ProfileFigures profile_figures(const std::vector<plan::PlannedMove>& moves) {
  ProfileFigures f;
  if (moves.empty()) return f;
  f.motion_time_s = moves.back().end_time_s() - moves.front().start_time_s;
  for (const plan::PlannedMove& m : moves) {
    if (m.accel_mm_s2 <= 0.0) continue;
    for (const auto& [a, b] : {std::pair{m.start_v_mm_s, m.cruise_v_mm_s},
                               std::pair{m.cruise_v_mm_s, m.end_v_mm_s}}) {
      if (std::abs(a - b) <= 1e-9 * std::max({1.0, a, b})) continue;
      const plan::Ramp r = plan::make_ramp(m.profile, a, b, m.accel_mm_s2, m.jerk_mm_s3);
      f.peak_accel_mm_s2 = std::max(f.peak_accel_mm_s2, r.peak_accel_mm_s2);
      f.peak_jerk_mm_s3 = std::max(f.peak_jerk_mm_s3, r.peak_jerk_mm_s3);
    }
  }
  return f;
}

}  // namespace amctl::trajectory
