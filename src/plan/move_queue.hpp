#pragma once
// Internal to the planner: a queued move and the FIFO that holds the look-ahead window.
// Not part of the public interface (include/amctl/plan/planner.hpp); see docs/planner.md,
// "Source map".
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "amctl/plan/planned_move.hpp"

namespace amctl::plan::detail {

/// One move waiting in the look-ahead window. Speeds are kept squared [mm^2/s^2].
struct Move {
  PlannedMove out;           // geometry and identity; speeds/times filled when emitted
  double max_cruise_v2 = 0;
  double max_start_v2 = 0;   // junction limit (then, in Marlin's buffer, the fixed entry)
  double delta_v2 = 0;       // 2 a D
  double max_mcr_start_v2 = 0;
  double mcr_delta_v2 = 0;
  double mcr_accel = 0;      // pseudo-accel of the smoothed pass (mcr_delta_v2 / 2D)
  // scurve7: last reachable-speed evaluation of each pass (flushes revisit queued moves,
  // mostly with the same neighbour speed).
  mutable double reach_from_v2 = -1, reach_to_v2 = 0, mcr_reach_from_v2 = -1, mcr_reach_to_v2 = 0;
  double min_move_t = 0;
  double planned_start_v2 = -1;   // Marlin buffer: this block's start in the last backward pass
  double junction_deviation = 0;  // Klipper jd of the limits in force for this move
  bool kinematic = true;
  // Marlin classic jerk bookkeeping
  std::array<double, 4> axis_v{};  // per-axis velocity at nominal speed
  double nominal_v = 0;
  double safe_v = 0;
  std::uint64_t seq = 0;  // arrival order, for events queued behind this move
};

/// FIFO over a vector: O(1) pops from the front without deque's per-block allocations.
/// Slots are recycled, not destroyed: emplace_back() returns a slot that may hold an old
/// move, and the planner's on_move() assigns every field (value-initialising a Move, ~300
/// bytes, was a quarter of on_move's time).
class MoveQueue {
 public:
  [[nodiscard]] std::size_t size() const { return end_ - head_; }
  [[nodiscard]] bool empty() const { return size() == 0; }
  Move& operator[](std::size_t i) { return buf_[head_ + i]; }
  const Move& operator[](std::size_t i) const { return buf_[head_ + i]; }
  Move& front() { return buf_[head_]; }
  Move& back() { return buf_[end_ - 1]; }
  const Move& back() const { return buf_[end_ - 1]; }
  Move& emplace_back() {
    if (end_ < slots_) return buf_[end_++];
    ++end_;
    ++slots_;  // buf_.size(), kept as a count (size() divides by sizeof(Move))
    return buf_.emplace_back();
  }
  void pop_back() { --end_; }
  void pop_front(std::size_t n = 1) {
    head_ += n;
    if (head_ == end_) {
      head_ = end_ = 0;
    } else if (head_ >= 64 && 2 * head_ >= end_) {
      std::move(buf_.begin() + static_cast<std::ptrdiff_t>(head_),
                buf_.begin() + static_cast<std::ptrdiff_t>(end_), buf_.begin());
      end_ -= head_;
      head_ = 0;
    }
  }

 private:
  std::vector<Move> buf_;
  std::size_t slots_ = 0;  // == buf_.size()
  std::size_t head_ = 0;
  std::size_t end_ = 0;
};

}  // namespace amctl::plan::detail
