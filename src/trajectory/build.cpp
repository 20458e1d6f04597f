#include "amctl/trajectory/build.hpp"

#include <cmath>

#include "amctl/core/error.hpp"

namespace amctl::trajectory {

plan::PlannedMove timed_move(const std::array<double, 4>& from, const MoveSpec& spec,
                             double start_v, double t0, double accel,
                             plan::VelocityProfile profile, double jerk) {
  plan::PlannedMove m;
  m.start_time_s = t0;
  m.start_mm = from;
  std::array<double, 4> d{};
  for (std::size_t i = 0; i < 4; ++i) d[i] = spec.to_mm[i] - from[i];
  const double xyz = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  m.extrude_only = xyz == 0.0;
  m.distance_mm = m.extrude_only ? std::abs(d[3]) : xyz;
  require_positive("move distance_mm", m.distance_mm);
  for (std::size_t i = 0; i < 4; ++i) m.axes_r[i] = d[i] / m.distance_mm;
  const plan::MoveTiming t = plan::time_move(profile, m.distance_mm, start_v, spec.max_v_mm_s,
                                             spec.end_v_mm_s, accel, jerk);
  m.start_v_mm_s = t.start_v_mm_s;
  m.cruise_v_mm_s = t.cruise_v_mm_s;
  m.end_v_mm_s = t.end_v_mm_s;
  m.accel_mm_s2 = accel;
  m.jerk_mm_s3 = profile == plan::VelocityProfile::scurve7 ? jerk : 0.0;
  m.accel_t_s = t.accel_t_s;
  m.cruise_t_s = t.cruise_t_s;
  m.decel_t_s = t.decel_t_s;
  m.profile = profile;
  m.line = spec.line;
  m.layer = spec.layer;
  m.feature = spec.feature;
  return m;
}

std::vector<plan::PlannedMove> chain_moves(const std::array<double, 4>& start,
                                           std::span<const MoveSpec> specs, double accel,
                                           plan::VelocityProfile profile, double jerk) {
  std::vector<plan::PlannedMove> out;
  out.reserve(specs.size());
  std::array<double, 4> at = start;
  double t = 0.0, v = 0.0;
  for (const MoveSpec& s : specs) {
    out.push_back(timed_move(at, s, v, t, accel, profile, jerk));
    at = s.to_mm;
    t = out.back().end_time_s();
    v = out.back().end_v_mm_s;
  }
  return out;
}

}  // namespace amctl::trajectory
