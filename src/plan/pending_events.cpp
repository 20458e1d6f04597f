#include "pending_events.hpp"

namespace amctl::plan::detail {

PendingEvent PendingEvent::make_heater(const gcode::HeaterCommand& cmd) {
  PendingEvent e;
  e.kind = Kind::heater;
  e.heater = cmd;
  e.line = cmd.line;
  return e;
}

PendingEvent PendingEvent::make_fan(double fraction, std::uint64_t line) {
  PendingEvent e;
  e.kind = Kind::fan;
  e.fan = fraction;
  e.line = line;
  return e;
}

PendingEvent PendingEvent::make_progress(const gcode::ProgressMarker& m) {
  PendingEvent e;
  e.kind = Kind::progress;
  e.progress = m;
  e.line = m.line;
  return e;
}

PendingEvent PendingEvent::make_layer(std::int32_t layer, std::uint64_t line) {
  PendingEvent e;
  e.kind = Kind::layer;
  e.layer = layer;
  e.line = line;
  return e;
}

PendingEvent PendingEvent::make_untimed(std::string_view name, std::uint64_t line) {
  PendingEvent e;
  e.kind = Kind::untimed;
  e.name = std::string(name);
  e.line = line;
  return e;
}

PendingEvent PendingEvent::make_input_shaping(const gcode::InputShapingCommand& cmd) {
  PendingEvent e;
  e.kind = Kind::input_shaping;
  e.shaping = cmd;
  e.line = cmd.line;
  return e;
}

PendingEvent PendingEvent::make_range_error(const RangeError& r) {
  PendingEvent e;
  e.kind = Kind::range_error;
  e.range = r;
  e.line = r.line;
  return e;
}

PendingEvent PendingEvent::make_step_tuning(const gcode::StepTuningCommand& cmd) {
  PendingEvent e;
  e.kind = Kind::step_tuning;
  e.tuning = cmd;
  e.line = cmd.line;
  return e;
}

void PendingEvents::release(std::uint64_t through_seq, double time_s, PlanSink& sink) {
  while (!queue_.empty() && queue_.front().after_seq <= through_seq) {
    queue_.front().fire(time_s, sink);
    queue_.pop_front();
  }
}

void PendingEvent::fire(double time_s, PlanSink& sink) const {
  switch (kind) {
    case Kind::heater: sink.on_heater(time_s, heater); break;
    case Kind::fan: sink.on_fan(time_s, fan, line); break;
    case Kind::progress: sink.on_progress(time_s, progress); break;
    case Kind::layer: sink.on_layer_change(time_s, layer, line); break;
    case Kind::untimed: sink.on_untimed(time_s, name, line); break;
    case Kind::input_shaping: sink.on_input_shaping(time_s, shaping); break;
    case Kind::step_tuning: sink.on_step_tuning(time_s, tuning); break;
    case Kind::range_error: {
      RangeError r = range;
      r.at_s = time_s;
      sink.on_range_error(r);
      break;
    }
  }
}

}  // namespace amctl::plan::detail
