#include "amctl/gcode/interpreter.hpp"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::gcode {
namespace {

char upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c; }

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (upper(a[i]) != upper(b[i])) return false;
  }
  return true;
}

bool starts_with_ci(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && iequals(s.substr(0, prefix.size()), prefix);
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::string to_upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = upper(c);
  return out;
}

/// "1d 2h 47m 50s", "1h 47m 50s", "11m 18s", "50s" -> seconds; nullopt if not that form.
std::optional<double> parse_dhms(std::string_view s) {
  s = trim(s);
  double total = 0.0;
  bool any = false;
  while (!s.empty()) {
    double v = 0.0;
    std::size_t used = parse_number(s, v);
    if (used == 0) return std::nullopt;
    s.remove_prefix(used);
    if (s.empty()) return std::nullopt;
    char unit = s.front();
    s.remove_prefix(1);
    switch (unit) {
      case 'd': total += v * 86400.0; break;
      case 'h': total += v * 3600.0; break;
      case 'm': total += v * 60.0; break;
      case 's': total += v; break;
      default: return std::nullopt;
    }
    any = true;
    s = trim(s);
  }
  if (!any) return std::nullopt;
  return total;
}

// Largest accepted machine coordinate [mm] (1000 km): anything beyond is an overflow or a
// typo, never a print, and squares of distances must stay far from double overflow.
constexpr double kMaxCoordinate_mm = 1e9;
// Largest accepted speed/acceleration/jerk limit (mm/s, mm/min, mm/s^2 alike): squared speeds
// and accel * distance products then stay finite.
constexpr double kMaxLimit = 1e9;

// Commands understood to have no effect on motion time.
bool is_ignored_word(char letter, int code) {
  if (letter == 'T') return true;  // tool select: single-extruder time model
  if (letter == 'G') {
    switch (code) {
      case 21: case 17: case 18: case 19: case 90: case 91: case 94: case 31: case 53: case 54:
      case 55: case 56: case 57: case 58: case 59:
        return true;
      default:
        return false;
    }
  }
  if (letter == 'M') {
    // Sorted: housekeeping, reporting, settings, SD card, LEDs, sound, leveling switches.
    static constexpr int kCodes[] = {
        17,  18,  21,  22,  23,  24,  25,  27,  28,  29,  30,  31,  32,  33,  34,  39,  42,
        43,  75,  76,  77,  78,  80,  81,  84,  85,  92,  105, 108, 110, 111, 112, 113, 114,
        115, 117, 118, 119, 120, 121, 122, 145, 149, 150, 155, 163, 164, 193, 200, 209, 211,
        217, 218, 250, 255, 280, 290, 300, 301, 302, 303, 304, 305, 306, 307, 350, 351, 355,
        380, 381, 401, 402, 403, 404, 405, 406, 407, 410, 412, 413, 420, 428, 486, 500, 501,
        502, 503, 504, 530, 531, 532, 540, 551, 552, 553, 554, 555, 569, 570, 571, 572, 573,
        574, 575, 577, 579, 581, 582, 584, 585, 591, 592, 593, 594, 595, 596, 597, 598, 603,
        605, 665, 666, 669, 671, 672, 701, 702, 703, 815, 851, 860, 861, 862, 863, 864, 865,
        866, 867, 868, 869, 876, 890, 891, 900, 906, 907, 911, 912, 913, 914, 915, 917, 918,
        919, 920, 928, 997, 999};
    return std::binary_search(std::begin(kCodes), std::end(kCodes), code);
  }
  return false;
}

// Commands that take real time amctl cannot predict (homing, probing, user interaction).
bool is_untimed_word(char letter, int code) {
  if (letter == 'G') {
    switch (code) {
      case 28: case 29: case 30: case 32: case 33: case 34: case 35: case 76: case 80: case 81:
      case 425:
        return true;
      default:
        return false;
    }
  }
  if (letter == 'M') {
    switch (code) {
      case 0: case 1: case 48: case 125: case 226: case 600: case 601: case 602: case 1001:
        return true;
      default:
        return false;
    }
  }
  return false;
}

