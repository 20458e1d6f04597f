#include "amctl/gcode/interpreter.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "annotations.hpp"
#include "command_table.hpp"
#include "internal.hpp"
#include "lexer.hpp"

// The modal state and the dispatch of the interpreter. The rest lives by concept next to it
// (docs/gcode.md, "Source files"): lexer.hpp (fast-path lexer), annotations.cpp (slicer
// comments), arcs.cpp (G2/G3), retraction.cpp (G10/G11, M207/M208), extended.cpp (Klipper
// extended commands), command_table.cpp (ignored and untimed commands).

namespace amctl::gcode {

using detail::kMaxCoordinate_mm;
using detail::kMaxLimit;
using detail::to_upper;
using detail::trim;

[[gnu::always_inline]] inline bool Interpreter::try_plain_move(std::string_view line, std::uint64_t line_no,
                                                                EventSink& sink) {
  detail::PlainMove pm;
  if (!detail::lex_plain_move(line, pm)) return false;
  // Everything that could fail is checked before any state changes, so a line that fails
  // here is handed whole to the general path and reported there.
  const bool has_f = (pm.present >> 4) & 1u;
  if (has_f && !in_range(detail::kFeedRange, pm.value[4] * unit_mm_)) return false;
  std::array<double, 4> new_gcode;
  std::array<double, 4> target = modal_target(pm.present & 0xFu, pm.value.data(), new_gcode);
  for (std::size_t a = 0; a < 4; ++a) {
    if (!(std::fabs(target[a]) <= kMaxCoordinate_mm)) return false;
  }
  if (pm.has_comment && !pm.comment.empty()) handle_comment(pm.comment, line_no, sink);
  if (has_f) feed_mm_s_ = pm.value[4] * unit_mm_ / 60.0;
  if ((pm.present & 0xFu) == 0) return true;  // F only: sets the speed of later moves
  const bool clamped = soft_endstops_ && soft_clamp(target, &new_gcode);
  gcode_pos_ = new_gcode;
  if (target == pos_ && !clamped) return true;
  MoveRequest m;
  m.start_mm = pos_;
  m.end_mm = target;
  m.speed_mm_s = feed_mm_s_ * speed_factor_;
  m.line = line_no;
  m.layer = notes_.layer;
  m.feature = notes_.feature;
  m.clamped = clamped;
  pos_ = target;
  sink.on_move(m);
  return true;
}

Interpreter::Interpreter(InterpreterOptions options, std::string source_name)
    : opt_(options), source_(std::move(source_name)) {
  for (std::size_t a = 0; a < 3; ++a) {
    if (opt_.soft_min_mm[a]) require_finite("soft endstop minimum", *opt_.soft_min_mm[a]);
    if (opt_.soft_max_mm[a]) require_finite("soft endstop maximum", *opt_.soft_max_mm[a]);
    soft_endstops_ = soft_endstops_ || opt_.soft_min_mm[a] || opt_.soft_max_mm[a];
  }
  // idex_modes.py: each pair starts with its first carriage PRIMARY, the second parked at 0.
  carriages_.assign(opt_.dual_carriages.size(),
                    {Carriage{CarriageMode::primary, 1.0, 0.0}, Carriage{}});
  stepper_carriages_ = opt_.stepper_carriages;
  require_positive("arcs.mm_per_arc_segment", opt_.mm_per_arc_segment);
  require_non_negative("arcs.min_arc_segment_mm", opt_.min_arc_segment_mm);
  require_non_negative("arcs.max_arc_segment_mm", opt_.max_arc_segment_mm);
  require_non_negative("arcs.segments_per_second", opt_.arc_segments_per_second);
  require_non_negative("retraction.retract_length", opt_.retract_length_mm);
  require_positive("retraction.retract_speed", opt_.retract_speed_mm_s);
  require_positive("retraction.unretract_speed", opt_.unretract_speed_mm_s);
  require_non_negative("arcs.min_circle_segments", opt_.min_circle_segments);
  require_non_negative("retraction.lift_z", opt_.lift_z_mm);
  require_positive("retraction.lift_z_speed", opt_.lift_z_speed_mm_s);
}

void Interpreter::fail(std::uint64_t line_no, std::uint32_t col, const std::string& msg) const {
  throw Error(SourceLocation{source_, line_no, col}, msg);
}

void Interpreter::run(LineReader& reader, EventSink& sink) {
  std::string_view line;
  while (reader.next(line)) feed(line, reader.line_number(), sink);
}

void Interpreter::set_expander(CommandExpander* expander) {
  expander_ = expander;
  update_path_choice();
}

InterpreterState Interpreter::state() const {
  InterpreterState s;
  s.position_mm = pos_;
  s.gcode_position_mm = gcode_pos_;
  s.absolute_coordinates = absolute_xyz_;
  s.absolute_extrude = absolute_e_;
  s.feed_mm_min = feed_mm_s_ * 60.0 / unit_mm_;
  s.speed_factor = speed_factor_;
  s.extrude_factor = extrude_factor_;
  s.homed_axes = homed_axes_;
  s.hotend_target_c = heater_target_c_[0];
  s.bed_target_c = heater_target_c_[1];
  s.chamber_target_c = heater_target_c_[2];
  s.active_extruder = active_extruder_;
  s.homing_origin_mm = homing_offset_mm_;
  if (opt_.exclude_object == InterpreterOptions::ExcludeObjectMode::active) {
    s.exclude_object = true;
    s.objects = exclude_.objects;
    s.excluded_objects = exclude_.excluded;
    s.current_object = exclude_.current;
  }
  return s;
}

bool Interpreter::parse(std::string_view line, std::uint64_t line_no) {
  if (parse_line(line, cmd_, issue_)) return true;
  if (opt_.strict) fail(line_no, issue_.column, fmt::format("{} in '{}'", issue_.message, trim(line)));
  ++skipped_lines_;
  return false;
}

void Interpreter::feed(std::string_view line, std::uint64_t line_no, EventSink& sink) {
  // Most lines of a sliced file are plain G0/G1 moves: a dedicated lexer takes them without
  // building a Command and a 26-letter Params (docs/gcode.md, "Fast path").
  if (!general_path_only_ && try_plain_move(line, line_no, sink)) return;
  if (!parse(line, line_no)) return;
  if (!cmd_.comment.empty()) handle_comment(cmd_.comment, line_no, sink);
  if (expander_ != nullptr && cmd_.kind != CommandKind::none && expand(line, line_no, sink)) return;
  dispatch(line_no, sink);
}

bool Interpreter::expand(std::string_view line, std::uint64_t line_no, EventSink& sink) {
  Expansion x = expander_->expand(cmd_, line, line_no, state());
  switch (x.kind) {
    case Expansion::Kind::none: return false;
    case Expansion::Kind::done: return true;
    case Expansion::Kind::builtin:
      // The renamed built-in: parsed and handled as itself, never offered again.
      if (parse(x.text, line_no)) dispatch(line_no, sink);
      return true;
    case Expansion::Kind::script: {
      // Every line of the script counts at the calling line (docs/macros.md).
      std::string_view rest = x.text;
      while (!rest.empty()) {
        const std::size_t nl = rest.find('\n');
        const std::string_view piece = rest.substr(0, nl);
        try {
          feed(piece, line_no, sink);
        } catch (const Error& e) {
          // An error placed in another file (a macro's bound, at its printer.cfg line) stays
          // where it is: that is the line to fix.
          if (!e.where().file.empty() && e.where().file != source_) throw;
          // The column belongs to the macro's line, not to the file's: name that line instead.
          fail(line_no, 0, fmt::format("{} (in the lines of macro {}: '{}')", e.detail(), x.name,
                                       trim(piece)));
        }
        if (nl == std::string_view::npos) break;
        rest.remove_prefix(nl + 1);
      }
      expander_->end_script(x.id);
      return true;
    }
  }
  return false;
}

void Interpreter::dispatch(std::uint64_t line_no, EventSink& sink) {
  switch (cmd_.kind) {
    case CommandKind::none:
      return;
    case CommandKind::word:
      try {
        handle_word(cmd_, line_no, sink);
      } catch (const detail::SkipMalformedLine&) {
        ++skipped_lines_;
      }
      return;
    case CommandKind::extended:
      handle_extended(cmd_, line_no, sink);
      return;
  }
}

void Interpreter::note_unknown(std::string_view name, std::uint64_t line_no) {
  std::string key = to_upper(name);
  if (const auto it = unknown_index_.find(key); it != unknown_index_.end()) {
    ++unknown_[it->second].count;
    return;
  }
  if (unknown_index_.size() >= kMaxUnknownCommandNames) key = std::string(kOtherUnknownCommands);
  if (const auto it = unknown_index_.find(key); it != unknown_index_.end()) {
    ++unknown_[it->second].count;
    return;
  }
  unknown_index_.emplace(key, unknown_.size());
  unknown_.push_back(UnknownCommand{std::move(key), line_no, 1});
}

void Interpreter::note_ignored(std::string_view name) { ++ignored_[to_upper(name)]; }

void Interpreter::handle_comment(std::string_view c, std::uint64_t line_no, EventSink& sink) {
  if (detail::read_annotation(c, line_no, notes_)) sink.on_layer_change(notes_.layer, line_no);
}

void Interpreter::handle_word(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  const char L = cmd.letter;
  const int code = cmd.code;
  auto params = [&]() -> const Params& {
    if (!parse_params(cmd, params_, issue_)) {
      // A malformed parameter ("G1 X1.2.3") is a malformed line: skipped in lenient mode
      // (feed() counts it), an error otherwise. Parameters are read before any state changes.
      if (!opt_.strict) throw detail::SkipMalformedLine{};
      fail(line_no, issue_.column, fmt::format("{} in {}", issue_.message, cmd.name));
    }
    return params_;
  };
  if (L == 'G' && cmd.subcode < 0) {
    switch (code) {
      case 0:
      case 1:
        do_move(params(), line_no, sink);
        return;
      case 2:
      case 3:
        if (!opt_.arcs_enabled) {  // Klipper without [gcode_arcs]: "Unknown command"
          note_unknown(cmd.name, line_no);
          return;
        }
        do_arc(cmd, params(), code == 2, line_no, sink);
        return;
      case 4: {
        const Params& p = params();
        double s = 0.0;
        if (p.has('S')) s = p.get('S');
        else if (p.has('P')) s = p.get('P') / 1000.0;
        if (!(s >= 0.0) || s > kDurationRange.max) {
          fail(line_no, p.column[p.has('S') ? 'S' - 'A' : 'P' - 'A'],
               detail::out_of_range("G4 dwell", kDurationRange, s));
        }
        sink.on_dwell(s, line_no);
        return;
      }
      case 10:
      case 11:
        firmware_retraction(code == 10, params(), line_no, sink);
        return;
      case 17: case 18: case 19:
        if (!opt_.arcs_enabled) {  // registered by Klipper's gcode_arcs.py too
          note_unknown(cmd.name, line_no);
          return;
        }
        arc_plane_ = code;
        return;
      case 20:
        unit_mm_ = 25.4;
        return;
      case 21:
        unit_mm_ = 1.0;
        return;
      case 90:
        absolute_xyz_ = true;
        return;
      case 91:
        absolute_xyz_ = false;
        return;
      case 92: {
        const Params& p = params();
        bool any = false;
        for (int a = 0; a < 4; ++a) {
          const char l = "XYZE"[a];
          if (p.has(l)) {
            gcode_pos_[a] = p.get(l) * unit_mm_;
            any = true;
          }
        }
        if (!any) gcode_pos_ = {0, 0, 0, 0};
        return;
      }
      default:
        break;
    }
  }
  if (L == 'M' && cmd.subcode < 0) {
    switch (code) {
      case 82:
        absolute_e_ = true;
        return;
      case 83:
        absolute_e_ = false;
        return;
      case 400:
        sink.on_wait_moves(line_no);
        return;
      case 18:
      case 84:
        // Motors off: the firmware finishes every move first. Klipper (stepper_enable.py
        // set_motors_enable) flushes the step generation, then dwells.
        if (opt_.motor_off_dwell_s > 0.0) {
          sink.on_step_flush(line_no);
          sink.on_dwell(opt_.motor_off_dwell_s, line_no);
        } else {
          sink.on_wait_moves(line_no);
        }
        note_ignored(cmd.name);
        return;
      case 211: {
        // Marlin M211 S0/S1: software endstops off/on (soft_endstop._enabled); without S it
        // only reports them.
        const Params& p = params();
        if (p.has('S')) soft_enabled_ = p.get('S') != 0.0;
        return;
      }
      case 220: {
        const Params& p = params();
        double s = p.get_or('S', 100.0);
        if (!in_range(kPercentRange, s)) {
          fail(line_no, p.column['S' - 'A'], detail::out_of_range("M220 S", kPercentRange, s));
        }
        speed_factor_ = s / 100.0;
        return;
      }
      case 221: {
        const Params& p = params();
        double s = p.get_or('S', 100.0);
        if (!in_range(kPercentRange, s)) {
          fail(line_no, p.column['S' - 'A'], detail::out_of_range("M221 S", kPercentRange, s));
        }
        extrude_factor_ = s / 100.0;
        return;
      }
      case 73: {
        const Params& p = params();
        ProgressMarker m;
        if (p.has('P')) m.percent = p.get('P');
        if (p.has('R')) m.remaining_min = p.get('R');
        m.line = line_no;
        sink.on_progress(m);
        return;
      }
      case 104: case 109: case 140: case 190: case 141: case 191: {
        const Params& p = params();
        HeaterCommand h;
        h.kind = (code == 104 || code == 109) ? HeaterCommand::Kind::hotend
                 : (code == 140 || code == 190) ? HeaterCommand::Kind::bed
                                                : HeaterCommand::Kind::chamber;
        h.wait = code == 109 || code == 190 || code == 191;
        h.target_c = p.has('S') ? p.get('S') : p.get_or('R', 0.0);
        h.tool = static_cast<int>(p.get_or('T', 0.0));
        h.line = line_no;
        heater_target_c_[static_cast<std::size_t>(h.kind)] = h.target_c;
        sink.on_heater(h);
        return;
      }
      case 106: {
        const Params& p = params();
        double s = p.get_or('S', 255.0);
        sink.on_fan(std::clamp(s > 1.0 ? s / 255.0 : s, 0.0, 1.0), line_no);
        return;
      }
      case 107:
        sink.on_fan(0.0, line_no);
        return;
      case 201: case 203: case 204: case 205: case 566: {
        LimitsCommand lc;
        lc.source = code == 201   ? LimitsCommand::Source::m201
                    : code == 203 ? LimitsCommand::Source::m203
                    : code == 204 ? LimitsCommand::Source::m204
                    : code == 205 ? LimitsCommand::Source::m205
                                  : LimitsCommand::Source::m566;
        lc.params = params();
        for (int i = 0; i < 26; ++i) {
          if ((lc.params.present >> i) & 1u) {
            double v = lc.params.value[static_cast<std::size_t>(i)];
            if (v < 0.0 || v > kMaxLimit) {
              fail(line_no, lc.params.column[static_cast<std::size_t>(i)],
                   fmt::format("{} {} must be in [0, {:g}], got {}", cmd.name,
                               static_cast<char>('A' + i), kMaxLimit, v));
            }
            // M201 accelerations, M203 feedrates (mm/s, or mm/min on RepRapFirmware), M204
            // accelerations: 0 is ignored as the firmware ignores it; a positive value must be
            // one a machine can have (1e-300 would make the moves take for ever).
            const PhysicalRange& r = code == 203 ? kSpeedRange : kAccelRange;
            if ((code == 201 || code == 203 || code == 204) && v > 0.0 && v < r.min) {
              fail(line_no, lc.params.column[static_cast<std::size_t>(i)],
                   detail::out_of_range(fmt::format("{} {}", cmd.name, static_cast<char>('A' + i)), r, v) +
                       " (or 0, which the firmware ignores)");
            }
          }
        }
        lc.line = line_no;
        sink.on_limits(lc);
        return;
      }
      case 207:
      case 208:
        set_firmware_retraction(code, params(), line_no);
        return;
      case 593: {  // Marlin input shaping: passed on, and counted as ignored as before
        const Params& p = params();
        InputShapingCommand c;
        const bool sx = p.has('X'), sy = p.has('Y');
        c.x = sx || !sy;
        c.y = sy || !sx;
        if (p.has('F')) c.freq_hz = p.get('F');
        if (p.has('D')) c.damping_ratio = p.get('D');
        if (p.has('T')) c.type = p.get('T');
        c.line = line_no;
        note_ignored(cmd.name);
        sink.on_input_shaping(c);
        return;
      }
      default:
        break;
    }
  }
  if (detail::is_untimed_word(L, code)) {
    if (L == 'G' && code == 28) {
      const Params& p = params();
      const bool any = !opt_.home_all_axes && (p.has('X') || p.has('Y') || p.has('Z'));
      for (int a = 0; a < 3; ++a) {
        if (!any || p.has("XYZ"[a])) {
          pos_[a] = opt_.home_position_mm[static_cast<std::size_t>(a)];
          // gcode_move.py: homing sets the base to the SET_GCODE_OFFSET offset.
          gcode_pos_[a] = pos_[a] - homing_offset_mm_[static_cast<std::size_t>(a)];
          homed_axes_ |= 1u << a;
        }
      }
      sink.on_untimed("G28", line_no);
      unsigned dc_homed = 0;  // bit per dual-carriage pair homed here
      for (std::size_t pair = 0; pair < opt_.dual_carriages.size(); ++pair) {
        if (any && !p.has("XY"[opt_.dual_carriages[pair].axis])) continue;
        home_dual_carriage(pair);
        dc_homed |= 1u << pair;
      }
      after_position_set(any ? (p.has('X') ? 1u : 0u) | (p.has('Y') ? 2u : 0u) | (p.has('Z') ? 4u : 0u) : 7u);
      sink.on_set_position(exclude_.transform ? exclude_.toolhead_mm : pos_, line_no);
      for (std::size_t pair = 0; pair < opt_.dual_carriages.size(); ++pair) {
        if ((dc_homed >> pair) & 1u) send_carriage_range(pair, line_no, sink);
      }
      return;
    }
    sink.on_untimed(cmd.name, line_no);
    sink.on_wait_moves(line_no);
    return;
  }
  if (detail::is_ignored_word(L, code)) {
    note_ignored(L == 'T' ? std::string_view("T") : cmd.name);
    return;
  }
  note_unknown(cmd.name, line_no);
}

void Interpreter::apply_feed(const Params& p, std::uint64_t line_no) {
  if (!p.has('F')) return;
  const double f = p.get('F');
  if (!in_range(detail::kFeedRange, f * unit_mm_)) {
    fail(line_no, p.column['F' - 'A'], detail::out_of_range("feedrate F", detail::kFeedRange, f * unit_mm_));
  }
  feed_mm_s_ = f * unit_mm_ / 60.0;
}

std::array<double, 4> Interpreter::modal_target(unsigned axes, const double* value,
                                                std::array<double, 4>& new_gcode) const {
  std::array<double, 4> target = pos_;
  new_gcode = gcode_pos_;
  for (std::size_t a = 0; a < 3; ++a) {
    if (!((axes >> a) & 1u)) continue;
    const double v = value[a] * unit_mm_;
    if (absolute_xyz_) {
      target[a] = pos_[a] + (v - gcode_pos_[a]);
      new_gcode[a] = v;
    } else {
      target[a] = pos_[a] + v;
      new_gcode[a] += v;
    }
  }
  if ((axes >> 3) & 1u) {
    // Like Klipper, E is relative when either G91 or M83 is in force.
    const double v = value[3] * unit_mm_;
    const bool rel = !absolute_xyz_ || !absolute_e_;
    target[3] = pos_[3] + (rel ? v : v - gcode_pos_[3]) * extrude_factor_;
    new_gcode[3] = rel ? gcode_pos_[3] + v : v;
  }
  return target;
}

std::array<double, 4> Interpreter::target_of(const Params& p,
                                             std::array<double, 4>& new_gcode) const {
  std::array<double, 4> value{};
  unsigned axes = 0;
  for (std::size_t a = 0; a < 4; ++a) {
    const char l = "XYZE"[a];
    if (!p.has(l)) continue;
    value[a] = p.get(l);
    axes |= 1u << a;
  }
  return modal_target(axes, value.data(), new_gcode);
}

void Interpreter::do_move(const Params& p, std::uint64_t line_no, EventSink& sink) {
  require_numbers(p, line_no);
  apply_feed(p, line_no);
  constexpr std::uint32_t kAxes = (1u << ('X' - 'A')) | (1u << ('Y' - 'A')) |
                                  (1u << ('Z' - 'A')) | (1u << ('E' - 'A'));
  if ((p.present & kAxes) == 0) {
    // F only: sets the speed of later moves. Klipper still passes the (unchanged) position
    // through the move transform, which exclude_object's state machine sees.
    if (exclude_.transform) emit_move(pos_, feed_mm_s_ * speed_factor_, line_no, sink, false);
    return;
  }
  std::array<double, 4> new_gcode;
  std::array<double, 4> target = target_of(p, new_gcode);
  const bool clamped = soft_endstops_ && soft_clamp(target, &new_gcode);
  gcode_pos_ = new_gcode;
  emit_move(target, feed_mm_s_ * speed_factor_, line_no, sink, false, false, clamped);
}

bool Interpreter::soft_clamp(std::array<double, 4>& target, std::array<double, 4>* gcode) const {
  bool changed = false;
  if (!soft_enabled_) return false;  // M211 S0
  for (std::size_t a = 0; a < 3; ++a) {
    if ((homed_axes_ & (1u << a)) == 0) continue;  // Marlin: axis_was_homed()
    double v = target[a];
    if (opt_.soft_min_mm[a]) v = std::max(v, *opt_.soft_min_mm[a]);
    if (opt_.soft_max_mm[a]) v = std::min(v, *opt_.soft_max_mm[a]);
    if (v == target[a]) continue;
    if (gcode) (*gcode)[a] -= target[a] - v;
    target[a] = v;
    changed = true;
  }
  return changed;
}

void Interpreter::require_numbers(const Params& p, std::uint64_t line_no) const {
  // A bare letter ("G1 X", a file cut after "E") has no meaning in a move.
  if (p.bare == 0) return;
  for (int i = 0; i < 26; ++i) {
    if ((p.bare >> i) & 1u) {
      fail(line_no, p.column[static_cast<std::size_t>(i)] + 1,
           fmt::format("expected a number after '{}' (is the file truncated?)", static_cast<char>('A' + i)));
    }
  }
}

void Interpreter::emit_move(const std::array<double, 4>& target, double speed_mm_s,
                            std::uint64_t line_no, EventSink& sink, bool from_arc,
                            bool from_retract, bool clamped) {
  // A move clamped to no motion still reaches the planner (which drops it) to be counted.
  // Under exclude_object's transform every move goes through it, as in Klipper.
  if (target == pos_ && !clamped && !exclude_.transform) return;
  // Every coordinate must stay finite and within a sane range: larger values come from
  // overflowing arithmetic (G20 with 1e308, G91 accumulation, M221 S1e308, huge arc offsets)
  // and would poison the planner with inf/NaN.
  for (std::size_t a = 0; a < 4; ++a) {
    if (!(std::fabs(target[a]) <= kMaxCoordinate_mm)) {
      const char l = "XYZE"[a];
      const std::uint32_t col = params_.has(l) ? params_.column[static_cast<std::size_t>(l - 'A')]
                                               : cmd_.args_column;
      fail(line_no, col,
           fmt::format("{} position {} mm is out of range: expected |{}| <= {:g} mm", l,
                       target[a], l, kMaxCoordinate_mm));
    }
  }
  MoveRequest m;
  m.start_mm = pos_;
  m.end_mm = target;
  m.speed_mm_s = speed_mm_s;
  m.line = line_no;
  m.layer = notes_.layer;
  m.feature = notes_.feature;
  m.from_arc = from_arc;
  m.from_firmware_retract = from_retract;
  m.clamped = clamped;
  if (exclude_.transform) {
    exclude_move(target, m, sink);  // klipper_state.cpp
    return;
  }
  pos_ = target;
  sink.on_move(m);
}

}  // namespace amctl::gcode
