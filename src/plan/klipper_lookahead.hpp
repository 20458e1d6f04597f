#pragma once
// Internal to the planner: Klipper's look-ahead (toolhead.py's lazy flush). Moves wait in
// the queue until 0.150 s of minimum move time is queued (1 s after a full stop); a flush
// then plans the whole queue as if the machine stopped after its last move and emits only
// the moves whose speeds can no longer change. docs/planner.md, "Look-ahead and flushing".
#include <cstddef>
#include <vector>

#include "move_queue.hpp"
#include "ramp_shape.hpp"
#include "timeline.hpp"

namespace amctl::plan::detail {

class KlipperLookahead {
 public:
  static constexpr double kLazyFlushTime_s = 0.150;  // Klipper LOOKAHEAD_FLUSH_TIME
  static constexpr double kFullFlushTime_s = 1.0;    // Klipper BUFFER_TIME_HIGH after a full flush

  KlipperLookahead(RampShape ramps, Timeline& out) : ramps_(ramps), out_(out) {}

  /// After a move was queued (its junction limit set): flushes lazily once enough time is
  /// queued. Returns true when the queue reached max_queue without that (the caller notes
  /// the forced flush and calls flush(queue, true)).
  [[nodiscard]] bool after_queued(MoveQueue& queue, std::size_t max_queue) {
    if (queue.size() == 1) return false;
    flush_budget_s_ -= queue.back().min_move_t;
    if (flush_budget_s_ <= 0.0) {
      flush(queue, true);
      return false;
    }
    return queue.size() >= max_queue;
  }

  /// Plans the queue ending at rest; lazy: emits only the moves that can no longer change,
  /// otherwise all of them.
  void flush(MoveQueue& queue, bool lazy);

  /// The toolhead is at rest with an empty queue (after a full stop).
  void after_full_stop() { flush_budget_s_ = kFullFlushTime_s; }

 private:
  struct JunctionInfo { double start_v2; double cruise_v2; bool has_cruise; double next_start_v2; };
  template <class Shape>
  void flush_with(MoveQueue& queue, bool lazy);

  RampShape ramps_;
  Timeline& out_;
  double flush_budget_s_ = kFullFlushTime_s;
  std::vector<JunctionInfo> scratch_;  // reused by flush()
};

}  // namespace amctl::plan::detail
