// Klipper commands that change the interpreter's state, each modelled on the Klipper module
// that defines it (read at Klipper 84104bbb; nothing of it copied):
//  - SAVE_GCODE_STATE / RESTORE_GCODE_STATE (klippy/extras/gcode_move.py);
//  - ACTIVATE_EXTRUDER (klippy/kinematics/extruder.py, gcode_move.py's activate handler);
//  - EXCLUDE_OBJECT_DEFINE / _START / _END, EXCLUDE_OBJECT (klippy/extras/exclude_object.py),
//    with its move transform;
//  - SET_DUAL_CARRIAGE, SAVE_ / RESTORE_DUAL_CARRIAGE_STATE (klippy/kinematics/idex_modes.py).
// docs/gcode.md ("Klipper state commands") gives the rules with their sources.
#include <algorithm>
#include <cctype>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "amctl/core/quantity.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "internal.hpp"

namespace amctl::gcode {

using detail::iequals;
using detail::kMaxLimit;
using detail::to_upper;

namespace {

/// KEY=VALUE of an extended command, quotes removed; nullopt when absent.
std::optional<std::string> text_arg(const Command& cmd, std::string_view key,
                                    std::uint32_t* col = nullptr) {
  std::string_view text;
  std::uint32_t c = 0;
  if (!find_extended_arg(cmd, key, text, c)) return std::nullopt;
  if (col) *col = c;
  if (text.size() >= 2 && (text.front() == '"' || text.front() == '\'') &&
      text.back() == text.front()) {
    text = text.substr(1, text.size() - 2);
  }
  return std::string(text);
}

bool contains(const std::vector<std::string>& v, std::string_view s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

void insert_sorted(std::vector<std::string>& v, std::string s) {
  v.insert(std::upper_bound(v.begin(), v.end(), s), std::move(s));
}

}  // namespace

bool Interpreter::handle_klipper_state(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  const std::string_view name = cmd.name;
  if (opt_.bed_mesh && (iequals(name, "BED_MESH_PROFILE") || iequals(name, "BED_MESH_CLEAR") ||
                        iequals(name, "BED_MESH_OFFSET"))) {
    handle_bed_mesh(cmd, line_no, sink);
    return true;
  }
  if (iequals(name, "SAVE_GCODE_STATE")) {
    save_gcode_state(cmd, line_no);
    return true;
  }
  if (iequals(name, "RESTORE_GCODE_STATE")) {
    restore_gcode_state(cmd, line_no, sink);
    return true;
  }
  if (iequals(name, "SET_GCODE_OFFSET")) {
    set_gcode_offset(cmd, line_no, sink);
    return true;
  }
  if (iequals(name, "ACTIVATE_EXTRUDER")) {
    // extruder.py: a different extruder flushes the look-ahead (a full stop), and gcode_move
    // then starts the new extruder's E at 0 with the extrusion factor back at 1.
    note_ignored(name);
    const std::string e = text_arg(cmd, "EXTRUDER").value_or("");
    if (e.empty() || e == active_extruder_) return true;
    sink.on_step_flush(line_no);
    active_extruder_ = e;
    gcode_pos_[3] = 0.0;
    extrude_factor_ = 1.0;
    return true;
  }
  if (iequals(name, "EXCLUDE_OBJECT_DEFINE") || iequals(name, "EXCLUDE_OBJECT_START") ||
      iequals(name, "EXCLUDE_OBJECT_END") || iequals(name, "EXCLUDE_OBJECT")) {
    switch (opt_.exclude_object) {
      case InterpreterOptions::ExcludeObjectMode::ignored: note_ignored(name); break;
      case InterpreterOptions::ExcludeObjectMode::unknown: note_unknown(name, line_no); break;
      case InterpreterOptions::ExcludeObjectMode::active:
        exclude_object_command(cmd, line_no);
        break;
    }
    return true;
  }
  if (!stepper_carriages_.empty() && iequals(name, "SET_STEPPER_CARRIAGES")) {
    set_stepper_carriages(cmd, line_no, sink);
    return true;
  }
  if (!opt_.dual_carriages.empty() &&
      (iequals(name, "SET_DUAL_CARRIAGE") || iequals(name, "SAVE_DUAL_CARRIAGE_STATE") ||
       iequals(name, "RESTORE_DUAL_CARRIAGE_STATE"))) {
    dual_carriage_command(cmd, line_no, sink);
    return true;
  }
  return false;
}

// ---- SAVE_GCODE_STATE / RESTORE_GCODE_STATE --------------------------------------------------

void Interpreter::save_gcode_state(const Command& cmd, std::uint64_t /*line_no*/) {
  SavedGcodeState s;
  s.absolute_xyz = absolute_xyz_;
  s.absolute_e = absolute_e_;
  s.position_mm = pos_;
  s.gcode_position_mm = gcode_pos_;
  s.feed_mm_s = feed_mm_s_;
  s.speed_factor = speed_factor_;
  s.extrude_factor = extrude_factor_;
  s.homing_offset_mm = homing_offset_mm_;
  saved_states_[text_arg(cmd, "NAME").value_or("default")] = s;
}

void Interpreter::restore_gcode_state(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  const std::string name = text_arg(cmd, "NAME").value_or("default");
  const auto it = saved_states_.find(name);
  if (it == saved_states_.end()) {
    // gcode_move.py raises this error; on a printer it ends the print.
    fail(line_no, cmd.args_column,
         fmt::format("Unknown g-code state: {} (no SAVE_GCODE_STATE NAME={} "
                     "before it; Klipper stops with this error)",
                     name, name));
  }
  const SavedGcodeState s = it->second;
  std::uint32_t col = 0;
  int move = 0;
  if (auto m = text_arg(cmd, "MOVE", &col)) {
    double v = 0.0;
    if (parse_float_value(*m, v) != m->size() || v != std::floor(v)) {
      fail(line_no, col,
           fmt::format("RESTORE_GCODE_STATE MOVE= expects an integer, found '{}'", *m));
    }
    move = v != 0.0;
  }
  double speed_mm_s = s.feed_mm_s * s.speed_factor;  // Klipper's saved `speed`
  if (auto m = text_arg(cmd, "MOVE_SPEED", &col)) {
    double v = 0.0;
    if (parse_float_value(*m, v) != m->size() || !in_range(kSpeedRange, v)) {
      fail(line_no, col,
           fmt::format("RESTORE_GCODE_STATE MOVE_SPEED= must be {}, found '{}'", describe(kSpeedRange), *m));
    }
    if (move) speed_mm_s = v;
  }
  absolute_xyz_ = s.absolute_xyz;
  absolute_e_ = s.absolute_e;
  feed_mm_s_ = s.feed_mm_s;
  speed_factor_ = s.speed_factor;
  extrude_factor_ = s.extrude_factor;
  homing_offset_mm_ = s.homing_offset_mm;
  if (move) {
    std::array<double, 4> target = pos_;
    for (std::size_t a = 0; a < 3; ++a) target[a] = s.position_mm[a];
    params_ = Params{};
    emit_move(target, speed_mm_s, line_no, sink, false);
  }
  // The saved base position (machine - file coordinates) comes back; E continues from the
  // file's saved E (Klipper adds the E travelled since to the base).
  for (std::size_t a = 0; a < 3; ++a)
    gcode_pos_[a] = pos_[a] - (s.position_mm[a] - s.gcode_position_mm[a]);
  gcode_pos_[3] = s.gcode_position_mm[3];
}

void Interpreter::set_gcode_offset(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  // gcode_move.py: X/Y/Z/E set the offset, X_ADJUST... add to it; the base position moves by
  // the change, so the file's coordinates shift; MOVE=1 moves the toolhead by it instead.
  auto number = [&](std::string_view key, double& v) {
    std::uint32_t col = 0;
    const auto t = text_arg(cmd, key, &col);
    if (!t) return false;
    if (parse_float_value(*t, v) != t->size() || !std::isfinite(v) ||
        std::fabs(v) > detail::kMaxCoordinate_mm) {
      fail(line_no, col, fmt::format("SET_GCODE_OFFSET {}= expects a number, found '{}'", key, *t));
    }
    return true;
  };
  std::array<double, 4> delta{};
  for (std::size_t a = 0; a < 4; ++a) {
    const std::string axis(1, "XYZE"[a]);
    double v = 0.0;
    double offset = 0.0;
    if (number(axis, v)) {
      offset = v;
    } else if (number(axis + "_ADJUST", v)) {
      offset = homing_offset_mm_[a] + v;
    } else {
      continue;
    }
    delta[a] = offset - homing_offset_mm_[a];
    homing_offset_mm_[a] = offset;
  }
  double move = 0.0;
  if (number("MOVE", move) && move != 0.0) {
    double speed_mm_s = feed_mm_s_ * speed_factor_;
    double v = 0.0;
    if (number("MOVE_SPEED", v)) {
      if (!in_range(kSpeedRange, v))
        fail(line_no, cmd.args_column, detail::out_of_range("SET_GCODE_OFFSET MOVE_SPEED=", kSpeedRange, v));
      speed_mm_s = v;
    }
    std::array<double, 4> target = pos_;
    for (std::size_t a = 0; a < 4; ++a) target[a] += delta[a];
    params_ = Params{};
    emit_move(target, speed_mm_s, line_no, sink, false);
    return;  // the toolhead moved with the base: the file's coordinates stay
  }
  for (std::size_t a = 0; a < 3; ++a) gcode_pos_[a] -= delta[a];
  gcode_pos_[3] -= delta[3] / extrude_factor_;
}

// ---- EXCLUDE_OBJECT ---------------------------------------------------------------------------

void Interpreter::exclude_object_command(const Command& cmd, std::uint64_t line_no) {
  ExcludeObjects& x = exclude_;
  const std::string_view name = cmd.name;
  auto unregister = [&] {
    if (!x.transform) return;
    // gcode_move.reset_last_position(): its position becomes the toolhead's again.
    for (std::size_t a = 0; a < 4; ++a) gcode_pos_[a] += x.toolhead_mm[a] - pos_[a];
    pos_ = x.toolhead_mm;
    x.transform = false;
    x.in_excluded_region = false;
    update_path_choice();
  };
  auto exclude = [&](const std::string& object) {
    if (!x.transform && !x.bypass) {
      // _register_transform: tracks from where the toolhead is, and needs five extruding
      // moves before it skips any (to learn the extruder's state).
      x.transform = true;
      x.offset_mm = {0, 0, 0, 0};
      x.max_extruded_mm = x.max_excluded_mm = x.extruder_adj_mm = 0.0;
      x.initial_extrusion_moves = 5;
      x.toolhead_mm = x.last_extruded_mm = x.last_excluded_mm = pos_;
      update_path_choice();
    }
    if (!contains(x.excluded, object)) insert_sorted(x.excluded, object);
    if (std::none_of(x.ever_excluded.begin(), x.ever_excluded.end(),
                     [&](const ExcludedObject& o) { return o.name == object; })) {
      x.ever_excluded.push_back(ExcludedObject{object, line_no});
    }
  };
  const auto object = text_arg(cmd, "NAME");
  const std::string upper = object ? to_upper(*object) : std::string();
  if (iequals(name, "EXCLUDE_OBJECT_DEFINE")) {
    if (text_arg(cmd, "RESET").value_or("") != "") {
      x.objects.clear();
      x.excluded.clear();
      x.current.reset();
      x.in_excluded_region = false;
      unregister();
    } else if (!upper.empty()) {
      insert_sorted(x.objects, upper);
    }
    return;
  }
  if (iequals(name, "EXCLUDE_OBJECT_START")) {
    if (!object)
      fail(line_no, cmd.args_column, "EXCLUDE_OBJECT_START needs NAME= (Klipper: missing NAME)");
    if (!contains(x.objects, upper)) insert_sorted(x.objects, upper);
    x.current = upper;
    return;
  }
  if (iequals(name, "EXCLUDE_OBJECT_END")) {
    x.current.reset();  // a NAME that differs is only reported by Klipper
    return;
  }
  // EXCLUDE_OBJECT [NAME=] [CURRENT=1] [RESET=1]: any non-empty value counts, as in Klipper.
  if (text_arg(cmd, "RESET").value_or("") != "") {
    if (!upper.empty()) {
      std::erase(x.excluded, upper);
    } else {
      x.excluded.clear();
    }
  } else if (!upper.empty()) {
    exclude(upper);
  } else if (text_arg(cmd, "CURRENT").value_or("") != "") {
    if (!x.current) {
      fail(line_no, cmd.args_column,
           "EXCLUDE_OBJECT CURRENT=1: there is no current object to cancel "
           "(Klipper stops with this error)");
    }
    exclude(*x.current);
  }
}

void Interpreter::exclude_move(const std::array<double, 4>& target, const MoveRequest& proto,
                               EventSink& sink) {
  ExcludeObjects& x = exclude_;
  auto& off = x.offset_mm;
  const bool skip = x.current && contains(x.excluded, *x.current) && x.initial_extrusion_moves == 0;
  if (skip) {
    // _ignore_move: the toolhead stays; the offset keeps what the file moved since.
    x.in_excluded_region = true;
    for (std::size_t a = 0; a < 3; ++a) off[a] = target[a] - x.last_extruded_mm[a];
    off[3] += target[3] - pos_[3];
    pos_ = target;
    x.last_excluded_mm = target;
    x.max_excluded_mm = std::max(x.max_excluded_mm, target[3]);
    ++x.skipped_moves;
    return;
  }
  if (x.in_excluded_region) {
    // _move_from_excluded_region: compensates a retraction state that differs between the
    // object printed last and the one skipped.
    x.in_excluded_region = false;
    x.extruder_adj_mm =
        x.max_excluded_mm - x.last_excluded_mm[3] - (x.max_extruded_mm - x.last_extruded_mm[3]);
  }
  // _normal_move
  if (x.initial_extrusion_moves > 0 && pos_[3] != target[3]) --x.initial_extrusion_moves;
  pos_ = target;
  x.last_extruded_mm = target;
  x.max_extruded_mm = std::max(x.max_extruded_mm, target[3]);
  if ((off[0] != 0.0 || off[1] != 0.0) &&
      (target[0] != x.last_excluded_mm[0] || target[1] != x.last_excluded_mm[1])) {
    off[0] = off[1] = off[2] = 0.0;
    off[3] += x.extruder_adj_mm;
    x.extruder_adj_mm = 0.0;
  }
  if (off[2] != 0.0 && target[2] != x.last_excluded_mm[2]) off[2] = 0.0;
  if (x.extruder_adj_mm != 0.0 && target[3] != x.last_excluded_mm[3]) {
    off[3] += x.extruder_adj_mm;
    x.extruder_adj_mm = 0.0;
  }
  std::array<double, 4> tx;
  for (std::size_t a = 0; a < 4; ++a) tx[a] = target[a] - off[a];
  if (tx == x.toolhead_mm) return;  // the toolhead drops a move of no length
  MoveRequest m = proto;
  m.start_mm = x.toolhead_mm;
  m.end_mm = tx;
  x.toolhead_mm = tx;
  sink.on_move(m);
}

void Interpreter::after_position_set(unsigned axes) {
  if (!exclude_.transform) return;
  for (std::size_t a = 0; a < 3; ++a) {
    if (!((axes >> a) & 1u)) continue;
    exclude_.toolhead_mm[a] = pos_[a];
    exclude_.offset_mm[a] = 0.0;
  }
}

void Interpreter::update_path_choice() {
  general_path_only_ = (expander_ != nullptr && expander_->expands_moves()) || exclude_.transform;
}

// ---- IDEX: SET_DUAL_CARRIAGE, SAVE_ / RESTORE_DUAL_CARRIAGE_STATE -------------------------------
// One pair of carriages per axis (opt_.dual_carriages, carriages_ index by pair): a cartesian or
// hybrid [dual_carriage], or a generic_cartesian [dual_carriage NAME] with its primary carriage.

namespace {

using Options = InterpreterOptions::DualCarriage;

/// idex_modes.py get_dc_order: +1 when carriage `a` is always on the high side of `b`.
int dc_order(const Options& o, std::size_t a, std::size_t b) {
  if (o.homing_positive_dir[a] != o.homing_positive_dir[b])
    return o.homing_positive_dir[a] ? 1 : -1;
  return o.position_endstop_mm[a] > o.position_endstop_mm[b] ? 1 : -1;
}

}  // namespace

void Interpreter::home_dual_carriage(std::size_t pair) {
  // idex_modes.py home(): both carriages home; carriage 0 ends PRIMARY at its endstop,
  // carriage 1 parked at its own.
  const Options& o = opt_.dual_carriages[pair];
  carriages_[pair][0] = Carriage{CarriageMode::primary, 1.0, 0.0};
  carriages_[pair][1] = Carriage{CarriageMode::inactive, 0.0, o.position_endstop_mm[1]};
}

void Interpreter::send_carriage_range(std::size_t pair, std::uint64_t line_no, EventSink& sink) {
  // idex_modes.py get_kin_range: each active carriage's rail range (shifted in COPY, mirrored
  // in MIRROR) and, with a safe distance, the room left before it meets the other carriage.
  const Options& o = opt_.dual_carriages[pair];
  const auto& carriages = carriages_[pair];
  const std::size_t axis = static_cast<std::size_t>(o.axis);
  const double p = pos_[axis];
  double lo = -1e10, hi = 1e10;
  double safe = 0.0;
  if (o.safe_distance_mm) {
    safe = *o.safe_distance_mm;
  } else {
    safe = std::min(std::fabs(o.position_min_mm[0] - o.position_min_mm[1]),
                    std::fabs(o.position_max_mm[0] - o.position_max_mm[1]));
  }
  for (std::size_t c = 0; c < 2; ++c) {
    const Carriage& me = carriages[c];
    const Carriage& other = carriages[1 - c];
    if (me.mode == CarriageMode::inactive) continue;
    const double ap0 = p * me.scale + me.offset_mm, ap1 = p * other.scale + other.offset_mm;
    switch (me.mode) {
      case CarriageMode::primary:
        lo = std::max(lo, o.position_min_mm[c]);
        hi = std::min(hi, o.position_max_mm[c]);
        break;
      case CarriageMode::copy:
        lo = std::max(lo, p + o.position_min_mm[c] - ap0);
        hi = std::min(hi, p + o.position_max_mm[c] - ap0);
        break;
      case CarriageMode::mirror:
        lo = std::max(lo, p + ap0 - o.position_max_mm[c]);
        hi = std::min(hi, p + ap0 - o.position_min_mm[c]);
        break;
      case CarriageMode::inactive: break;
    }
    if (safe == 0.0) continue;
    const auto both = [&](CarriageMode a, CarriageMode b) {
      return (me.mode == a && other.mode == b) || (me.mode == b && other.mode == a);
    };
    if (me.mode == other.mode || both(CarriageMode::primary, CarriageMode::copy)) continue;
    const int order = dc_order(o, c, 1 - c);
    double room = order > 0 ? (ap1 - ap0) + safe : (ap1 - ap0) - safe;
    if (other.mode != CarriageMode::inactive) room *= 0.5;
    if (me.mode == CarriageMode::primary || me.mode == CarriageMode::copy) {
      if (order > 0)
        lo = std::max(lo, p + room);
      else
        hi = std::min(hi, p + room);
    } else {
      if (order > 0)
        hi = std::min(hi, p - room);
      else
        lo = std::max(lo, p - room);
    }
  }
  if (lo > hi) hi = lo;  // Klipper: an empty range blocks the axis
  sink.on_axis_range(o.axis, lo, hi, line_no);
}

void Interpreter::dual_carriage_command(const Command& cmd, std::uint64_t line_no,
                                        EventSink& sink) {
  const auto& pairs = opt_.dual_carriages;
  auto axis_of = [&](std::size_t pair) { return static_cast<std::size_t>(pairs[pair].axis); };
  auto position_of = [&](std::size_t pair, std::size_t c) {
    return pos_[axis_of(pair)] * carriages_[pair][c].scale + carriages_[pair][c].offset_mm;
  };
  // The toolhead's position on the axis is redefined with the motion stopped
  // (toolhead.set_position); the file's coordinates keep their base (G92) offset.
  auto set_axis_position = [&](std::size_t axis, double v) {
    gcode_pos_[axis] += v - pos_[axis];
    pos_[axis] = v;
    after_position_set(1u << axis);
    sink.on_set_position(exclude_.transform ? exclude_.toolhead_mm : pos_, line_no);
  };
  auto inactivate = [&](std::size_t pair, std::size_t c) {
    carriages_[pair][c] = Carriage{CarriageMode::inactive, 0.0, position_of(pair, c)};
  };
  auto rail_range = [&](std::size_t pair, std::size_t c) {
    const Options& o = pairs[pair];
    sink.on_axis_range(o.axis, o.position_min_mm[c], o.position_max_mm[c], line_no);
  };
  // toggle_active_dc_rail: the other carriage parks where it is; the target becomes PRIMARY
  // and the toolhead's position on the axis becomes the target carriage's.
  auto make_primary = [&](std::size_t pair, std::size_t c) {
    auto& cs = carriages_[pair];
    if (cs[1 - c].mode != CarriageMode::inactive) inactivate(pair, 1 - c);
    if (cs[c].mode != CarriageMode::primary) {
      const double v = position_of(pair, c);
      cs[c] = Carriage{CarriageMode::primary, 1.0, 0.0};
      set_axis_position(axis_of(pair), v);
    }
    rail_range(pair, c);
  };
  const std::string_view name = cmd.name;
  if (iequals(name, "SET_DUAL_CARRIAGE")) {
    sink.on_step_flush(line_no);  // idex_modes.py flushes the step generation first
    std::uint32_t col = cmd.args_column;
    const auto which = text_arg(cmd, "CARRIAGE", &col);
    if (!which) fail(line_no, cmd.args_column, "SET_DUAL_CARRIAGE: CARRIAGE must be specified");
    // idex_modes.py cmd_SET_DUAL_CARRIAGE: a carriage by its name (generic_cartesian: the
    // section's, as written) or, with a single pair, by index 0 / 1.
    std::optional<std::pair<std::size_t, std::size_t>> found;
    std::vector<std::string> known;
    for (std::size_t pair = 0; pair < pairs.size() && !found; ++pair) {
      for (std::size_t c = 0; c < 2; ++c) {
        const std::string& n = pairs[pair].names[c];
        if (n.empty()) continue;
        known.push_back(n);
        if (*which == n) {
          found = std::make_pair(pair, c);
          break;
        }
      }
    }
    if (!found && pairs.size() == 1) {
      const bool named = !pairs[0].names[0].empty();
      if (*which == "0" ||
          (!named && (iequals(*which, "stepper_x") || iequals(*which, "stepper_y") ||
                      iequals(*which, "x") || iequals(*which, "y"))))
        found = std::make_pair(std::size_t{0}, std::size_t{0});
      else if (*which == "1" || (!named && iequals(*which, "dual_carriage")))
        found = std::make_pair(std::size_t{0}, std::size_t{1});
    }
    if (!found) {
      fail(line_no, col,
           known.empty()
               ? fmt::format("SET_DUAL_CARRIAGE: invalid CARRIAGE={} (expected 0, 1 or a carriage "
                             "name)",
                             *which)
               : fmt::format("SET_DUAL_CARRIAGE: invalid CARRIAGE={} (expected one of {}{})",
                             *which, fmt::join(known, ", "), pairs.size() == 1 ? ", 0, 1" : ""));
    }
    const auto [pair, c] = *found;
    const std::size_t axis = axis_of(pair);
    auto& cs = carriages_[pair];
    const std::string mode = to_upper(text_arg(cmd, "MODE").value_or("PRIMARY"));
    if (mode == "PRIMARY") {
      make_primary(pair, c);
    } else if (mode == "COPY" || mode == "MIRROR") {
      if (cs[1 - c].mode != CarriageMode::primary) {
        fail(line_no, cmd.args_column,
             fmt::format(
                 "SET_DUAL_CARRIAGE MODE={}: must activate another carriage as PRIMARY first",
                 mode));
      }
      if (!((homed_axes_ >> axis) & 1u)) {
        fail(line_no, cmd.args_column,
             fmt::format("SET_DUAL_CARRIAGE MODE={}: axis {} must be homed first", mode,
                         "XY"[axis]));
      }
      const double old = position_of(pair, c);
      const double scale = mode == "MIRROR" ? -1.0 : 1.0;
      cs[c] = Carriage{mode == "MIRROR" ? CarriageMode::mirror : CarriageMode::copy, scale,
                       old - pos_[axis] * scale};
    } else if (mode == "INACTIVE") {
      if (cs[1 - c].mode == CarriageMode::inactive) {
        fail(
            line_no, cmd.args_column,
            fmt::format("SET_DUAL_CARRIAGE: cannot deactivate the only active carriage for axis {}",
                        "XY"[axis]));
      }
      if (cs[c].mode != CarriageMode::inactive) inactivate(pair, c);
    } else {
      fail(line_no, cmd.args_column,
           fmt::format(
               "SET_DUAL_CARRIAGE: invalid MODE={} (expected PRIMARY, COPY, MIRROR or INACTIVE)",
               mode));
    }
    send_carriage_range(pair, line_no, sink);
    return;
  }
  const std::string state = text_arg(cmd, "NAME").value_or("default");
  if (iequals(name, "SAVE_DUAL_CARRIAGE_STATE")) {
    saved_carriages_[state] = carriages_;
    saved_carriage_pos_[state] = pos_;
    return;
  }
  // RESTORE_DUAL_CARRIAGE_STATE [NAME=] [MOVE=1] [MOVE_SPEED=]
  sink.on_step_flush(line_no);
  const auto it = saved_carriages_.find(state);
  if (it == saved_carriages_.end()) {
    fail(line_no, cmd.args_column,
         fmt::format("Unknown DUAL_CARRIAGE state: {} (Klipper stops with this error)", state));
  }
  const std::vector<std::array<Carriage, 2>> saved = it->second;
  const std::array<double, 4> saved_pos = saved_carriage_pos_.at(state);
  bool move = true;
  double speed_mm_s = 1e300;
  for (const Options& o : pairs) {
    speed_mm_s = std::min({speed_mm_s, o.homing_speed_mm_s[0], o.homing_speed_mm_s[1]});
  }
  std::uint32_t col = 0;
  if (auto m = text_arg(cmd, "MOVE", &col)) {
    double v = 0.0;
    if (parse_float_value(*m, v) != m->size() || v != std::floor(v)) {
      fail(line_no, col,
           fmt::format("RESTORE_DUAL_CARRIAGE_STATE MOVE= expects an integer, found '{}'", *m));
    }
    move = v != 0.0;
  }
  if (auto m = text_arg(cmd, "MOVE_SPEED", &col)) {
    double v = 0.0;
    if (parse_float_value(*m, v) != m->size() || !in_range(kSpeedRange, v)) {
      fail(line_no, col,
           fmt::format("RESTORE_DUAL_CARRIAGE_STATE MOVE_SPEED= must be {}, found '{}'", describe(kSpeedRange),
                       *m));
    }
    speed_mm_s = v;
  }
  std::vector<std::array<double, 2>> target(pairs.size()), end(pairs.size());
  for (std::size_t pair = 0; pair < pairs.size(); ++pair) {
    for (std::size_t c = 0; c < 2; ++c) {
      target[pair][c] = saved_pos[axis_of(pair)] * saved[pair][c].scale + saved[pair][c].offset_mm;
      end[pair][c] = position_of(pair, c);
    }
  }
  if (move) {
    // On each axis both carriages travel together (the one with the longer way leads, the
    // other scaled to arrive with it): one move of the leading carriages, every axis at once,
    // at MOVE_SPEED or the lowest homing speed, from rest to rest.
    MoveRequest m;
    for (std::size_t pair = 0; pair < pairs.size(); ++pair) {
      const double d0 = target[pair][0] - end[pair][0], d1 = target[pair][1] - end[pair][1];
      make_primary(pair, std::fabs(d0) >= std::fabs(d1) ? 0 : 1);
    }
    m.start_mm = exclude_.transform ? exclude_.toolhead_mm : pos_;
    m.end_mm = m.start_mm;
    bool moves = false;
    for (std::size_t pair = 0; pair < pairs.size(); ++pair) {
      const std::size_t axis = axis_of(pair);
      const std::size_t lead = carriages_[pair][0].mode == CarriageMode::primary ? 0 : 1;
      const double d = target[pair][lead] - pos_[axis];
      if (d == 0.0) continue;
      moves = true;
      m.end_mm[axis] += d;
      gcode_pos_[axis] += d;
      pos_[axis] += d;
      if (exclude_.transform) exclude_.toolhead_mm[axis] += d;
    }
    if (moves) {
      m.speed_mm_s = speed_mm_s;
      m.line = line_no;
      m.layer = notes_.layer;
      m.feature = notes_.feature;
      sink.on_move(m);
      sink.on_step_flush(line_no);  // manual_move, then flush_step_generation
    }
    end = target;
  }
  // The saved modes come back with each carriage where it now is; the toolhead's position
  // on each axis is its primary carriage's.
  for (std::size_t pair = 0; pair < pairs.size(); ++pair) {
    const std::size_t axis = axis_of(pair);
    const std::size_t primary = saved[pair][0].mode == CarriageMode::primary ? 0 : 1;
    const std::size_t other = 1 - primary;
    auto& cs = carriages_[pair];
    cs[primary] = Carriage{CarriageMode::primary, 1.0, 0.0};
    if (pos_[axis] != end[pair][primary]) set_axis_position(axis, end[pair][primary]);
    const double s = saved[pair][other].mode == CarriageMode::inactive ? 0.0 : saved[pair][other].scale;
    cs[other] = Carriage{saved[pair][other].mode, s, end[pair][other] - pos_[axis] * s};
    send_carriage_range(pair, line_no, sink);
  }
}

// ---- SET_STEPPER_CARRIAGES (generic_cartesian.py) ------------------------------------------------

void Interpreter::set_stepper_carriages(const Command& cmd, std::uint64_t line_no,
                                        EventSink& sink) {
  // Klipper flushes the step generation, then changes the stepper's coefficients; the
  // toolhead does not move, so only the flush costs time.
  sink.on_step_flush(line_no);
  std::uint32_t col = cmd.args_column;
  const auto stepper = text_arg(cmd, "STEPPER", &col);
  if (!stepper) fail(line_no, cmd.args_column, "SET_STEPPER_CARRIAGES: STEPPER must be specified");
  // Klipper matches the full name ("stepper a") or the short one ("a").
  std::string key = *stepper;
  if (key.rfind("stepper ", 0) == 0) key = key.substr(8);
  const auto it = stepper_carriages_.find(key);
  if (it == stepper_carriages_.end()) {
    fail(line_no, col, fmt::format("SET_STEPPER_CARRIAGES: invalid STEPPER '{}' specified (Klipper "
                                   "stops with this error)",
                                   *stepper));
  }
  const auto carriages = text_arg(cmd, "CARRIAGES", &col);
  if (!carriages) {
    fail(line_no, cmd.args_column, "SET_STEPPER_CARRIAGES: CARRIAGES must be specified");
  }
  std::string expr = *carriages;
  for (char& ch : expr) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  bool full = true;
  std::uint32_t dcol = 0;
  if (auto d = text_arg(cmd, "DISABLE_CHECKS", &dcol)) {
    double v = 0.0;
    if (parse_float_value(*d, v) != d->size() || v != std::floor(v)) {
      fail(line_no, dcol,
           fmt::format("SET_STEPPER_CARRIAGES DISABLE_CHECKS= expects an integer, found '{}'", *d));
    }
    full = v == 0.0;
  }
  if (opt_.check_stepper_carriages) {
    const std::string why = opt_.check_stepper_carriages(stepper_carriages_, key, expr, full);
    if (!why.empty()) fail(line_no, col, fmt::format("SET_STEPPER_CARRIAGES: {}", why));
  }
  it->second = expr;
}

}  // namespace amctl::gcode

namespace amctl::gcode {

// klippy/extras/bed_mesh.py: BED_MESH_PROFILE takes the first of LOAD, SAVE, REMOVE that is
// given (an empty name is an error; none of them: "Invalid syntax", no effect; SAVE=default
// is refused with a message and no effect); BED_MESH_CLEAR; BED_MESH_OFFSET X= Y= ZFADE=.
void Interpreter::handle_bed_mesh(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  BedMeshCommand bm;
  bm.line = line_no;
  bm.column = cmd.args_column;
  if (iequals(cmd.name, "BED_MESH_CLEAR")) {
    bm.kind = BedMeshCommand::Kind::clear;
    sink.on_bed_mesh(bm);
    return;
  }
  if (iequals(cmd.name, "BED_MESH_OFFSET")) {
    bm.kind = BedMeshCommand::Kind::offset;
    auto number = [&](std::string_view key) -> std::optional<double> {
      std::uint32_t col = 0;
      const auto t = text_arg(cmd, key, &col);
      if (!t) return std::nullopt;
      double v = 0.0;
      if (parse_float_value(*t, v) != t->size() || t->empty() || !std::isfinite(v)) {
        fail(line_no, col, fmt::format("BED_MESH_OFFSET {}=: found '{}', expected a finite number [mm]", key, *t));
      }
      // An offset on the bed, in mm: no machine is larger than amctl's largest length.
      if (std::abs(v) > kLengthRange.max) {
        fail(line_no, col, fmt::format("BED_MESH_OFFSET {}= must be a length within +-{:g} mm, found '{}'",
                                       key, kLengthRange.max, *t));
      }
      return v;
    };
    bm.x_mm = number("X");
    bm.y_mm = number("Y");
    bm.zfade_mm = number("ZFADE");
    sink.on_bed_mesh(bm);
    return;
  }
  static constexpr std::pair<std::string_view, BedMeshCommand::Kind> kKeys[] = {
      {"LOAD", BedMeshCommand::Kind::load},
      {"SAVE", BedMeshCommand::Kind::save},
      {"REMOVE", BedMeshCommand::Kind::remove}};
  for (const auto& [key, kind] : kKeys) {
    std::uint32_t col = 0;
    const auto t = text_arg(cmd, key, &col);
    if (!t) continue;
    if (t->find_first_not_of(" \t") == std::string::npos) {
      fail(line_no, col, fmt::format("BED_MESH_PROFILE {}=: found an empty name, expected a profile's name "
                                     "(Klipper: \"Value for parameter '{}' must be specified\")", key, key));
    }
    if (kind == BedMeshCommand::Kind::save && *t == "default") {
      note_ignored(cmd.name);  // "Profile 'default' is reserved": a message, no effect
      return;
    }
    bm.kind = kind;
    bm.profile = *t;
    bm.column = col;
    sink.on_bed_mesh(bm);
    return;
  }
  note_ignored(cmd.name);  // "Invalid syntax": a message, no effect
}

}  // namespace amctl::gcode
