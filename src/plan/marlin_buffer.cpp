#include "marlin_buffer.hpp"

#include <algorithm>

namespace amctl::plan::detail {

void MarlinBuffer::start_oldest(MoveQueue& queue) {
  if (ramps_.jerk_limited()) {
    start_oldest_with<StaticRampShape<true>>(queue);
  } else {
    start_oldest_with<StaticRampShape<false>>(queue);
  }
}

template <class Shape>
void MarlinBuffer::start_oldest_with(MoveQueue& queue) {
  constexpr Shape ramps{};
  // Plan the whole buffer as if the machine stopped after its last block, then execute the
  // oldest block. Its exit speed becomes the fixed entry speed of the next block.
  // The backward pass keeps each block's result (planned_start_v2) and stops at the first
  // block whose start comes out as before: every older block has the same inputs as in the
  // previous pass (its own limit and that start), so it would repeat its previous result too.
  // This is Marlin's own shortcut (it stops at blocks already planned optimally), exact here.
  // The head is always recomputed: its entry limit was just replaced by the previous exit.
  const std::size_t n = queue.size();
  double next_start_v2 = 0.0;  // ends as the planned start of block 1 (0 if none)
  for (std::size_t k = n; k-- > 1;) {
    Move& mv = queue[k];
    const double start_v2 = std::min(mv.max_start_v2, ramps.reach_v2(next_start_v2, mv));
    if (start_v2 == mv.planned_start_v2) {
      next_start_v2 = queue[1].planned_start_v2;
      break;
    }
    mv.planned_start_v2 = start_v2;
    next_start_v2 = start_v2;
  }
  Move& head = queue.front();
  const double s2 = std::min(head.max_start_v2, ramps.reach_v2(next_start_v2, head));
  const double e2 = std::min(next_start_v2, ramps.reach_v2(s2, head));
  // Peak of the trapezoid (seed 000 eq. 3.1) or of the S-curve, capped by the nominal speed.
  const double cruise_v2 =
      Shape::jerk_limited()
          ? std::max({RampShape::scurve_peak_v2(s2, e2, head, head.out.accel_mm_s2, head.max_cruise_v2), s2, e2})
          : std::max({std::min(head.max_cruise_v2, (s2 + e2 + head.delta_v2) * 0.5), s2, e2});
  out_.emit(head, s2, cruise_v2, e2);
  queue.pop_front();
  if (!queue.empty()) {
    queue.front().max_start_v2 = e2;
    queue.front().max_mcr_start_v2 = e2;
  }
}

}  // namespace amctl::plan::detail