constexpr std::string_view kIgnoredExtended[] = {
    "EXCLUDE_OBJECT_DEFINE", "EXCLUDE_OBJECT_START", "EXCLUDE_OBJECT_END", "EXCLUDE_OBJECT",
    "SET_PRESSURE_ADVANCE", "SET_INPUT_SHAPER", "SET_PRINT_STATS_INFO", "RESPOND",
    "SAVE_GCODE_STATE", "RESTORE_GCODE_STATE", "SET_GCODE_OFFSET", "SET_FAN_SPEED",
    "SET_LED", "SET_PIN", "SET_IDLE_TIMEOUT", "SET_STEPPER_ENABLE", "SET_TMC_CURRENT",
    "SET_SKEW", "SKEW_PROFILE", "BED_MESH_PROFILE", "BED_MESH_CLEAR", "SET_GCODE_VARIABLE",
    "UPDATE_DELAYED_GCODE", "SET_EXTRUDER_ROTATION_DISTANCE", "SYNC_EXTRUDER_MOTION",
    "ACTIVATE_EXTRUDER", "SET_FILAMENT_SENSOR", "STATUS", "ECHO", "M117"};
constexpr std::string_view kUntimedExtended[] = {
    "BED_MESH_CALIBRATE", "QUAD_GANTRY_LEVEL", "Z_TILT_ADJUST", "PROBE", "PROBE_ACCURACY",
    "PROBE_CALIBRATE", "SCREWS_TILT_CALCULATE", "PAUSE", "CALIBRATE_Z", "SHAPER_CALIBRATE",
    "TEST_RESONANCES", "PID_CALIBRATE", "DELTA_CALIBRATE"};

}  // namespace

