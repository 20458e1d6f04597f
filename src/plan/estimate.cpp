#include "amctl/plan/estimate.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::plan {
namespace {

const char* heater_name(gcode::HeaterCommand::Kind k) {
  switch (k) {
    case gcode::HeaterCommand::Kind::hotend: return "hotend";
    case gcode::HeaterCommand::Kind::bed: return "bed";
    case gcode::HeaterCommand::Kind::chamber: return "chamber";
  }
  return "heater";
}

/// Accumulates the report from the planner's output.
class ReportSink final : public PlanSink {
 public:
  ReportSink(EstimateReport& r, const EstimateOptions& opt, const gcode::Interpreter& interp,
             double filament_area_mm2)
      : r_(r), opt_(opt), interp_(interp), filament_area_(filament_area_mm2) {}

  void on_planned(const PlannedMove& m) override {
    const double t = m.duration_s();
    ++r_.moves;
    r_.motion_time_s += t;
    r_.max_speed_mm_s = std::max(r_.max_speed_mm_s, m.cruise_v_mm_s);
    const double de = m.axes_r[3] * m.distance_mm;
    r_.filament_mm += de;
    FeatureTime& f = feature(m.feature);
    f.time_s += t;
    ++f.moves;
    if (m.extrude_only) {
      r_.extrude_only_time_s += t;
    } else if (de > 0.0) {
      r_.extrude_time_s += t;
      r_.extrude_path_mm += m.distance_mm;
      f.extrude_time_s += t;
      f.path_mm += m.distance_mm;
      f.filament_mm += de;
      if (!r_.layers.empty() && !layer_has_z_) {
        r_.layers.back().z_mm = m.start_mm[2] + m.axes_r[2] * m.distance_mm;
        layer_has_z_ = true;
      }
    } else {
      r_.travel_time_s += t;
      r_.travel_mm += m.distance_mm;
    }
    if (opt_.checkpoint_interval_s > 0.0 && m.start_time_s >= next_checkpoint_s_) {
      r_.checkpoints.push_back(Checkpoint{m.line, m.start_time_s});
      next_checkpoint_s_ = (std::floor(m.start_time_s / opt_.checkpoint_interval_s) + 1.0) *
                           opt_.checkpoint_interval_s;
    }
    if (opt_.on_move) opt_.on_move(m);
  }

  void on_dwell(double start_time_s, double duration_s, std::uint64_t line) override {
    (void)start_time_s;
    (void)line;
    r_.dwell_time_s += duration_s;
  }

  void on_heater(double time_s, const gcode::HeaterCommand& cmd) override {
    TimedEvent e{time_s,
                 fmt::format("{} {} {:g} C{}", cmd.wait ? (cmd.kind == gcode::HeaterCommand::Kind::bed ? "M190" : "M109")
                                                       : (cmd.kind == gcode::HeaterCommand::Kind::bed ? "M140" : "M104"),
                             heater_name(cmd.kind), cmd.target_c, cmd.wait ? " (wait)" : ""),
                 cmd.line};
    (cmd.wait ? r_.heater_waits : r_.heater_sets).push_back(std::move(e));
  }

  void on_untimed(double time_s, std::string_view name, std::uint64_t line) override {
    if (r_.untimed.size() < 1000) r_.untimed.push_back(TimedEvent{time_s, std::string(name), line});
  }

  void on_layer_change(double time_s, std::int32_t layer, std::uint64_t line) override {
    close_layer(time_s);
    r_.layers.push_back(LayerTime{layer, time_s, 0.0, 0.0, line});
    layer_has_z_ = false;
  }

  void close_layer(double now_s) {
    if (!r_.layers.empty()) r_.layers.back().time_s = now_s - r_.layers.back().start_s;
  }

 private:
  FeatureTime& feature(std::uint16_t idx) {
    if (idx >= r_.features.size()) r_.features.resize(idx + 1u);
    return r_.features[idx];
  }

