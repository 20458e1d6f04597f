// SET_INPUT_SHAPER and SET_PRESSURE_ADVANCE in the G-code (docs/steppers.md section 8), checked
// against a second method. Klipper applies a new shaper or smoothing time after a
// step-generation flush, from rest where the toolhead stands (its flush moves the finished
// moves out of the queue the position reads), and a new advance alone to the moves queued
// after it. So between two flushes the motors follow the settings of that stretch applied to
// its moves only, and across a flush each motor goes on from where it stood: the chained
// position P(t) = q_k(t) - q_k(start of stretch k) + P(end of stretch k - 1), with q_k the
// motor at the shaped position of shaping::ShapedCursor (one trajectory cursor per impulse,
// no polynomial pieces) or the extruder by 5-point Gauss-Legendre quadrature of
// e + pa(move) v_e under the triangular weight. Every step must sit on its level of P, and
// at every sample the steps taken so far must equal P rounded. The planner's restart waits
// are checked against Klipper's kin_flush_delay written out here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"
#include "amctl/shaping/shaper.hpp"
#include "amctl/steppers/shaped_steps.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "pressure_advance_reference.hpp"

namespace amctl::steppers {
namespace {

using machine::Machine;

Machine corexy() {
  Machine m;
  m.kinematics = kinematics::CoreXY{};
  m.steppers["x"] = {40.0, 16, 200};  // 0.0125 mm
  m.steppers["y"] = {40.0, 16, 200};
  m.steppers["z"] = {8.0, 16, 200};
  m.steppers["e"] = {22.857142857142858, 32, 200};
  m.input_shaper.shaper_type_x = "mzv";
  m.input_shaper.shaper_freq_x_hz = 40.0;
  m.input_shaper.shaper_type_y = "ei";
  m.input_shaper.shaper_freq_y_hz = 35.0;
  m.extruder.pressure_advance_s = 0.04;
  m.extruder.pressure_advance_smooth_time_s = 0.03;
  return m;
}

struct TunedRun {
  std::vector<kinematics::Motor> motors;
  std::vector<Step> steps;
  std::vector<plan::PlannedMove> moves;
  std::vector<plan::PlanEvent> events;
  std::vector<StepperStats> stats;
};

TunedRun run(const std::string& gcode, const Machine& m) {
  TunedRun r;
  r.motors = machine::motors(m);
  plan::PlanSource source(std::string_view(gcode), "test", m);
  TunedStepSink sink(r.motors, m, [&](std::span<const Step> st) {
    r.steps.insert(r.steps.end(), st.begin(), st.end());
  });
  plan::CollectSink collect;
  plan::Sink* sinks[] = {&sink, &collect};
  plan::run_pipeline(source, sinks);
  r.moves = collect.moves;
  r.events = collect.events;
  r.stats = sink.stats();
  return r;
}

std::string moves(int n, double z, std::uint64_t seed) {
  std::string g;
  std::uint64_t x = seed;
  auto rnd = [&x] {
    x = x * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(x >> 11) / 9007199254740992.0;
  };
  static double e = 0.0;
  for (int i = 0; i < n; ++i) {
    e += 0.3 * rnd();
    g += "G1 X" + std::to_string(5.0 + 40.0 * rnd()) + " Y" + std::to_string(5.0 + 40.0 * rnd()) +
         " E" + std::to_string(e) + " F" + std::to_string(1800 + 12000 * rnd()) + "\n";
    if (i % 5 == 4) g += "G1 E" + std::to_string(e - 0.5) + " F2400\nG1 E" + std::to_string(e) + "\n";
  }
  g += "G1 Z" + std::to_string(z) + " F600\n";
  return g;
}

/// One stretch between flushes: its moves and its settings.
struct Stretch {
  std::vector<plan::PlannedMove> moves;
  std::vector<double> advance;  ///< per move
  shaping::AxisShapers shapers;
  double half_smooth_s = 0.0;   ///< 0: no pressure advance
};

double motor_at(std::uint32_t c, const std::array<double, 4>& p) {
  if (c == 0) return p[0] + p[1];
  if (c == 1) return p[0] - p[1];
  return p[c];
}

// The extruder of stretch s at t by quadrature (pressure_advance_reference.hpp), each move
// with the advance it was queued under.
double extruder_at(const Stretch& s, const trajectory::Trajectory& traj, double t) {
  return test::extruder_by_quadrature(traj, s.moves, [&s](std::size_t j) { return s.advance[j]; },
                                      s.half_smooth_s, t);
}

// Splits the run at its flush events, with the settings each stretch had (written out from
// the G-code's commands as the test gives them).
void check(const TunedRun& r, std::vector<Stretch> stretches, const std::vector<double>& switch_s) {
  ASSERT_EQ(stretches.size(), switch_s.size() + 1);
  for (const plan::PlannedMove& mv : r.moves) {
    std::size_t k = 0;
    while (k < switch_s.size() && mv.start_time_s >= switch_s[k]) ++k;
    stretches[k].moves.push_back(mv);
  }
  for (std::uint32_t c = 0; c < r.motors.size(); ++c) {
    const double step = r.motors[c].step_distance.value;
    // P(t) per stretch: the position function and its offset so the chain is continuous.
    std::vector<std::unique_ptr<trajectory::Trajectory>> trajs;
    std::vector<double> offset(stretches.size(), 0.0);
    for (std::size_t k = 0; k < stretches.size(); ++k) {
      ASSERT_FALSE(stretches[k].moves.empty());
      trajs.push_back(std::make_unique<trajectory::Trajectory>(stretches[k].moves));
    }
    const auto value = [&](std::size_t k, double t) {
      if (c == 3) return extruder_at(stretches[k], *trajs[k], t);
      // ShapedCursor wants non-decreasing times: a fresh one per query keeps it simple.
      shaping::ShapedCursor sc(stretches[k].moves, stretches[k].shapers);
      return motor_at(c, sc.evaluate(t).pos_mm);
    };
    for (std::size_t k = 1; k < stretches.size(); ++k) {
      const double rest_prev = value(k - 1, switch_s[k - 1]);
      const double rest_now = value(k, stretches[k].moves.front().start_time_s - 0.5);
      offset[k] = offset[k - 1] + rest_prev - rest_now;
    }
    const auto P = [&](double t) {
      std::size_t k = 0;
      while (k < switch_s.size() && t >= switch_s[k]) ++k;
      return value(k, t) + offset[k];
    };
    const double t0 = r.moves.front().start_time_s - 0.1;
    const double origin = P(t0);
    long n = 0;
    std::vector<Step> mine;
    for (const Step& st : r.steps) if (st.stepper == c) mine.push_back(st);
    ASSERT_GT(mine.size(), 100u) << r.motors[c].name;
    for (const Step& st : mine) {
      const double level = origin + (static_cast<double>(n) + 0.5 * st.direction) * step;
      n += st.direction;
      ASSERT_NEAR(P(st.time_s), level, 1e-9) << r.motors[c].name << " t=" << st.time_s;
    }
    EXPECT_EQ(n, r.stats[c].position_steps);
    std::size_t i = 0;
    long taken = 0;
    const double t_end = r.moves.back().end_time_s() + 0.2;
    std::size_t checked = 0;
    for (double t = t0; t < t_end; t += 5e-4) {
      while (i < mine.size() && mine[i].time_s <= t) taken += mine[i++].direction;
      const double u = (P(t) - origin) / step;
      if (std::abs(u - std::floor(u) - 0.5) < 1e-6) continue;
      ASSERT_EQ(taken, std::lround(u)) << r.motors[c].name << " t=" << t;
      ++checked;
    }
    EXPECT_GT(checked, 1000u);
  }
}

std::vector<double> flush_times(const TunedRun& r) {
  std::vector<double> t;
  for (const plan::PlanEvent& e : r.events) {
    if (e.kind == plan::PlanEvent::Kind::step_tuning && e.tuning.flush) t.push_back(e.time_s);
  }
  return t;
}

// Klipper's kin_flush_delay written out: the farthest impulse from the shaper's weighted
// centre, half the smoothing time with pressure advance on, at least 1 ms.
double reach(const shaping::Shaper& s) {
  double sa = 0.0, sat = 0.0;
  for (std::size_t i = 0; i < s.amplitudes.size(); ++i) {
    sa += s.amplitudes[i];
    sat += s.amplitudes[i] * s.times_s[i];
  }
  const double c = sat / sa;
  return std::max(c, s.times_s.back() - c);
}

TEST(TunedSteps, ShaperChangesMidPrintAgainstShapedCursor) {
  const Machine m = corexy();
  const std::string g = "G1 X5 Y5 F6000\n" + moves(12, 0.4, 1) +
                        "SET_INPUT_SHAPER SHAPER_FREQ_X=25 SHAPER_TYPE_X=zvd\n" + moves(12, 0.6, 2) +
                        "SET_INPUT_SHAPER SHAPER_FREQ_Y=0 SHAPER_FREQ_Z=30 SHAPER_TYPE_Z=zv\n" +
                        moves(12, 0.9, 3) + "SET_INPUT_SHAPER SHAPER_TYPE=2hump_ei SHAPER_FREQ_Y=50\n" +
                        moves(12, 1.2, 4);
  const TunedRun r = run(g, m);
  const std::vector<double> sw = flush_times(r);
  ASSERT_EQ(sw.size(), 3u);
  const auto sh = [](const char* t, double f) { return shaping::make_shaper(t, f, 0.1); };
  std::vector<Stretch> s(4);
  s[0].shapers.xyz = {sh("mzv", 40), sh("ei", 35), std::nullopt};
  s[1].shapers.xyz = {sh("zvd", 25), sh("ei", 35), std::nullopt};
  s[2].shapers.xyz = {sh("zvd", 25), std::nullopt, sh("zv", 30)};
  s[3].shapers.xyz = {sh("2hump_ei", 25), sh("2hump_ei", 50), sh("2hump_ei", 30)};
  for (auto& x : s) x.half_smooth_s = 0.015;
  for (auto& x : s) x.advance.assign(200, 0.04);
  // The restart waits: each flush's next move starts the delays before and after it past the
  // last move's end.
  const double h = 0.015;
  const std::vector<double> before = {std::max({reach(*s[0].shapers.xyz[0]), reach(*s[0].shapers.xyz[1]), h}),
                                      std::max({reach(*s[1].shapers.xyz[0]), reach(*s[1].shapers.xyz[1]), h}),
                                      std::max({reach(*s[2].shapers.xyz[0]), reach(*s[2].shapers.xyz[2]), h})};
  const std::vector<double> after = {before[1], before[2],
                                     std::max({reach(*s[3].shapers.xyz[0]), reach(*s[3].shapers.xyz[1]),
                                               reach(*s[3].shapers.xyz[2]), h})};
  for (std::size_t k = 0; k < sw.size(); ++k) {
    double last_end = 0.0, next_start = 1e9;
    for (const plan::PlannedMove& mv : r.moves) {
      if (mv.end_time_s() <= sw[k] + 1e-12) last_end = std::max(last_end, mv.end_time_s());
      else next_start = std::min(next_start, mv.start_time_s);
    }
    EXPECT_NEAR(sw[k], last_end + before[k], 1e-12) << k;
    EXPECT_NEAR(next_start, last_end + before[k] + after[k], 1e-9) << k;
  }
  // Stretch moves need per-move advance; sized once the moves are split (check() resizes).
  for (auto& x : s) x.advance.assign(r.moves.size(), 0.04);
  check(r, s, sw);
}

TEST(TunedSteps, PressureAdvanceChangesMidPrintAgainstQuadrature) {
  Machine m = corexy();
  m.input_shaper = {};
  m.input_shaper.shaper_freq_x_hz = 0.0;
  // The first stretch: pa 0.04 then 0.1 (no flush: moves after the command), then a new
  // smoothing time (flush), then pressure advance off (flush), then on again (flush).
  const std::string g = "G1 X5 Y5 F6000\n" + moves(10, 0.4, 5) + "SET_PRESSURE_ADVANCE ADVANCE=0.1\n" +
                        moves(10, 0.5, 6) + "SET_PRESSURE_ADVANCE SMOOTH_TIME=0.08\n" +
                        moves(10, 0.6, 7) + "SET_PRESSURE_ADVANCE ADVANCE=0\n" + moves(10, 0.7, 8) +
                        "SET_PRESSURE_ADVANCE EXTRUDER=extruder ADVANCE=0.03 SMOOTH_TIME=0.02\n" +
                        moves(10, 0.8, 9);
  const TunedRun r = run(g, m);
  const std::vector<double> sw = flush_times(r);
  ASSERT_EQ(sw.size(), 3u);
  std::vector<Stretch> s(4);
  s[0].half_smooth_s = 0.015;
  s[1].half_smooth_s = 0.04;
  s[2].half_smooth_s = 0.0;
  s[3].half_smooth_s = 0.01;
  // The advance of each move: 0.04 up to the first command's place in the stream, 0.1 after.
  double first_change = 0.0;
  for (const plan::PlanEvent& e : r.events) {
    if (e.kind == plan::PlanEvent::Kind::step_tuning && !e.tuning.flush) first_change = e.time_s;
  }
  ASSERT_GT(first_change, 0.0);
  for (const plan::PlannedMove& mv : r.moves) {
    std::size_t k = 0;
    while (k < sw.size() && mv.start_time_s >= sw[k]) ++k;
    const double pa = k == 0 ? (mv.start_time_s < first_change ? 0.04 : 0.1) : k == 1 ? 0.1 : k == 2 ? 0.0 : 0.03;
    s[k].advance.push_back(pa);
  }
  check(r, s, sw);
}

TEST(TunedSteps, NoCommandEqualsTheMachinesSettingsAndThePlainGenerator) {
  // Without shaper or pressure advance the sink is the plain generator (byte for byte); a
  // SET_INPUT_SHAPER that turns nothing on keeps it.
  Machine m = corexy();
  m.input_shaper = {};
  m.extruder.pressure_advance_s = 0.0;
  m.klipper_config.push_back(ConfigSection{"input_shaper", {}, {}, {}});
  const std::string g = "G1 X5 Y5 F6000\n" + moves(20, 0.4, 11);
  const TunedRun a = run(g, m);
  const TunedRun b = run(g + "SET_INPUT_SHAPER SHAPER_FREQ_X=0\n" + moves(5, 0.5, 12), m);
  const std::vector<kinematics::Motor> motors = machine::motors(m);
  std::vector<Step> plain;
  plan::PlanSource source(std::string_view(g), "test", m);
  StepSink sink(motors, [&](std::span<const Step> st) { plain.insert(plain.end(), st.begin(), st.end()); });
  plan::Sink* sinks[] = {&sink};
  plan::run_pipeline(source, sinks);
  ASSERT_EQ(a.steps.size(), plain.size());
  for (std::size_t i = 0; i < plain.size(); ++i) {
    EXPECT_EQ(a.steps[i].time_s, plain[i].time_s);
    EXPECT_EQ(a.steps[i].stepper, plain[i].stepper);
    EXPECT_EQ(b.steps[i].time_s, plain[i].time_s);
  }
  // Turning the shaper on mid-print hands the motors over with their counts.
  const TunedRun c = run(g + "SET_INPUT_SHAPER SHAPER_FREQ_X=40 SHAPER_FREQ_Y=40\n" + moves(20, 0.5, 13), m);
  const std::vector<double> sw = flush_times(c);
  ASSERT_EQ(sw.size(), 1u);
  std::vector<Stretch> s(2);
  s[1].shapers.xyz = {shaping::make_shaper("mzv", 40, 0.1), shaping::make_shaper("mzv", 40, 0.1), std::nullopt};
  for (auto& x : s) x.advance.assign(c.moves.size(), 0.0);
  check(c, s, sw);
}

TEST(TunedSteps, BadValuesStopAtTheirPlace) {
  Machine m = corexy();
  const auto fails = [&](const std::string& line, const std::string& what) {
    try {
      run("G1 X5 Y5 F6000\nG1 X10 E1\n" + line + "\nG1 X20 E2\n", m);
      ADD_FAILURE() << line;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("test:3:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  fails("SET_INPUT_SHAPER SHAPER_TYPE_X=foo SHAPER_FREQ_X=40", "'foo'");
  fails("SET_INPUT_SHAPER SHAPER_TYPE=zvdd", "'zvdd'");
  fails("SET_INPUT_SHAPER SHAPER_FREQ_Y=-3", "at least 0");
  fails("SET_INPUT_SHAPER SHAPER_TYPE_X=3hump_ei DAMPING_RATIO_X=0.3", "0.2");
  fails("SET_PRESSURE_ADVANCE ADVANCE=-0.1", "at least 0");
  fails("SET_PRESSURE_ADVANCE SMOOTH_TIME=0.3", "at most 0.2");
  fails("SET_PRESSURE_ADVANCE EXTRUDER=extruder1 ADVANCE=0.1", "'extruder1'");
  fails("SET_PRESSURE_ADVANCE ADVANCE=abc", "expected a finite number");
}

}  // namespace
}  // namespace amctl::steppers