namespace {

/// The plain-move lexer of the fast path: "G0"/"G1", then only X Y Z E F words with plain
/// decimal numbers, spaces and an optional ';' comment. Anything else (N, '*', '(', other
/// letters, exponents, a repeated letter, a number not exactly representable by Clinger's
/// rule) returns false and the line goes through the general parser, which alone reports
/// errors. Values are computed exactly as parse_number() does, so both paths give the same
/// doubles.
struct PlainMove {
  std::array<double, 5> value{};  // X Y Z E F
  unsigned present = 0;           // bit i: value[i] given
  std::string_view comment;
  bool has_comment = false;
};

inline int plain_axis(char c) {
  switch (c) {
    case 'X': case 'x': return 0;
    case 'Y': case 'y': return 1;
    case 'Z': case 'z': return 2;
    case 'E': case 'e': return 3;
    case 'F': case 'f': return 4;
    default: return -1;
  }
}

/// Copies line[0, n) (3 <= n <= 64) into buf, whose bytes from n on are zero, with fixed-size
/// (overlapping) copies the compiler turns into a few vector moves.
inline void copy_short(char* buf, const char* s, std::size_t n) {
  if (n >= 32) {
    std::memcpy(buf, s, 32);
    std::memcpy(buf + n - 32, s + n - 32, 32);
  } else if (n >= 16) {
    std::memcpy(buf, s, 16);
    std::memcpy(buf + n - 16, s + n - 16, 16);
  } else if (n >= 8) {
    std::memcpy(buf, s, 8);
    std::memcpy(buf + n - 8, s + n - 8, 8);
  } else {
    for (std::size_t i = 0; i < n; ++i) buf[i] = s[i];
  }
}

inline bool lex_plain_move(std::string_view line, PlainMove& out) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                      1e16, 1e17, 1e18, 1e19};
  const std::size_t n = line.size();
  if (n < 3 || (line[0] != 'G' && line[0] != 'g') || (line[1] != '0' && line[1] != '1') ||
      (line[2] != ' ' && line[2] != '\t')) {
    return false;
  }
  // The lexer reads a zero-padded copy of the code part of the line (at most 64 bytes, up to
  // a ';' comment on longer lines), so its loops need no bounds checks. A NUL anywhere but at
  // the copy's end (a NUL byte in the file) hands the line to the general parser; a comment
  // is taken from the line itself.
  constexpr std::size_t kMaxCode = 64;
  std::size_t code = n;
  if (n > kMaxCode) {
    const void* semi = std::memchr(line.data(), ';', kMaxCode + 1);
    if (semi == nullptr) return false;
    code = static_cast<std::size_t>(static_cast<const char*>(semi) - line.data());
  }
  alignas(16) char buf[kMaxCode + 16] = {};  // zeros past the copy end every loop
  copy_short(buf, line.data(), code);
  const char* p = buf + 3;
  for (;;) {
    while (*p == ' ' || *p == '\t') ++p;
    if (*p == '\0') {
      const auto at = static_cast<std::size_t>(p - buf);
      if (at != code) return false;
      if (code < n) {
        out.comment = line.substr(code + 1);
        out.has_comment = true;
      }
      return true;
    }
    if (*p == ';') {
      out.comment = line.substr(static_cast<std::size_t>(p - buf) + 1);
      out.has_comment = true;
      return true;
    }
    const int axis = plain_axis(*p);
    if (axis < 0 || ((out.present >> axis) & 1u)) return false;
    ++p;
    bool negative = false;
    if (*p == '-' || *p == '+') negative = *p++ == '-';
    std::uint64_t mant = 0;
    const char* const int_begin = p;
    while (static_cast<unsigned>(*p - '0') < 10u) mant = mant * 10 + static_cast<unsigned>(*p++ - '0');
    std::ptrdiff_t ndigits = p - int_begin;
    std::ptrdiff_t frac = 0;
    if (*p == '.') {
      const char* const frac_begin = ++p;
      while (static_cast<unsigned>(*p - '0') < 10u) mant = mant * 10 + static_cast<unsigned>(*p++ - '0');
      frac = p - frac_begin;
      ndigits += frac;
    }
    if (ndigits == 0 || ndigits > 19 || mant > (std::uint64_t{1} << 53)) return false;
    if (*p != ' ' && *p != '\t' && *p != ';' && *p != '\0') return false;
    const double v = static_cast<double>(mant) / kPow10[frac];
    out.value[static_cast<std::size_t>(axis)] = negative ? -v : v;
    out.present |= 1u << axis;
  }
}

}  // namespace

[[gnu::always_inline]] inline bool Interpreter::try_plain_move(std::string_view line, std::uint64_t line_no,
                                                                EventSink& sink) {
  PlainMove pm;
  if (!lex_plain_move(line, pm)) return false;
  // Everything that could fail is checked before any state changes, so a line that fails
  // here is handed whole to the general path and reported there.
  const bool has_f = (pm.present >> 4) & 1u;
  if (has_f && !(pm.value[4] > 0.0)) return false;
  std::array<double, 4> new_gcode;
  const std::array<double, 4> target = modal_target(pm.present & 0xFu, pm.value.data(), new_gcode);
  for (std::size_t a = 0; a < 4; ++a) {
    if (!(std::fabs(target[a]) <= kMaxCoordinate_mm)) return false;
  }
  if (pm.has_comment && !pm.comment.empty()) handle_comment(pm.comment, line_no, sink);
  if (has_f) feed_mm_s_ = pm.value[4] * unit_mm_ / 60.0;
  if ((pm.present & 0xFu) == 0) return true;  // F only: sets the speed of later moves
  gcode_pos_ = new_gcode;
  if (target == pos_) return true;
  MoveRequest m;
  m.start_mm = pos_;
  m.end_mm = target;
  m.speed_mm_s = feed_mm_s_ * speed_factor_;
  m.line = line_no;
  m.layer = notes_.layer;
  m.feature = notes_.feature;
  pos_ = target;
  sink.on_move(m);
  return true;
}

