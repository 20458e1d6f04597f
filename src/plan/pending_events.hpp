#pragma once
// Internal to the planner: event re-timing. A non-motion command (heater, fan, progress,
// layer mark, untimed command) takes effect once every move queued before it has run, so
// it waits behind the last queued move and is released when that move is emitted, at the
// print time reached then. This is the one place that releases them.
#include <cstdint>
#include <deque>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

#include "amctl/gcode/events.hpp"
#include "amctl/plan/planner.hpp"

namespace amctl::plan::detail {

struct PendingEvent {
  enum class Kind : std::uint8_t { heater, fan, progress, layer, untimed, input_shaping, range_error, step_tuning } kind = Kind::heater;
  std::uint64_t after_seq = 0;  // released once the move with this seq has been emitted
  gcode::HeaterCommand heater{};
  gcode::ProgressMarker progress{};
  double fan = 0.0;
  std::int32_t layer = 0;
  std::uint64_t line = 0;
  std::string name;
  gcode::InputShapingCommand shaping{};
  RangeError range{};  ///< range_error: at_s is set when fired
  gcode::StepTuningCommand tuning{};

  static PendingEvent make_heater(const gcode::HeaterCommand& cmd);
  static PendingEvent make_fan(double fraction, std::uint64_t line);
  static PendingEvent make_progress(const gcode::ProgressMarker& m);
  static PendingEvent make_layer(std::int32_t layer, std::uint64_t line);
  static PendingEvent make_untimed(std::string_view name, std::uint64_t line);
  static PendingEvent make_input_shaping(const gcode::InputShapingCommand& cmd);
  static PendingEvent make_range_error(const RangeError& e);
  static PendingEvent make_step_tuning(const gcode::StepTuningCommand& cmd);

  /// Hands the event to the sink as taking effect at print time time_s.
  void fire(double time_s, PlanSink& sink) const;
};

class PendingEvents {
 public:
  static constexpr std::uint64_t kAll = std::numeric_limits<std::uint64_t>::max();

  [[nodiscard]] bool empty() const { return queue_.empty(); }
  [[nodiscard]] std::size_t size() const { return queue_.size(); }

  /// Queues e behind the move with sequence number after_seq.
  void push(PendingEvent&& e, std::uint64_t after_seq) {
    e.after_seq = after_seq;
    queue_.push_back(std::move(e));
  }

  /// Fires, at time_s, every event waiting behind a move with seq <= through_seq (kAll:
  /// every event), oldest first.
  void release(std::uint64_t through_seq, double time_s, PlanSink& sink);

 private:
  std::deque<PendingEvent> queue_;
};

}  // namespace amctl::plan::detail
