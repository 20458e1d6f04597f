#include "amctl/plan/estimate.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/machine/kinematics.hpp"

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

// An IDEX pair's two rails (idex_modes.py): ranges and endstops of carriage 0 and 1; stepper.py:
// a rail homes towards max when its endstop lies in the top quarter of it.
void set_idex_rails(gcode::InterpreterOptions::DualCarriage& d, std::array<double, 2> min_mm,
                    std::array<double, 2> max_mm, std::array<double, 2> endstop_mm) {
  d.position_min_mm = min_mm;
  d.position_max_mm = max_mm;
  d.position_endstop_mm = endstop_mm;
  for (std::size_t c = 0; c < 2; ++c) {
    const double len = max_mm[c] - min_mm[c];
    d.homing_positive_dir[c] = endstop_mm[c] >= max_mm[c] - len / 4.0;
  }
}

}  // namespace

std::string describe_range_error(const RangeError& e) {
  const bool below = e.position_mm < e.limit_mm;
  if (e.axis == 'r') {
    return fmt::format(
        "line {}: move out of range: radius sqrt(X^2 + Y^2) = {:.3f} mm is beyond the delta's "
        "build radius {:.3f} mm at that height; Klipper refuses it (\"Move out of range\") and "
        "the print would stop here at t = {:.3f} s; the times reported cover the whole file as "
        "if it did not",
        e.line, e.position_mm, e.limit_mm, e.at_s);
  }
  return fmt::format(
      "line {}: move out of range: {} = {:.3f} mm is {} {} = {:.3f} mm; Klipper refuses it "
      "(\"Move out of range\") and the print would stop here at t = {:.3f} s; the times "
      "reported cover the whole file as if it did not",
      e.line, static_cast<char>(std::toupper(static_cast<unsigned char>(e.axis))), e.position_mm,
      below ? "below" : "above", below ? "position_min" : "position_max", e.limit_mm, e.at_s);
}

std::string_view pause_reason(std::string_view name) {
  struct Entry {
    std::string_view name, reason;
  };
  // Marlin/Prusa: M0/M1 unconditional stop (wait for the user), M125 park head (pause),
  // M226 wait for a pin state, M600 filament change, M601 pause print; G29 bed levelling,
  // G80 Prusa mesh bed levelling, G34 Z steppers auto-alignment. Klipper: PAUSE and the
  // levelling commands of [bed_mesh], [quad_gantry_level], [z_tilt], [z_calibration].
  static constexpr Entry kPauses[] = {
      {"M0", "stop, waits for the user"}, {"M1", "stop, waits for the user"},
      {"M125", "park head, pause"}, {"M226", "waits for a pin state"},
      {"M600", "filament change"}, {"M601", "pause print"}, {"PAUSE", "pause print"},
      {"G29", "bed levelling"}, {"G80", "mesh bed levelling"}, {"G34", "Z auto-alignment"},
      {"BED_MESH_CALIBRATE", "bed levelling"}, {"QUAD_GANTRY_LEVEL", "gantry levelling"},
      {"Z_TILT_ADJUST", "Z tilt levelling"}, {"CALIBRATE_Z", "Z offset calibration"}};
  auto iequal = [](std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
             return std::toupper(static_cast<unsigned char>(x)) == std::toupper(static_cast<unsigned char>(y));
           });
  };
  // "M00" is M0: G/M words compare by their number.
  std::string word(name);
  if (word.size() > 1 && (word[0] == 'G' || word[0] == 'M' || word[0] == 'g' || word[0] == 'm') &&
      std::all_of(word.begin() + 1, word.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; })) {
    const std::size_t nz = std::min(word.find_first_not_of('0', 1), word.size() - 1);
    word = word.substr(0, 1) + word.substr(nz);
  }
  for (const auto& e : kPauses) {
    if (iequal(word, e.name)) return e.reason;
  }
  return {};
}

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
  o.arcs_enabled = m.arcs.enabled;
  o.lift_z_mm = m.firmware_retraction.lift_z_mm;
  // Marlin moves the G10/G11 Z hop at the Z axis's maximum feedrate (fwretract.cpp); Klipper
  // has no hop, so a configured one moves at Klipper's Z speed limit (max_z_velocity, which
  // defaults to max_velocity).
  o.lift_z_speed_mm_s = m.firmware == machine::Firmware::klipper
                            ? (m.max_z_velocity_mm_s > 0.0 ? m.max_z_velocity_mm_s : m.max_velocity_mm_s)
                            : m.max_feedrate_mm_s[2];
  // Klipper's M84/M18 dwells DISABLE_STALL_TIME (0.1 s) before and after switching off.
  o.motor_off_dwell_s = m.firmware == machine::Firmware::klipper ? 0.2 : 0.0;
  const std::shared_ptr<const kinematics::Kinematics> kin = machine::make_kinematics(m);
  const kinematics::Homing homing = kin->homing();
  if (!homing.klipper_only || m.firmware == machine::Firmware::klipper) {
    o.home_all_axes = homing.all_axes;
    for (std::size_t a = 0; a < 3; ++a) {
      if (homing.position_mm[a]) o.home_position_mm[a] = *homing.position_mm[a];
    }
  }
  if (m.firmware == machine::Firmware::marlin) {
    o.soft_min_mm = m.soft_min_position_mm;
    o.soft_max_mm = m.soft_max_position_mm;
  }
  // Klipper's [exclude_object]; a printer.cfg without it: EXCLUDE_OBJECT* are unknown there.
  using ExcludeMode = gcode::InterpreterOptions::ExcludeObjectMode;
  // Klipper's [bed_mesh]: its commands reach the mesh transform (plan/stream.cpp).
  for (const ConfigSection& sec : m.klipper_config) {
    if (sec.name == "bed_mesh") o.bed_mesh = true;
  }
  o.exclude_object = m.exclude_object              ? ExcludeMode::active
                     : !m.klipper_config.empty()   ? ExcludeMode::unknown
                                                   : ExcludeMode::ignored;
  if (m.firmware == machine::Firmware::klipper) {
    // IDEX pairs (idex_modes.py): [dual_carriage] on cartesian and hybrid printers, the
    // [dual_carriage NAME] of a generic_cartesian.
    for (const kinematics::IdexPair& p : kin->idex_pairs()) {
      gcode::InterpreterOptions::DualCarriage d;
      d.axis = p.axis;
      d.names = p.names;
      set_idex_rails(d, p.position_min_mm, p.position_max_mm, p.position_endstop_mm);
      d.safe_distance_mm = p.safe_distance_mm;
      d.homing_speed_mm_s = p.homing_speed_mm_s;
      o.dual_carriages.push_back(d);
    }
    // generic_cartesian's SET_STEPPER_CARRIAGES: the expressions as configured, checked as
    // Klipper checks them.
    o.stepper_carriages = kin->stepper_carriages();
    if (!o.stepper_carriages.empty()) {
      o.check_stepper_carriages = [kin](const std::map<std::string, std::string, std::less<>>& now,
                                      const std::string& stepper, const std::string& expr,
                                      bool full) {
        return kin->stepper_carriages_error(now, stepper, expr, full);
      };
    }
  }
  return o;
}