Interpreter::Interpreter(InterpreterOptions options, std::string source_name)
    : opt_(options), source_(std::move(source_name)) {
  require_positive("arcs.mm_per_arc_segment", opt_.mm_per_arc_segment);
  require_non_negative("arcs.min_arc_segment_mm", opt_.min_arc_segment_mm);
  require_non_negative("arcs.max_arc_segment_mm", opt_.max_arc_segment_mm);
  require_non_negative("arcs.segments_per_second", opt_.arc_segments_per_second);
  require_non_negative("retraction.retract_length", opt_.retract_length_mm);
  require_positive("retraction.retract_speed", opt_.retract_speed_mm_s);
  require_positive("retraction.unretract_speed", opt_.unretract_speed_mm_s);
}

void Interpreter::fail(std::uint64_t line_no, std::uint32_t col, const std::string& msg) const {
  throw Error(SourceLocation{source_, line_no, col}, msg);
}

void Interpreter::run(LineReader& reader, EventSink& sink) {
  std::string_view line;
  while (reader.next(line)) feed(line, reader.line_number(), sink);
}

void Interpreter::feed(std::string_view line, std::uint64_t line_no, EventSink& sink) {
  // Most lines of a sliced file are plain G0/G1 moves: a dedicated lexer takes them without
  // building a Command and a 26-letter Params (docs/gcode.md, "Fast path").
  if (try_plain_move(line, line_no, sink)) return;
  if (!parse_line(line, cmd_, issue_)) {
    if (opt_.strict) {
      fail(line_no, issue_.column, fmt::format("{} in '{}'", issue_.message, trim(line)));
    }
    ++skipped_lines_;
    return;
  }
  if (!cmd_.comment.empty()) handle_comment(cmd_.comment, line_no, sink);
  switch (cmd_.kind) {
    case CommandKind::none:
      return;
    case CommandKind::word:
      handle_word(cmd_, line_no, sink);
      return;
    case CommandKind::extended:
      handle_extended(cmd_, line_no, sink);
      return;
  }
}

void Interpreter::note_unknown(std::string_view name, std::uint64_t line_no) {
  std::string key = to_upper(name);
  for (auto& u : unknown_) {
    if (u.name == key) {
      ++u.count;
      return;
    }
  }
  unknown_.push_back(UnknownCommand{key, line_no, 1});
}

void Interpreter::note_ignored(std::string_view name) { ++ignored_[to_upper(name)]; }

void Interpreter::set_feature(std::string_view name) {
  name = trim(name);
  auto& names = notes_.feature_names;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) {
      notes_.feature = static_cast<std::uint16_t>(i);
      return;
    }
  }
  if (names.size() >= 65535) return;  // absurd number of distinct features: keep the last
  names.emplace_back(name);
  notes_.feature = static_cast<std::uint16_t>(names.size() - 1);
}