  EstimateReport& r_;
  const EstimateOptions& opt_;
  const gcode::Interpreter& interp_;
  double filament_area_;
  bool layer_has_z_ = false;
  double next_checkpoint_s_ = 0.0;
};

EstimateReport run(gcode::LineReader& reader, const machine::Machine& machine,
                   const EstimateOptions& opt) {
  EstimateReport r;
  r.file = reader.name();
  r.machine_name = machine.name;
  gcode::InterpreterOptions io = interpreter_options(machine);
  io.strict = opt.strict;
  gcode::Interpreter interp(io, reader.name());
  const double area = std::numbers::pi * 0.25 * machine.extruder.filament_diameter_mm *
                      machine.extruder.filament_diameter_mm;
  ReportSink sink(r, opt, interp, area);
  Planner planner(machine, sink, opt.planner);
  std::string_view line;
  try {
    while (reader.next(line)) interp.feed(line, reader.line_number(), planner);
    planner.finish();
  } catch (const Error& e) {
    // Errors raised below the interpreter know the line but not the file.
    if (e.where().file.empty() && e.where().line != 0) {
      throw Error(SourceLocation{reader.name(), e.where().line, e.where().column}, e.detail());
    }
    throw;
  }
  sink.close_layer(planner.print_time_s());
  r.total_time_s = planner.print_time_s();
  r.lines = reader.line_number();
  r.bytes = reader.bytes_read();
  r.ended_without_newline = reader.ended_without_newline();
  r.skipped_lines = interp.skipped_lines();
  r.filament_volume_mm3 = r.filament_mm * area;
  const auto& names = interp.annotations().feature_names;
  r.features.resize(std::max(r.features.size(), names.size()));
  for (std::size_t i = 0; i < r.features.size(); ++i) {
    r.features[i].name = i < names.size() ? names[i] : "unknown";
    r.features[i].index = static_cast<std::uint16_t>(i);
  }
  // Drop features that never had a move (e.g. "unknown" when every move is annotated).
  std::erase_if(r.features, [](const FeatureTime& f) { return f.moves == 0; });
  r.unknown_commands = interp.unknown_commands();
  r.ignored_commands = interp.ignored_commands();
  r.slicer_estimate_s = interp.annotations().slicer_estimate_s;
  r.slicer_name = interp.annotations().slicer_name;
  r.diagnostics = planner.diagnostics();
  r.final_limits = planner.limits();
  return r;
}

}  // namespace

gcode::InterpreterOptions interpreter_options(const machine::Machine& m) {
  gcode::InterpreterOptions o;
  o.mm_per_arc_segment = m.arcs.mm_per_arc_segment;
  o.min_arc_segment_mm = m.arcs.min_arc_segment_mm;
  o.max_arc_segment_mm = m.arcs.max_arc_segment_mm;
  o.arc_segments_per_second = m.arcs.segments_per_second;
  o.retract_length_mm = m.firmware_retraction.retract_length_mm;
  o.retract_speed_mm_s = m.firmware_retraction.retract_speed_mm_s;
  o.unretract_extra_length_mm = m.firmware_retraction.unretract_extra_length_mm;
  o.unretract_speed_mm_s = m.firmware_retraction.unretract_speed_mm_s;
  o.min_circle_segments = m.arcs.min_circle_segments;
  o.lift_z_mm = m.firmware_retraction.lift_z_mm;
  // Marlin moves the G10/G11 Z hop at the Z axis's maximum feedrate (fwretract.cpp); Klipper
  // has no hop, so a configured one moves at Klipper's Z speed limit (max_z_velocity, which
  // defaults to max_velocity).
  o.lift_z_speed_mm_s = m.firmware == machine::Firmware::klipper
                            ? (m.max_z_velocity_mm_s > 0.0 ? m.max_z_velocity_mm_s : m.max_velocity_mm_s)
                            : m.max_feedrate_mm_s[2];
  // Klipper's M84/M18 dwells DISABLE_STALL_TIME (0.1 s) before and after switching off.
  o.motor_off_dwell_s = m.firmware == machine::Firmware::klipper ? 0.2 : 0.0;
  return o;
}

EstimateReport estimate_file(const std::string& path, const machine::Machine& machine,
                             const EstimateOptions& options) {
  gcode::LineReader reader(path);
  return run(reader, machine, options);
}

EstimateReport estimate_text(std::string_view gcode, const std::string& name,
                             const machine::Machine& machine, const EstimateOptions& options) {
  gcode::LineReader reader(gcode, name);
  return run(reader, machine, options);
}

}  // namespace amctl::plan