EstimateSink::EstimateSink(const machine::Machine& machine, double checkpoint_interval_s)
    : checkpoint_interval_s_(checkpoint_interval_s),
      filament_area_mm2_(std::numbers::pi * 0.25 * machine.extruder.filament_diameter_mm *
                         machine.extruder.filament_diameter_mm) {
  r_.machine_name = machine.name;
}

// Inlined into consume(): one call per batch, not per move.
[[gnu::always_inline]] inline void EstimateSink::add_move(const PlannedMove& m) {
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
  if (checkpoint_interval_s_ > 0.0 && m.start_time_s >= next_checkpoint_s_) {
    r_.checkpoints.push_back(Checkpoint{m.line, m.start_time_s});
    next_checkpoint_s_ =
        (std::floor(m.start_time_s / checkpoint_interval_s_) + 1.0) * checkpoint_interval_s_;
  }
}

void EstimateSink::consume(const PlanBatch& batch) {
  // for_each_in_order() written out: GCC keeps the lambda as a call per move.
  std::size_t i = 0;
  for (const PlanEvent& e : batch.events) {
    for (; i < e.before_move; ++i) add_move(batch.moves[i]);
    add_event(e);
  }
  for (; i < batch.moves.size(); ++i) add_move(batch.moves[i]);
}

void EstimateSink::add_event(const PlanEvent& e) {
  switch (e.kind) {
    case PlanEvent::Kind::dwell:
      r_.dwell_time_s += e.duration_s;
      break;
    case PlanEvent::Kind::heater: {
      const gcode::HeaterCommand& cmd = e.heater;
      const bool bed = cmd.kind == gcode::HeaterCommand::Kind::bed;
      TimedEvent te{e.time_s,
                    fmt::format("{} {} {:g} C{}", cmd.wait ? (bed ? "M190" : "M109") : (bed ? "M140" : "M104"),
                                heater_name(cmd.kind), cmd.target_c, cmd.wait ? " (wait)" : ""),
                    cmd.line};
      (cmd.wait ? r_.heater_waits : r_.heater_sets).push_back(std::move(te));
      break;
    }
    case PlanEvent::Kind::untimed:
      if (r_.untimed.size() < 1000) r_.untimed.push_back(TimedEvent{e.time_s, e.name, e.line});
      if (const std::string_view why = pause_reason(e.name); !why.empty() && r_.pauses.size() < 1000) {
        r_.pauses.push_back(TimedEvent{e.time_s, fmt::format("{} ({})", e.name, why), e.line});
      }
      break;
    case PlanEvent::Kind::range_error:
      if (!r_.range_error) r_.range_error = e.range;
      break;
    case PlanEvent::Kind::layer:
      close_layer(e.time_s);
      r_.layers.push_back(LayerTime{e.layer, e.time_s, 0.0, 0.0, e.line});
      layer_has_z_ = false;
      break;
    case PlanEvent::Kind::progress:
    case PlanEvent::Kind::fan:
    case PlanEvent::Kind::input_shaping:  // no effect on print time
      break;
  }
}