void Interpreter::handle_comment(std::string_view c, std::uint64_t line_no, EventSink& sink) {
  // Cheap first-character filter: most comments are none of these.
  std::string_view t = c;
  while (!t.empty() && t.front() == ' ') t.remove_prefix(1);
  if (t.empty()) return;
  auto layer_marker = [&] {
    ++notes_.layer;
    sink.on_layer_change(notes_.layer, line_no);
  };
  switch (t.front()) {
    case 'L':
      if (t.starts_with("LAYER_CHANGE")) {
        layer_marker();
      } else if (t.starts_with("LAYER:")) {
        layer_marker();
      }
      return;
    case 'C':
      if (t.starts_with("CHANGE_LAYER")) layer_marker();
      return;
    case 'T':
      if (t.starts_with("TYPE:")) {
        set_feature(t.substr(5));
      } else if (t.starts_with("TIME:") && !notes_.slicer_estimate_s) {
        double v = 0;
        if (parse_number(trim(t.substr(5)), v) > 0) notes_.slicer_estimate_s = v;
      }
      return;
    case 'F':
      if (t.starts_with("FEATURE:")) set_feature(t.substr(8));
      return;
    case 'P':
      if (t.starts_with("Print Time:")) {
        double v = 0;
        if (parse_number(trim(t.substr(11)), v) > 0) notes_.slicer_estimate_s = v;
      }
      return;
    case 'e':
      if (t.starts_with("estimated printing time (normal mode) =")) {
        if (auto s = parse_dhms(t.substr(39))) notes_.slicer_estimate_s = s;
      }
      return;
    case 't':
      if (t.starts_with("total estimated time:")) {
        if (auto s = parse_dhms(t.substr(21))) notes_.slicer_estimate_s = s;
      }
      return;
    case 'm':
      if (t.starts_with("model printing time:")) {
        auto pos = t.find("total estimated time:");
        if (pos != std::string_view::npos) {
          if (auto s = parse_dhms(t.substr(pos + 21))) notes_.slicer_estimate_s = s;
        }
      }
      return;
    case 'g':
    case 'G':
    case 'S':
      if (notes_.slicer_name.empty() && line_no < 50) {
        if (starts_with_ci(t, "generated by ")) {
          std::string_view rest = t.substr(13);
          notes_.slicer_name = std::string(rest.substr(0, rest.find(' ')));
        } else if (starts_with_ci(t, "Generated with ")) {
          std::string_view rest = t.substr(15);
          notes_.slicer_name = std::string(rest.substr(0, rest.find(' ')));
        } else if (starts_with_ci(t, "Sliced by ")) {
          std::string_view rest = t.substr(10);
          notes_.slicer_name = std::string(rest.substr(0, rest.find(' ')));
        }
      }
      return;
    default:
      return;
  }
}

void Interpreter::handle_word(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  const char L = cmd.letter;
  const int code = cmd.code;
  auto params = [&]() -> const Params& {
    if (!parse_params(cmd, params_, issue_)) {
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
        do_arc(cmd, params(), code == 2, line_no, sink);
        return;
      case 4: {
        const Params& p = params();
        double s = 0.0;
        if (p.has('S')) s = p.get('S');
        else if (p.has('P')) s = p.get('P') / 1000.0;
        if (s < 0.0) {
          fail(line_no, p.column[p.has('S') ? 'S' - 'A' : 'P' - 'A'],
               fmt::format("G4 dwell must be >= 0, got {}", s));
        }
        sink.on_dwell(s, line_no);
        return;
      }
      case 10:
      case 11: {
        const Params& p = params();
        if (code == 10 && (p.has('L') || p.has('P'))) {  // G10 L2/L20 P: coordinate offsets
          note_ignored("G10 L");
          return;
        }
        if (code == 10 && !retracted_) {
          retracted_ = true;
          auto t = pos_;
          t[3] -= opt_.retract_length_mm;
          if (opt_.retract_length_mm > 0) emit_move(t, opt_.retract_speed_mm_s, line_no, sink, false, true);
        } else if (code == 11 && retracted_) {
          retracted_ = false;
          auto t = pos_;
          t[3] += opt_.retract_length_mm + opt_.unretract_extra_length_mm;
          if (t[3] != pos_[3]) emit_move(t, opt_.unretract_speed_mm_s, line_no, sink, false, true);
        }
        return;
      }
      case 17: case 18: case 19:
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
        // Motors off: the firmware finishes every move first (and Klipper dwells).
        if (opt_.motor_off_dwell_s > 0.0) sink.on_dwell(opt_.motor_off_dwell_s, line_no);
        else sink.on_wait_moves(line_no);
        note_ignored(cmd.name);
        return;
      case 220: {
        const Params& p = params();
        double s = p.get_or('S', 100.0);
        if (!(s > 0.0)) fail(line_no, p.column['S' - 'A'], fmt::format("M220 S must be > 0 %, got {}", s));
        speed_factor_ = s / 100.0;
        return;
      }
      case 221: {
        const Params& p = params();
        double s = p.get_or('S', 100.0);
        if (!(s > 0.0)) fail(line_no, p.column['S' - 'A'], fmt::format("M221 S must be > 0 %, got {}", s));
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
          }
        }
        lc.line = line_no;
        sink.on_limits(lc);
        return;
      }
      case 207: {  // firmware retraction settings (Marlin/RRF): S length, F speed mm/min
        const Params& p = params();
        if (p.has('S')) opt_.retract_length_mm = std::max(0.0, p.get('S'));
        if (p.has('F') && p.get('F') > 0) opt_.retract_speed_mm_s = p.get('F') / 60.0;
        return;
      }
      case 208: {
        const Params& p = params();
        if (p.has('S')) opt_.unretract_extra_length_mm = p.get('S');
        if (p.has('F') && p.get('F') > 0) opt_.unretract_speed_mm_s = p.get('F') / 60.0;
        return;
      }
      default:
        break;
    }
  }
  if (is_untimed_word(L, code)) {
    if (L == 'G' && code == 28) {
      const Params& p = params();
      bool any = p.has('X') || p.has('Y') || p.has('Z');
      for (int a = 0; a < 3; ++a) {
        if (!any || p.has("XYZ"[a])) {
          pos_[a] = 0.0;
          gcode_pos_[a] = 0.0;
        }
      }
      sink.on_untimed("G28", line_no);
      sink.on_set_position(pos_, line_no);
      return;
    }
    sink.on_untimed(cmd.name, line_no);
    sink.on_wait_moves(line_no);
    return;
  }
  if (is_ignored_word(L, code)) {
    note_ignored(L == 'T' ? std::string_view("T") : cmd.name);
    return;
  }
  note_unknown(cmd.name, line_no);
}

