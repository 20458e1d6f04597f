// Klipper's SET_INPUT_SHAPER (klippy/extras/input_shaper.py) and SET_PRESSURE_ADVANCE
// (klippy/kinematics/extruder.py): the interpreter keeps the settings in force, applies a
// command's parameters to them as Klipper does, and hands the result on (docs/steppers.md,
// section 8). The shaper types and their damping limits are checked by the planner, which
// builds the shapers for the step generator's restart delay.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/process_ranges.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "internal.hpp"

namespace amctl::gcode {

using detail::iequals;

namespace {
/// extruder.py: SMOOTH_TIME maxval (the same limit as pressure_advance_smooth_time) [s].
constexpr double kMaxSmoothTimeS = 0.200;
}  // namespace

bool Interpreter::handle_step_tuning(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  const std::string_view name = cmd.name;
  const bool shaper = iequals(name, "SET_INPUT_SHAPER");
  if (!shaper && !iequals(name, "SET_PRESSURE_ADVANCE")) return false;
  if (!opt_.step_tuning) return false;  // counted as ignored (command_table.cpp)
  InterpreterOptions::StepTuning& st = *opt_.step_tuning;
  if (shaper ? !st.input_shaper : st.extruders.empty()) return false;
  // KEY=number (Python's float()), >= 0 as Klipper's minval=0. checks it.
  const auto number = [&](std::string_view key, double& out) {
    std::string_view text;
    std::uint32_t col = 0;
    if (!find_extended_arg(cmd, key, text, col)) return false;
    double v = 0.0;
    const std::size_t used = parse_float_value(text, v);
    // A subnormal number is no setting a printer has (it passes ">= 0" and divides to inf).
    if (used == 0 || used != text.size() || !std::isfinite(v) ||
        (v != 0.0 && std::abs(v) < std::numeric_limits<double>::min())) {
      fail(line_no, col, fmt::format("{} {}=: found '{}', expected a finite number", cmd.name, key, text));
    }
    if (v < 0.0) {
      fail(line_no, col, fmt::format("{} {}= must be at least 0 (Klipper's minimum), found {}",
                                     cmd.name, key, text));
    }
    out = v;
    return true;
  };
  StepTuningCommand c;
  c.line = line_no;
  if (shaper) {
    // input_shaper.py: with no parameter at all the command only reports.
    if (cmd.args.find('=') == std::string_view::npos) {
      note_ignored(name);
      return true;
    }
    c.kind = StepTuningCommand::Kind::input_shaper;
    std::string_view text;
    std::uint32_t col = 0;
    std::optional<std::string> both;
    std::uint32_t both_col = 0;
    if (find_extended_arg(cmd, "SHAPER_TYPE", text, col)) {
      both = std::string(text);
      both_col = col;
    }
    for (std::size_t a = 0; a < 3; ++a) {
      AxisShaperSetting& s = st.shapers[a];
      const char axis = "XYZ"[a];
      // SHAPER_TYPE (every axis) before SHAPER_TYPE_<axis>; the type lower-cased.
      if (both) {
        s.type = *both;
        c.type_column[a] = both_col;
      } else if (find_extended_arg(cmd, fmt::format("SHAPER_TYPE_{}", axis), text, col)) {
        s.type = std::string(text);
        c.type_column[a] = col;
      }
      for (char& ch : s.type) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      number(fmt::format("DAMPING_RATIO_{}", axis), s.damping_ratio);
      if (find_extended_arg(cmd, fmt::format("DAMPING_RATIO_{}", axis), text, col)) {
        c.damping_column[a] = col;
      }
      if (number(fmt::format("SHAPER_FREQ_{}", axis), s.freq_hz) && s.freq_hz != 0.0 &&
          !in_range(kFrequencyRange, s.freq_hz)) {
        // 0 turns the axis' shaper off; 1e-300 Hz would delay every move by 1e300 s.
        find_extended_arg(cmd, fmt::format("SHAPER_FREQ_{}", axis), text, col);
        fail(line_no, col,
             fmt::format("SET_INPUT_SHAPER SHAPER_FREQ_{}= must be 0 (no shaper) or {}, found '{}'", axis,
                         describe(kFrequencyRange), text));
      }
    }
    c.shapers = st.shapers;
    c.flush = true;  // _update_input_shaping: toolhead.flush_step_generation()
    note_ignored(name);
    sink.on_step_tuning(c);
    return true;
  }
  // SET_PRESSURE_ADVANCE [EXTRUDER=name] [ADVANCE=] [SMOOTH_TIME=]: without EXTRUDER the
  // active extruder's stepper; a name that is not a stepper's is Klipper's "The value '...'
  // is not valid for EXTRUDER".
  c.kind = StepTuningCommand::Kind::pressure_advance;
  std::uint32_t col = 0;
  const std::string who = [&] {
    std::string_view text;
    if (find_extended_arg(cmd, "EXTRUDER", text, col)) return std::string(text);
    return active_extruder_;
  }();
  auto it = std::find_if(st.extruders.begin(), st.extruders.end(),
                         [&](const auto& e) { return e.name == who; });
  if (it == st.extruders.end()) {
    std::string names;
    for (const auto& e : st.extruders) names += (names.empty() ? "" : ", ") + e.name;
    fail(line_no, col == 0 ? cmd.args_column : col,
         fmt::format("SET_PRESSURE_ADVANCE EXTRUDER: found '{}', expected an extruder stepper of "
                     "the printer ({}; Klipper: \"The value '{}' is not valid for EXTRUDER\")",
                     who, names, who));
  }
  const double old_pa = it->pressure_advance_s, old_st = it->smooth_time_s;
  std::string_view text;
  if (number("ADVANCE", it->pressure_advance_s) && !in_range(kPressureAdvanceRange, it->pressure_advance_s)) {
    find_extended_arg(cmd, "ADVANCE", text, col);
    fail(line_no, col, fmt::format("SET_PRESSURE_ADVANCE ADVANCE= must be {}, found '{}'",
                                   describe(kPressureAdvanceRange), text));
  }
  if (number("SMOOTH_TIME", it->smooth_time_s) && it->smooth_time_s > kMaxSmoothTimeS) {
    find_extended_arg(cmd, "SMOOTH_TIME", text, col);
    fail(line_no, col,
         fmt::format("SET_PRESSURE_ADVANCE SMOOTH_TIME= must be at most {} s (Klipper's maximum), "
                     "found {}", kMaxSmoothTimeS, text));
  }
  // extruder.py _set_pressure_advance: the smoothing in force is 0 while the advance is 0; a
  // change of it needs a full step-generation flush, a new advance alone waits for the end
  // of the queued moves.
  const double before = old_pa != 0.0 ? old_st : 0.0;
  const double after = it->pressure_advance_s != 0.0 ? it->smooth_time_s : 0.0;
  c.extruder = it->name;
  c.pressure_advance_s = it->pressure_advance_s;
  c.smooth_time_s = it->smooth_time_s;
  c.flush = before != after;
  note_ignored(name);
  sink.on_step_tuning(c);
  return true;
}

}  // namespace amctl::gcode
