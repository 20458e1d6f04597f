// libFuzzer target for the G-code reader: arbitrary bytes through the line reader, the
// parser, the interpreter and the planner, in strict and lenient mode. The only acceptable
// outcomes are a report or amctl::Error (bad input); anything else is a bug. Each input is
// also interpreted twice to compare the fast path for plain moves with the general parser.
//
// Work budget: one G2/G3 line may legitimately expand into millions of segments (a 6 m arc at
// 1 mm per segment), so a 20 kB input could ask for 1e9 planned moves. That is real work, not
// a hang, but it hides actual hangs behind -timeout; the harness stops an input after
// kMaxMoves planned moves (every move up to there has been checked like any other).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include <cstring>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/plan/estimate.hpp"

namespace {
constexpr std::uint64_t kMaxMoves = 200000;
struct BudgetExhausted {};

// Differential check of the interpreter's fast path for plain G0/G1 lines: the same text with
// a "( )" comment after every G0/G1 word (which the fast path refuses) goes through the general
// parser only, and must give the same moves bit for bit and fail (or not) on the same line.
struct Moves : amctl::gcode::EventSink {
  std::vector<amctl::gcode::MoveRequest> moves;
  void on_move(const amctl::gcode::MoveRequest& m) override {
    if (moves.size() >= kMaxMoves) throw BudgetExhausted{};
    moves.push_back(m);
  }
};

struct Run {
  Moves events;
  std::uint64_t error_line = 0;  // 0: no error
  bool exhausted = false;
};

Run interpret(std::string_view text) {
  Run r;
  amctl::gcode::Interpreter in({}, "fuzz");
  amctl::gcode::LineReader reader(text, "fuzz");
  try {
    in.run(reader, r.events);
  } catch (const amctl::Error& e) {
    r.error_line = e.where().line == 0 ? ~std::uint64_t{0} : e.where().line;
  } catch (const BudgetExhausted&) {
    r.exhausted = true;
  }
  return r;
}

std::string general_only(std::string_view text) {
  std::string out;
  out.reserve(text.size() + text.size() / 4);
  std::size_t begin = 0;
  while (begin <= text.size()) {
    std::size_t end = text.find('\n', begin);
    const bool last = end == std::string_view::npos;
    if (last) end = text.size();
    std::string_view line = text.substr(begin, end - begin);
    // Lines with a checksum keep their bytes (the comment would change the XOR).
    if (line.size() >= 3 && (line[0] == 'G' || line[0] == 'g') && (line[1] == '0' || line[1] == '1') &&
        (line[2] == ' ' || line[2] == '\t') && line.find('*') == std::string_view::npos) {
      out.append(line.substr(0, 2));
      out.append(" (g)");
      out.append(line.substr(2));
    } else {
      out.append(line);
    }
    if (last) break;
    out.push_back('\n');
    begin = end + 1;
  }
  return out;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void check_fast_path(std::string_view text) {
  const Run fast = interpret(text);
  const std::string other = general_only(text);
  const Run general = interpret(other);
  if (fast.exhausted || general.exhausted) return;
  if (fast.error_line != general.error_line) __builtin_trap();
  if (fast.events.moves.size() != general.events.moves.size()) __builtin_trap();
  for (std::size_t i = 0; i < fast.events.moves.size(); ++i) {
    const auto& a = fast.events.moves[i];
    const auto& b = general.events.moves[i];
    for (std::size_t k = 0; k < 4; ++k) {
      if (!same_bits(a.start_mm[k], b.start_mm[k]) || !same_bits(a.end_mm[k], b.end_mm[k])) __builtin_trap();
    }
    if (!same_bits(a.speed_mm_s, b.speed_mm_s) || a.line != b.line || a.layer != b.layer ||
        a.feature != b.feature) {
      __builtin_trap();
    }
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  check_fast_path(text);
  for (bool strict : {true, false}) {
    // Klipper, Marlin, and a Klipper IDEX with [exclude_object] (the state commands' paths).
    for (int variant = 0; variant < 3; ++variant) {
      const auto fw = variant == 1 ? amctl::machine::Firmware::marlin : amctl::machine::Firmware::klipper;
      amctl::machine::Machine m;
      m.firmware = fw;
      if (variant == 2) {
        m.exclude_object = true;
        amctl::machine::Stepper x;
        x.position_min_mm = 0.0;
        x.position_max_mm = 250.0;
        x.position_endstop_mm = 0.0;
        m.steppers["x"] = x;
        m.dual_carriage.axis = "x";
        m.dual_carriage.position_min_mm = 0.0;
        m.dual_carriage.position_max_mm = 250.0;
        m.dual_carriage.position_endstop_mm = 250.0;
        m.dual_carriage.safe_distance_mm = 50.0;
      }
      m.junction = fw == amctl::machine::Firmware::klipper
                       ? amctl::machine::JunctionPolicy::square_corner_velocity
                       : amctl::machine::JunctionPolicy::classic_jerk;
      // Range checks: Klipper's stepper limits stop the print, Marlin's soft endstops clamp
      // (after G28) and later relative moves continue from the clamped point.
      if (fw == amctl::machine::Firmware::marlin) {
        m.soft_min_position_mm = {0.0, -5.0, 0.0};
        m.soft_max_position_mm = {220.0, 220.0, 250.0};
      }
      amctl::plan::EstimateOptions opt;
      opt.strict = strict;
      std::uint64_t moves = 0;
      opt.on_move = [&moves](const amctl::plan::PlannedMove& mv) {
        // Every planned move must have finite, non-negative phases.
        if (!(mv.accel_t_s >= 0.0 && mv.cruise_t_s >= 0.0 && mv.decel_t_s >= 0.0 &&
              std::isfinite(mv.duration_s()))) {
          __builtin_trap();
        }
        if (++moves > kMaxMoves) throw BudgetExhausted{};
      };
      try {
        auto r = amctl::plan::estimate_text(text, "fuzz", m, opt);
        if (!(r.total_time_s >= 0.0)) __builtin_trap();  // NaN or negative time is a bug
      } catch (const amctl::Error&) {
      } catch (const BudgetExhausted&) {
      }
    }
  }
  return 0;
}