double Interpreter::number_arg(const Command& cmd, std::string_view key, std::uint64_t line_no,
                               bool& present) const {
  std::string_view text;
  std::uint32_t col = 0;
  present = find_extended_arg(cmd, key, text, col);
  if (!present) return 0.0;
  double v = 0.0;
  std::size_t used = parse_number(text, v);
  if (used == 0 || used != text.size() || !std::isfinite(v)) {
    fail(line_no, col, fmt::format("{} {}= expects a number, found '{}'", cmd.name, key, text));
  }
  return v;
}

void Interpreter::handle_extended(const Command& cmd, std::uint64_t line_no, EventSink& sink) {
  const std::string_view name = cmd.name;
  if (iequals(name, "SET_VELOCITY_LIMIT")) {
    LimitsCommand lc;
    lc.source = LimitsCommand::Source::set_velocity_limit;
    lc.line = line_no;
    bool has = false;
    double v = number_arg(cmd, "VELOCITY", line_no, has);
    if (has) lc.velocity = v;
    v = number_arg(cmd, "ACCEL", line_no, has);
    if (has) lc.accel = v;
    v = number_arg(cmd, "SQUARE_CORNER_VELOCITY", line_no, has);
    if (has) lc.square_corner_velocity = v;
    v = number_arg(cmd, "MINIMUM_CRUISE_RATIO", line_no, has);
    if (has) lc.minimum_cruise_ratio = v;
    v = number_arg(cmd, "ACCEL_TO_DECEL", line_no, has);
    if (has) lc.accel_to_decel = v;
    auto bad = [&](const std::optional<double>& o, std::string_view key, bool allow_zero) {
      if (o && (*o < 0.0 || (!allow_zero && *o == 0.0) || *o > kMaxLimit)) {
        fail(line_no, cmd.args_column,
             fmt::format("SET_VELOCITY_LIMIT {} must be {} 0 and <= {:g}, got {}", key,
                         allow_zero ? ">=" : ">", kMaxLimit, *o));
      }
    };
    bad(lc.velocity, "VELOCITY", false);
    bad(lc.accel, "ACCEL", false);
    bad(lc.square_corner_velocity, "SQUARE_CORNER_VELOCITY", true);
    bad(lc.minimum_cruise_ratio, "MINIMUM_CRUISE_RATIO", true);
    bad(lc.accel_to_decel, "ACCEL_TO_DECEL", false);
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
      double v = number_arg(cmd, key, line_no, has);
      if (has) {
        pos_[a] = v;
        gcode_pos_[a] = v;
      }
    }
    sink.on_set_position(pos_, line_no);
    return;
  }
  if (iequals(name, "SET_RETRACTION")) {
    bool has = false;
    double v = number_arg(cmd, "RETRACT_LENGTH", line_no, has);
    if (has) opt_.retract_length_mm = std::max(0.0, v);
    v = number_arg(cmd, "RETRACT_SPEED", line_no, has);
    if (has && v > 0) opt_.retract_speed_mm_s = v;
    v = number_arg(cmd, "UNRETRACT_EXTRA_LENGTH", line_no, has);
    if (has) opt_.unretract_extra_length_mm = v;
    v = number_arg(cmd, "UNRETRACT_SPEED", line_no, has);
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
    double v = number_arg(cmd, "TARGET", line_no, has);
    if (!has) v = number_arg(cmd, "MINIMUM", line_no, has);
    h.target_c = has ? v : 0.0;
    h.wait = iequals(name, "TEMPERATURE_WAIT");
    h.line = line_no;
    sink.on_heater(h);
    return;
  }
  if (iequals(name, "G4") || iequals(name, "M400")) {  // unreachable: words; kept for clarity
    return;
  }
  for (auto n : kUntimedExtended) {
    if (iequals(name, n)) {
      sink.on_untimed(to_upper(name), line_no);
      sink.on_wait_moves(line_no);
      return;
    }
  }
  for (auto n : kIgnoredExtended) {
    if (iequals(name, n)) {
      note_ignored(name);
      return;
    }
  }
  note_unknown(name, line_no);
}

