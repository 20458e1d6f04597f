// Klipper extended commands (NAME KEY=VALUE ...): SET_VELOCITY_LIMIT,
// SET_KINEMATIC_POSITION, SET_RETRACTION, TEMPERATURE_WAIT / SET_HEATER_TEMPERATURE, and
// the lists of ignored and untimed ones (command_table.cpp).
#include <algorithm>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "amctl/gcode/interpreter.hpp"
#include "command_table.hpp"
#include "internal.hpp"

namespace amctl::gcode {

using detail::iequals;
using detail::kMaxLimit;
using detail::starts_with_ci;
using detail::to_upper;

void Interpreter::handle_extended(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  const std::string_view name = cmd.name;
  // KEY=number: the value, or 0 with has = false when KEY is absent; an error otherwise.
  auto number_arg = [&](std::string_view key, bool& present) {
    std::string_view text;
    std::uint32_t col = 0;
    present = find_extended_arg(cmd, key, text, col);
    if (!present) return 0.0;
    double v = 0.0;
    const std::size_t used = parse_float_value(text, v);  // Klipper: Python's float()
    if (used == 0 || used != text.size() || !std::isfinite(v)) {
      fail(line_no, col, fmt::format("{} {}= expects a number, found '{}'", cmd.name, key, text));
    }
    return v;
  };
  if (handle_klipper_state(cmd, line_no, sink)) return;  // klipper_state.cpp
  if (handle_step_tuning(cmd, line_no, sink)) return;    // step_tuning.cpp
  if (iequals(name, "SET_VELOCITY_LIMIT")) {
    LimitsCommand lc;
    lc.source = LimitsCommand::Source::set_velocity_limit;
    lc.line = line_no;
    bool has = false;
    double v = number_arg("VELOCITY", has);
    if (has) lc.velocity = v;
    v = number_arg("ACCEL", has);
    if (has) lc.accel = v;
    v = number_arg("SQUARE_CORNER_VELOCITY", has);
    if (has) lc.square_corner_velocity = v;
    v = number_arg("MINIMUM_CRUISE_RATIO", has);
    if (has) lc.minimum_cruise_ratio = v;
    v = number_arg("ACCEL_TO_DECEL", has);
    if (has) lc.accel_to_decel = v;
    auto bad = [&](const std::optional<double>& o, std::string_view key, bool allow_zero) {
      if (o && (*o < 0.0 || (!allow_zero && *o == 0.0) || *o > kMaxLimit)) {
        fail(line_no, cmd.args_column,
             fmt::format("SET_VELOCITY_LIMIT {} must be {} 0 and <= {:g}, got {}", key,
                         allow_zero ? ">=" : ">", kMaxLimit, *o));
      }
    };
    // A velocity or an acceleration a machine can have: 1e-300 passes "> 0" but makes every
    // move take for ever (PhysicalRange, core/quantity.hpp).
    auto physical = [&](const std::optional<double>& o, std::string_view key, const PhysicalRange& r,
                        bool allow_zero) {
      if (o && !(allow_zero && *o == 0.0) && !in_range(r, *o)) {
        fail(line_no, cmd.args_column,
             detail::out_of_range(fmt::format("SET_VELOCITY_LIMIT {}", key), r, *o) +
                 (allow_zero ? " (or 0)" : ""));
      }
    };
    bad(lc.velocity, "VELOCITY", false);
    bad(lc.accel, "ACCEL", false);
    bad(lc.square_corner_velocity, "SQUARE_CORNER_VELOCITY", true);
    bad(lc.minimum_cruise_ratio, "MINIMUM_CRUISE_RATIO", true);
    bad(lc.accel_to_decel, "ACCEL_TO_DECEL", false);
    physical(lc.velocity, "VELOCITY", kSpeedRange, false);
    physical(lc.accel, "ACCEL", kAccelRange, false);
    physical(lc.square_corner_velocity, "SQUARE_CORNER_VELOCITY", kSpeedRange, true);
    physical(lc.accel_to_decel, "ACCEL_TO_DECEL", kAccelRange, false);
    if (lc.minimum_cruise_ratio && *lc.minimum_cruise_ratio >= 1.0) {
      fail(line_no, cmd.args_column, "SET_VELOCITY_LIMIT MINIMUM_CRUISE_RATIO must be < 1");
    }
    sink.on_limits(lc);
    return;
  }
  if (iequals(name, "SET_KINEMATIC_POSITION")) {
    bool has = false;
    for (int a = 0; a < 3; ++a) {
      const char key[2] = {"XYZ"[a], 0};
      double v = number_arg(key, has);
      if (has) {
        // gcode_move.py keeps base_position: the file's coordinate keeps its G92 offset.
        const double base = pos_[a] - gcode_pos_[a];
        pos_[a] = v;
        gcode_pos_[a] = v - base;
      }
    }
    homed_axes_ = 0x7u;  // Klipper marks the axes homed
    sink.on_step_flush(line_no);  // toolhead.set_position flushes the step generation
    after_position_set(0x7u);
    sink.on_set_position(exclude_.transform ? exclude_.toolhead_mm : pos_, line_no);
    for (std::size_t pair = 0; pair < opt_.dual_carriages.size(); ++pair) {
      // cartesian.py set_position: a homed axis gets the rail range of its primary carriage.
      const auto& o = opt_.dual_carriages[pair];
      const std::size_t c = carriages_[pair][1].mode == CarriageMode::primary ? 1 : 0;
      sink.on_axis_range(o.axis, o.position_min_mm[c], o.position_max_mm[c], line_no);
    }
    return;
  }
  if (iequals(name, "SET_RETRACTION")) {
    bool has = false;
    double v = number_arg("RETRACT_LENGTH", has);
    if (has) opt_.retract_length_mm = std::max(0.0, v);
    v = number_arg("RETRACT_SPEED", has);
    if (has && v > 0 && !in_range(kSpeedRange, v)) {
      fail(line_no, cmd.args_column, detail::out_of_range("SET_RETRACTION RETRACT_SPEED", kSpeedRange, v));
    }
    if (has && v > 0) opt_.retract_speed_mm_s = v;
    v = number_arg("UNRETRACT_EXTRA_LENGTH", has);
    if (has) opt_.unretract_extra_length_mm = v;
    v = number_arg("UNRETRACT_SPEED", has);
    if (has && v > 0 && !in_range(kSpeedRange, v)) {
      fail(line_no, cmd.args_column, detail::out_of_range("SET_RETRACTION UNRETRACT_SPEED", kSpeedRange, v));
    }
    if (has && v > 0) opt_.unretract_speed_mm_s = v;
    return;
  }
  if (iequals(name, "TEMPERATURE_WAIT") || iequals(name, "SET_HEATER_TEMPERATURE")) {
    HeaterCommand h;
    std::string_view text;
    std::uint32_t col = 0;
    if (find_extended_arg(cmd, "SENSOR", text, col) || find_extended_arg(cmd, "HEATER", text, col)) {
      h.kind = starts_with_ci(text, "heater_bed") ? HeaterCommand::Kind::bed : HeaterCommand::Kind::hotend;
    }
    bool has = false;
    double v = number_arg("TARGET", has);
    if (!has) v = number_arg("MINIMUM", has);
    h.target_c = has ? v : 0.0;
    h.wait = iequals(name, "TEMPERATURE_WAIT");
    h.line = line_no;
    if (!h.wait) heater_target_c_[static_cast<std::size_t>(h.kind)] = h.target_c;
    sink.on_heater(h);
    return;
  }
  if (iequals(name, "TURN_OFF_HEATERS")) {  // Klipper heaters.py: every target to 0
    heater_target_c_ = {0.0, 0.0, 0.0};
    note_ignored(name);
    return;
  }
  if (detail::is_untimed_extended(name)) {
    sink.on_untimed(to_upper(name), line_no);
    sink.on_wait_moves(line_no);
    return;
  }
  if (detail::is_ignored_extended(name)) {
    note_ignored(name);
    return;
  }
  note_unknown(name, line_no);
}

}  // namespace amctl::gcode
