#include "klipper_lookahead.hpp"

#include <algorithm>

namespace amctl::plan::detail {

void KlipperLookahead::flush(MoveQueue& queue, bool lazy) {
  if (ramps_.jerk_limited()) {
    flush_with<StaticRampShape<true>>(queue, lazy);
  } else {
    flush_with<StaticRampShape<false>>(queue, lazy);
  }
}

template <class Shape>
void KlipperLookahead::flush_with(MoveQueue& queue, bool lazy) {
  flush_budget_s_ = kLazyFlushTime_s;
  const std::size_t n = queue.size();
  if (n == 0) return;
  constexpr Shape ramps{};
  constexpr bool jerk_limited = Shape::jerk_limited();
  bool update_flush_count = lazy;
  std::size_t flush_count = n;
  scratch_.resize(n);
  // Backward pass: the fastest start speed each move may have, assuming the machine comes
  // to rest after the last queued move; the smoothed (mcr) pass picks the cruise peaks.
  double next_start_v2 = 0.0, next_mcr_start_v2 = 0.0, peak_cruise_v2 = 0.0;
  std::size_t pending = 0;
  for (std::size_t k = n; k-- > 0;) {
    const Move& mv = queue[k];
    const double reachable_start_v2 = ramps.reach_v2(next_start_v2, mv);
    const double start_v2 = std::min(mv.max_start_v2, reachable_start_v2);
    const double reach_mcr_start_v2 = ramps.reach_mcr_v2(next_mcr_start_v2, mv);
    const double mcr_start_v2 = std::min(mv.max_mcr_start_v2, reach_mcr_start_v2);
    ++pending;
    JunctionInfo& ji = scratch_[k];
    ji.has_cruise = false;
    if (mcr_start_v2 < reach_mcr_start_v2) {
      // This move may accelerate: either it can both accelerate and decelerate, or it is a
      // full acceleration followed by a full deceleration.
      if (ramps.reach_mcr_v2(mcr_start_v2, mv) > next_mcr_start_v2 || pending > 1) {
        if (update_flush_count && peak_cruise_v2 != 0.0) {
          flush_count = k + pending;
          update_flush_count = false;
        }
        // Peak of the smoothed pass; the S-curve's is below the trapezoid's (3.1), its cap here.
        peak_cruise_v2 = jerk_limited
                             ? RampShape::scurve_peak_v2(mcr_start_v2, next_mcr_start_v2, mv, mv.mcr_accel,
                                                         (mcr_start_v2 + next_mcr_start_v2) * 0.5 +
                                                             mv.out.distance_mm * mv.mcr_accel)
                             : (mcr_start_v2 + reach_mcr_start_v2) * 0.5;
      }
      ji.cruise_v2 = jerk_limited
                         ? RampShape::scurve_peak_v2(start_v2, next_start_v2, mv, mv.out.accel_mm_s2,
                                                     std::min(mv.max_cruise_v2, peak_cruise_v2))
                         : std::min({(start_v2 + reachable_start_v2) * 0.5, mv.max_cruise_v2, peak_cruise_v2});
      ji.has_cruise = true;
      pending = 0;
    }
    ji.start_v2 = start_v2;
    ji.next_start_v2 = next_start_v2;
    next_start_v2 = start_v2;
    next_mcr_start_v2 = mcr_start_v2;
  }
  if (update_flush_count || flush_count == 0) return;
  // Forward pass: moves that cannot accelerate keep the cruise speed of the move before.
  double prev_cruise_v2 = scratch_[0].start_v2;
  for (std::size_t k = 0; k < flush_count; ++k) {
    const JunctionInfo& ji = scratch_[k];
    const double cruise_v2 = ji.has_cruise ? ji.cruise_v2 : std::min(prev_cruise_v2, ji.start_v2);
    out_.emit(queue[k], std::min(ji.start_v2, cruise_v2), cruise_v2, std::min(ji.next_start_v2, cruise_v2));
    prev_cruise_v2 = cruise_v2;
  }
  queue.pop_front(flush_count);
}

}  // namespace amctl::plan::detail