void Interpreter::apply_feed(const Params& p, std::uint64_t line_no) {
  if (!p.has('F')) return;
  const double f = p.get('F');
  if (!(f > 0.0)) {
    fail(line_no, p.column['F' - 'A'], fmt::format("feedrate F must be > 0 mm/min, got {}", f));
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
  if ((p.present & kAxes) == 0) return;  // F only: sets the speed of later moves
  std::array<double, 4> new_gcode;
  const std::array<double, 4> target = target_of(p, new_gcode);
  gcode_pos_ = new_gcode;
  emit_move(target, feed_mm_s_ * speed_factor_, line_no, sink, false);
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
                            bool from_retract) {
  if (target == pos_) return;
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
  pos_ = target;
  sink.on_move(m);
}

void Interpreter::do_arc(const Command& cmd, const Params& p, bool clockwise,
                         std::uint64_t line_no, EventSink& sink) {
  require_numbers(p, line_no);
  // Klipper refuses relative arcs; Marlin allows them: targets are then relative.
  apply_feed(p, line_no);
  // Plane axes: (alpha, beta) in the plane, helical axis normal to it.
  std::size_t a0 = 0, a1 = 1, ah = 2;
  char c0 = 'I', c1 = 'J';
  if (arc_plane_ == 18) { a0 = 0; a1 = 2; ah = 1; c0 = 'I'; c1 = 'K'; }
  if (arc_plane_ == 19) { a0 = 1; a1 = 2; ah = 0; c0 = 'J'; c1 = 'K'; }

  std::array<double, 4> new_gcode;
  const std::array<double, 4> target = target_of(p, new_gcode);
  const double e_total = target[3] - pos_[3];
  double off0 = 0.0, off1 = 0.0;  // center - start, in the plane
  const double p0 = pos_[a0], q0 = pos_[a1], p1 = target[a0], q1 = target[a1];
  if (p.has('R')) {
    const double r = p.get('R') * unit_mm_;
    const double dx = p1 - p0, dy = q1 - q0;
    const double d = std::hypot(dx, dy);
    if (d == 0.0 || r == 0.0) {
      fail(line_no, p.column['R' - 'A'],
           "G2/G3 R form needs a target different from the start and R != 0");
    }
    // Centre on the perpendicular bisector of the chord at distance h from its midpoint.
    // Counter-clockwise with R > 0 (arc < 180 degrees) puts the centre left of the chord.
    double h2 = r * r - 0.25 * d * d;
    if (h2 < 0.0) {
      if (std::fabs(r) * 2.0 < d * (1.0 - 1e-3)) {
        fail(line_no, p.column['R' - 'A'],
             fmt::format("G2/G3 radius R={} is smaller than half the chord ({} mm)", r, 0.5 * d));
      }
      h2 = 0.0;
    }
    const double side = ((clockwise ? -1.0 : 1.0) * (r < 0 ? -1.0 : 1.0));
    const double h = std::sqrt(h2);
    const double cx = 0.5 * (p0 + p1) + side * h * (-dy / d);
    const double cy = 0.5 * (q0 + q1) + side * h * (dx / d);
    off0 = cx - p0;
    off1 = cy - q0;
  } else {
    off0 = p.get_or(c0, 0.0) * unit_mm_;
    off1 = p.get_or(c1, 0.0) * unit_mm_;
    if (off0 == 0.0 && off1 == 0.0) {
      fail(line_no, cmd.args_column,
           fmt::format("{} needs a centre offset ({} {}) or a radius R", cmd.name, c0, c1));
    }
  }
  // Angular travel from start radius vector to end radius vector.
  const double rs0 = -off0, rs1 = -off1;  // start relative to centre
  const double cx = p0 + off0, cy = q0 + off1;
  const double re0 = p1 - cx, re1 = q1 - cy;
  double angle = std::atan2(rs0 * re1 - rs1 * re0, rs0 * re0 + rs1 * re1);
  if (angle < 0.0) angle += 2.0 * std::numbers::pi;
  if (clockwise) angle -= 2.0 * std::numbers::pi;
  if (angle == 0.0 && p0 == p1 && q0 == q1) angle = clockwise ? -2.0 * std::numbers::pi : 2.0 * std::numbers::pi;
  const double radius = std::hypot(rs0, rs1);
  const double linear = target[ah] - pos_[ah];
  const double flat = radius * std::fabs(angle);
  const double travel = linear != 0.0 ? std::hypot(flat, linear) : flat;
  double seg_len = opt_.mm_per_arc_segment;
  if (opt_.arc_segments_per_second > 0.0) {
    seg_len = feed_mm_s_ * speed_factor_ / opt_.arc_segments_per_second;
  }
  if (opt_.min_arc_segment_mm > 0.0) seg_len = std::max(seg_len, opt_.min_arc_segment_mm);
  if (opt_.max_arc_segment_mm > 0.0) seg_len = std::min(seg_len, opt_.max_arc_segment_mm);
  const double segments_d = std::max(1.0, std::floor(travel / seg_len));
  if (segments_d > 1e7) {
    fail(line_no, cmd.args_column,
         fmt::format("arc of {} mm would need {} segments: radius or segment length is absurd",
                     travel, segments_d));
  }
  const auto segments = static_cast<std::int64_t>(segments_d);
  const double start_e = pos_[3];
  const std::array<double, 4> start = pos_;
  for (std::int64_t i = 1; i <= segments; ++i) {
    std::array<double, 4> t;
    if (i == segments) {
      t = target;
      t[3] = start_e + e_total;
    } else {
      const double th = angle * static_cast<double>(i) / segments_d;
      const double c = std::cos(th), s = std::sin(th);
      t = start;
      t[a0] = cx + rs0 * c - rs1 * s;
      t[a1] = cy + rs0 * s + rs1 * c;
      t[ah] = start[ah] + linear * static_cast<double>(i) / segments_d;
      t[3] = start_e + e_total * static_cast<double>(i) / segments_d;
    }
    emit_move(t, feed_mm_s_ * speed_factor_, line_no, sink, true);
  }
  gcode_pos_ = new_gcode;
}

}  // namespace amctl::gcode
