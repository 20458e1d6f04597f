#pragma once
// Internal to the planner: everything leaves the planner through the Timeline, in time
// order. It times a move whose three speeds the strategy has chosen (trapezoid closed form,
// or the jerk-limited ramps), advances the print clock, and releases the non-motion events
// that were waiting behind that move.
#include <cstdint>

#include "amctl/plan/planner.hpp"
#include "move_queue.hpp"
#include "pending_events.hpp"

namespace amctl::plan::detail {

class Timeline {
 public:
  Timeline(PlanSink& sink, bool jerk_limited) : sink_(sink), jerk_limited_(jerk_limited) {}

  /// Times m with the given squared start, cruise and end speeds, hands it to the sink and
  /// fires the events queued behind it.
  void emit(Move& m, double start_v2, double cruise_v2, double end_v2);

  /// The toolhead waits duration_s at rest (G4), after everything emitted so far.
  void dwell(double duration_s, std::uint64_t line);

  /// An event with no move left to wait for takes effect now.
  void fire_now(const PendingEvent& e) { e.fire(print_time_s_, sink_); }
  void fire_at(const PendingEvent& e, double time_s) { e.fire(time_s, sink_); }
  void release_all_events() { events_.release(PendingEvents::kAll, print_time_s_, sink_); }
  [[nodiscard]] PendingEvents& events() { return events_; }

  [[nodiscard]] double print_time_s() const { return print_time_s_; }

 private:
  void emit_jerk_limited(PlannedMove& o, double start_v2, double cruise_v2, double end_v2);

  PlanSink& sink_;
  bool jerk_limited_ = false;
  double print_time_s_ = 0.0;
  // Trapezoid timing: the last 0.5 / accel and the last end speed with its square root.
  double last_a_ = 0, last_half_inv_a_ = 0, last_end_v2_ = 0, last_end_v_ = 0;
  PendingEvents events_;
};

}  // namespace amctl::plan::detail
