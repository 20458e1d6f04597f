#pragma once
// Internal to the planner: the two places where the ramp shape enters the look-ahead
// (docs/planner.md, "Jerk-limited profiles"): the squared speed reachable over a move from
// from_v2 (accelerating, or by time reversal braking), and the squared cruise peak between
// two end speeds. The smoothed (minimum cruise ratio) pass uses the same shapes with the
// pseudo-accel. The trapezoid (and bezier5, timed like it) keeps v0^2 + 2 a D.
#include <algorithm>
#include <cmath>

#include "amctl/plan/velocity_profile.hpp"
#include "move_queue.hpp"

namespace amctl::plan::detail {

class RampShape {
 public:
  explicit RampShape(bool jerk_limited) : jerk_limited_(jerk_limited) {}
  [[nodiscard]] bool jerk_limited() const { return jerk_limited_; }

  [[nodiscard]] double reach_v2(double from_v2, const Move& m) const {
    if (!jerk_limited_) return from_v2 + m.delta_v2;  // v^2 = v0^2 + 2 a D
    if (from_v2 == m.reach_from_v2) return m.reach_to_v2;
    const double v = max_reachable_speed_mm_s(VelocityProfile::scurve7, std::sqrt(from_v2),
                                              m.out.distance_mm, m.out.accel_mm_s2, m.out.jerk_mm_s3);
    m.reach_from_v2 = from_v2;
    m.reach_to_v2 = v * v;
    return v * v;
  }

  [[nodiscard]] double reach_mcr_v2(double from_v2, const Move& m) const {
    if (!jerk_limited_) return from_v2 + m.mcr_delta_v2;
    if (from_v2 == m.mcr_reach_from_v2) return m.mcr_reach_to_v2;
    const double v = max_reachable_speed_mm_s(VelocityProfile::scurve7, std::sqrt(from_v2),
                                              m.out.distance_mm, m.mcr_accel, m.out.jerk_mm_s3);
    m.mcr_reach_from_v2 = from_v2;
    m.mcr_reach_to_v2 = v * v;
    return v * v;
  }

  /// S-curve peak between two end speeds, as min(peak, cap) for the trapezoid: a cap below
  /// an end speed flattens the move at the cap (the emitter then clips the end speeds to it).
  [[nodiscard]] static double scurve_peak_v2(double start_v2, double end_v2, const Move& m,
                                             double accel, double cap_v2) {
    if (cap_v2 <= std::max(start_v2, end_v2)) return cap_v2;
    const double v = peak_speed_mm_s(VelocityProfile::scurve7, std::sqrt(start_v2), std::sqrt(end_v2),
                                     m.out.distance_mm, accel, m.out.jerk_mm_s3, std::sqrt(cap_v2));
    return v * v;
  }

 private:
  bool jerk_limited_ = false;
};

/// RampShape with the profile fixed at compile time, for the hot loops (each strategy
/// instantiates both and picks one per flush): the same arithmetic, without the tests.
template <bool kJerkLimited>
struct StaticRampShape {
  static constexpr bool jerk_limited() { return kJerkLimited; }
  static double reach_v2(double from_v2, const Move& m) {
    if constexpr (kJerkLimited) return RampShape(true).reach_v2(from_v2, m);
    else return from_v2 + m.delta_v2;
  }
  static double reach_mcr_v2(double from_v2, const Move& m) {
    if constexpr (kJerkLimited) return RampShape(true).reach_mcr_v2(from_v2, m);
    else return from_v2 + m.mcr_delta_v2;
  }
};

}  // namespace amctl::plan::detail