void EstimateSink::close_layer(double now_s) {
  if (!r_.layers.empty()) r_.layers.back().time_s = now_s - r_.layers.back().start_s;
}

void EstimateSink::finish(const StreamSummary& s) {
  close_layer(s.end_time_s);
  r_.file = s.file;
  r_.total_time_s = s.end_time_s;
  r_.lines = s.lines;
  r_.bytes = s.bytes;
  r_.ended_without_newline = s.ended_without_newline;
  r_.skipped_lines = s.skipped_lines;
  r_.filament_volume_mm3 = r_.filament_mm * filament_area_mm2_;
  const auto& names = s.feature_names;
  r_.features.resize(std::max(r_.features.size(), names.size()));
  for (std::size_t i = 0; i < r_.features.size(); ++i) {
    r_.features[i].name = i < names.size() ? names[i] : "unknown";
    r_.features[i].index = static_cast<std::uint16_t>(i);
  }
  // Drop features that never had a move (e.g. "unknown" when every move is annotated).
  std::erase_if(r_.features, [](const FeatureTime& f) { return f.moves == 0; });
  r_.unknown_commands = s.unknown_commands;
  r_.ignored_commands = s.ignored_commands;
  r_.macros = s.macros;
  r_.excluded_objects = s.excluded_objects;
  r_.excluded_moves = s.excluded_moves;
  r_.slicer_estimate_s = s.slicer_estimate_s;
  r_.slicer_name = s.slicer_name;
  r_.diagnostics = s.diagnostics;
  r_.final_limits = s.final_limits;
}

namespace {

EstimateReport run_estimate(PlanSource& source, const machine::Machine& machine,
                            const EstimateOptions& options) {
  EstimateSink sink(machine, options.checkpoint_interval_s);
  if (options.on_move) {
    CallbackSink tap(options.on_move);
    Sink* sinks[] = {&sink, &tap};
    run_pipeline(source, sinks);
  } else {
    Sink* sinks[] = {&sink};
    run_pipeline(source, sinks);
  }
  return sink.take_report();
}

}  // namespace

/// The time [exclude_object] saved: the file planned again with every move made (only when an
/// object was excluded, so other files pay nothing).
double time_without_exclusion(PlanSource& source, const machine::Machine& machine) {
  EstimateSink sink(machine);
  Sink* sinks[] = {&sink};
  run_pipeline(source, sinks);
  return sink.report().total_time_s;
}

std::vector<EstimateRow> estimate_files(const std::vector<std::string>& inputs,
                                        const machine::Machine& machine,
                                        const EstimateOptions& options) {
  std::vector<EstimateRow> rows;
  for (const std::string& file : formats::expand_gcode_inputs(inputs)) {
    EstimateRow row;
    row.file = file;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      row.report = estimate_file(file, machine, options);
    } catch (const Error& e) {
      row.error = e.what();
    }
    row.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rows.push_back(std::move(row));
  }
  return rows;
}

EstimateReport estimate_file(const GcodeInput& input, const machine::Machine& machine,
                             const EstimateOptions& options) {
  // Rewindable: [exclude_object] needs a second pass (standard input and a FIFO from the copy
  // the reader keeps; a regular file costs nothing more).
  RewindableGcode path(input);
  PlanSource source(path, machine, options.source());
  EstimateReport r = run_estimate(source, machine, options);
  if (!r.excluded_objects.empty()) {
    SourceOptions all = options.source();
    all.bypass_exclusion = true;
    PlanSource again(path, machine, all);
    r.exclusion_time_saved_s = time_without_exclusion(again, machine) - r.total_time_s;
  }
  return r;
}

EstimateReport estimate_text(std::string_view gcode, const std::string& name,
                             const machine::Machine& machine, const EstimateOptions& options) {
  PlanSource source(gcode, name, machine, options.source());
  EstimateReport r = run_estimate(source, machine, options);
  if (!r.excluded_objects.empty()) {
    SourceOptions all = options.source();
    all.bypass_exclusion = true;
    PlanSource again(gcode, name, machine, all);
    r.exclusion_time_saved_s = time_without_exclusion(again, machine) - r.total_time_s;
  }
  return r;
}

}  // namespace amctl::plan
