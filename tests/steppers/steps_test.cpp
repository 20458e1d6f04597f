// Step generation against closed forms, a bisection on the exact trajectory, and counting.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/steppers/steps.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "step_run.hpp"

namespace amctl::steppers {
namespace {

using machine::Machine;

Machine test_machine(kinematics::Params k = kinematics::Cartesian{},
                     machine::VelocityProfile p = machine::VelocityProfile::trapezoid) {
  Machine m;
  m.kinematics = k;
  m.profile = p;
  m.max_jerk_mm_s3 = 1.0e5;
  m.steppers["x"] = {40.0, 16, 200};  // 0.0125 mm
  m.steppers["y"] = {40.0, 16, 200};
  m.steppers["z"] = {8.0, 16, 200};   // 0.0025 mm
  m.steppers["e"] = {22.857142857142858, 32, 200};
  return m;
}

using test::run;
using test::StepRun;

// The tool state with X, Y replaced by the motors' A, B: CoreXY A = X + Y, B = X - Y
// (Klipper's kin_corexy.c), cartesian unchanged. Written here, independent of the kinematics
// module.
trajectory::AxisState to_motor(kinematics::Params k, trajectory::AxisState s) {
  if (!kinematics::is<kinematics::CoreXY>(k)) return s;
  for (auto* v : {&s.pos_mm, &s.vel_mm_s, &s.acc_mm_s2, &s.jerk_mm_s3}) {
    const double x = (*v)[0], y = (*v)[1];
    (*v)[0] = x + y;
    (*v)[1] = x - y;
  }
  return s;
}

// Every step sits on its half-step level: motor position at the step time, from
// Trajectory::evaluate, equals origin + (n - dir/2) * step after the step to 1e-9 mm.
void expect_on_levels(const StepRun& r, kinematics::Params k) {
  const trajectory::Trajectory traj(r.moves);
  const auto s0 = to_motor(k, traj.evaluate(r.moves.front().start_time_s));
  for (std::uint32_t c = 0; c < r.motors.size(); ++c) {
    const std::size_t axis = c < 2 ? c : (r.motors[c].key[0] == 'z' ? 2 : 3);
    const double origin = s0.pos_mm[axis];
    const double step = r.motors[c].step_distance.value;
    long n = 0;
    double last_t = -1.0;
    for (const Step& s : r.of(c)) {
      const double level = origin + (static_cast<double>(n) + 0.5 * s.direction) * step;
      n += s.direction;
      const auto st = to_motor(k, traj.evaluate(s.time_s));
      ASSERT_NEAR(st.pos_mm[axis], level, 1e-9) << r.motors[c].name << " t=" << s.time_s;
      ASSERT_GE(s.time_s, last_t);
      last_t = s.time_s;
    }
  }
}

TEST(Steps, TrapezoidFromRestMatchesClosedForm) {
  const Machine m = test_machine();
  const StepRun r = run("G1 X10 F6000\n", m);
  ASSERT_EQ(r.moves.size(), 1u);
  const plan::PlannedMove& mv = r.moves[0];
  ASSERT_EQ(mv.start_v_mm_s, 0.0);
  ASSERT_GT(mv.cruise_t_s, 0.0);
  const double a = mv.accel_mm_s2, v = mv.cruise_v_mm_s, D = mv.distance_mm;
  const double xa = 0.5 * v * mv.accel_t_s, xc = xa + v * mv.cruise_t_s;
  const std::vector<Step> xs = r.of(0);
  ASSERT_EQ(xs.size(), 800u);
  const double step = 0.0125;
  for (std::size_t k = 1; k <= xs.size(); ++k) {
    const double x = (static_cast<double>(k) - 0.5) * step;
    double t = 0.0;
    if (x <= xa) t = std::sqrt(2.0 * x / a);
    else if (x <= xc) t = mv.accel_t_s + (x - xa) / v;
    else t = mv.duration_s() - std::sqrt(2.0 * (D - x) / a);
    EXPECT_NEAR(xs[k - 1].time_s, mv.start_time_s + t, 1e-9) << "k=" << k;
    EXPECT_EQ(xs[k - 1].direction, 1);
  }
  // Cruise steps are equally spaced by step / v.
  int cruise_pairs = 0;
  for (std::size_t k = 1; k < xs.size(); ++k) {
    const double x0 = (static_cast<double>(k) - 0.5) * step, x1 = x0 + step;
    if (x0 > xa && x1 < xc) {
      EXPECT_NEAR(xs[k].time_s - xs[k - 1].time_s, step / v, 1e-12);
      ++cruise_pairs;
    }
  }
  EXPECT_GT(cruise_pairs, 100);
  EXPECT_NEAR(r.stats[0].min_interval_s, step / v, 1e-12);
  EXPECT_TRUE(r.of(1).empty());
  expect_on_levels(r, m.kinematics);
}

TEST(Steps, ReversalChangesDirection) {
  const Machine m = test_machine();
  const StepRun r = run("G1 X10 F6000\nG1 X5\n", m);
  const std::vector<Step> xs = r.of(0);
  ASSERT_EQ(xs.size(), 1200u);
  for (std::size_t i = 0; i < 800; ++i) EXPECT_EQ(xs[i].direction, 1);
  for (std::size_t i = 800; i < 1200; ++i) EXPECT_EQ(xs[i].direction, -1);
  EXPECT_GE(xs[800].time_s, r.moves[1].start_time_s);
  EXPECT_EQ(r.stats[0].position_steps, 400);
  expect_on_levels(r, m.kinematics);
}

TEST(Steps, CoreXYPureXPureYAndDiagonal) {
  const Machine m = test_machine(kinematics::Params{kinematics::CoreXY{}});
  {  // pure X: A = X + Y and B = X - Y both turn forward, step for step
    const StepRun r = run("G1 X10 F6000\n", m);
    const auto a = r.of(0), b = r.of(1);
    ASSERT_EQ(a.size(), 800u);
    ASSERT_EQ(b.size(), 800u);
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].time_s, b[i].time_s);
      EXPECT_EQ(a[i].direction, 1);
      EXPECT_EQ(b[i].direction, 1);
    }
    expect_on_levels(r, m.kinematics);
  }
  {  // pure Y: A forward, B backward
    const StepRun r = run("G1 Y10 F6000\n", m);
    const auto a = r.of(0), b = r.of(1);
    ASSERT_EQ(a.size(), 800u);
    ASSERT_EQ(b.size(), 800u);
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].time_s, b[i].time_s);
      EXPECT_EQ(a[i].direction, 1);
      EXPECT_EQ(b[i].direction, -1);
    }
    expect_on_levels(r, m.kinematics);
  }
  {  // diagonal X = Y: B stands still, A moves 2x
    const StepRun r = run("G1 X10 Y10 F6000\n", m);
    EXPECT_EQ(r.of(0).size(), 1600u);
    EXPECT_TRUE(r.of(1).empty());
    expect_on_levels(r, m.kinematics);
  }
}

TEST(Steps, CountEqualsRoundedDisplacementBetweenRests) {
  const Machine m = test_machine();
  const StepRun r = run("G1 X13.3337 Y-7.21 Z0.3 E1.2345 F3000\nG4 P100\nG1 E0.4 F2400\n", m);
  const double d[4] = {13.3337, 7.21, 0.3, 0.4};
  for (std::uint32_t c = 0; c < 4; ++c) {
    const double step = r.motors[c].step_distance.value;
    const std::size_t expect = c < 3 ? static_cast<std::size_t>(std::llround(d[c] / step))
                                     : static_cast<std::size_t>(std::llround(1.2345 / step)) +
                                           static_cast<std::size_t>(std::llround(1.2345 / step) -
                                                                    std::llround(0.4 / step));
    EXPECT_EQ(r.of(c).size(), expect) << r.motors[c].name;
  }
  EXPECT_EQ(r.stats[1].steps_negative, r.stats[1].steps);
  EXPECT_EQ(r.stats[3].position_steps, std::llround(0.4 / r.motors[3].step_distance.value));
  expect_on_levels(r, m.kinematics);
}

TEST(Steps, ExtrudeOnlyMove) {
  const Machine m = test_machine();
  const StepRun r = run("G1 E5 F1800\nG1 E3\n", m);
  const double step = r.motors[3].step_distance.value;
  EXPECT_EQ(r.stats[3].steps_positive, static_cast<std::uint64_t>(std::llround(5.0 / step)));
  EXPECT_EQ(r.stats[3].position_steps, std::llround(3.0 / step));
  expect_on_levels(r, m.kinematics);
}

// Crossing times on jerk-limited pieces against a plain bisection on Trajectory::evaluate.
void check_against_bisection(machine::VelocityProfile p) {
  const Machine m = test_machine(kinematics::Params{kinematics::Cartesian{}}, p);
  const StepRun r = run("G1 X10 Y3 F9000\nG1 X2 Y5\n", m);
  ASSERT_EQ(r.moves.size(), 2u);
  ASSERT_EQ(r.moves[0].profile, p);
  const trajectory::Trajectory traj(r.moves);
  std::size_t checked = 0;
  for (std::uint32_t c = 0; c < 2; ++c) {
    const double step = r.motors[c].step_distance.value;
    const double origin = 0.0;
    long n = 0;
    std::size_t i = 0;
    for (const Step& s : r.of(c)) {
      const double level = origin + (static_cast<double>(n) + 0.5 * s.direction) * step;
      n += s.direction;
      if (i++ % 7 != 0) continue;
      // The move holding the step, then bisection on its time span.
      const plan::PlannedMove* mv = nullptr;
      for (const auto& mm : r.moves) if (mm.start_time_s <= s.time_s) mv = &mm;
      double lo = mv->start_time_s, hi = mv->end_time_s();
      const double sign = s.direction * (mv->axes_r[c] > 0 ? 1.0 : -1.0) * s.direction;
      for (int it = 0; it < 100; ++it) {
        const double mid = 0.5 * (lo + hi);
        const double f = (traj.evaluate(mid).pos_mm[c] - level) * sign;
        if (f >= 0.0) hi = mid; else lo = mid;
      }
      EXPECT_NEAR(s.time_s, 0.5 * (lo + hi), 1e-9) << r.motors[c].name << " step " << i;
      ++checked;
    }
    EXPECT_EQ(r.stats[c].position_steps, std::lround((c == 0 ? 2.0 : 5.0) / step));
  }
  EXPECT_GT(checked, 250u);
  expect_on_levels(r, m.kinematics);
}

TEST(Steps, Scurve7CrossingsMatchBisection) { check_against_bisection(machine::VelocityProfile::scurve7); }
TEST(Steps, Bezier5CrossingsMatchBisection) { check_against_bisection(machine::VelocityProfile::bezier5); }

// A zigzag of short and long moves through corners (motors reverse at speed on CoreXY),
// with Z hops and retracts: every step on its half-step level, times non-decreasing, and the
// net step position of each motor equal to its rounded displacement.
TEST(Steps, RandomZigzagStaysOnTheGrid) {
  for (const kinematics::Params& k : {kinematics::Params{kinematics::Cartesian{}}, kinematics::Params{kinematics::CoreXY{}}}) {
    for (const auto p : {machine::VelocityProfile::trapezoid, machine::VelocityProfile::scurve7,
                         machine::VelocityProfile::bezier5}) {
      const Machine m = test_machine(k, p);
      std::string g = "G1 X5 Y5 F9000\n";
      std::uint64_t x = 12345;
      auto rnd = [&x] {  // deterministic LCG in [0, 1)
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<double>(x >> 11) / 9007199254740992.0;
      };
      double e = 0.0;
      for (int i = 0; i < 60; ++i) {
        e += 0.05 * rnd();
        g += "G1 X" + std::to_string(2.0 + 40.0 * rnd()) + " Y" + std::to_string(2.0 + 40.0 * rnd()) +
             " E" + std::to_string(e) + " F" + std::to_string(1200 + 12000 * rnd()) + "\n";
        if (i % 10 == 9) g += "G1 E" + std::to_string(e - 0.8) + " F2400\nG1 Z" + std::to_string(0.2 * i / 9) + "\nG1 E" + std::to_string(e) + "\n";
      }
      const StepRun r = run(g, m);
      expect_on_levels(r, k);
      const trajectory::Trajectory traj(r.moves);
      const auto s0 = to_motor(k, traj.evaluate(r.moves.front().start_time_s));
      const auto s1 = to_motor(k, traj.evaluate(traj.end_time_s() + 1.0));
      for (std::uint32_t c = 0; c < 4; ++c) {
        const std::size_t axis = c;
        EXPECT_EQ(r.stats[c].position_steps,
                  std::llround((s1.pos_mm[axis] - s0.pos_mm[axis]) / r.motors[c].step_distance.value))
            << r.motors[c].name;
        EXPECT_EQ(r.stats[c].steps, r.stats[c].steps_positive + r.stats[c].steps_negative);
      }
      EXPECT_GT(r.stats[0].steps_negative, 1000u);
    }
  }
}

// Klipper's itersolve takes a step when the motor is within 1e-9 mm of the half-step level: a
// move ending 0.5 nm short of the level steps at its end, one ending 5 nm short does not (the
// step comes in the next move). Found by the Klipper cross-check (docs/steppers.md section 6):
// a Cura purge line ends at E15, 0.98 nm short of the extruder's level 2116.5.
TEST(Steps, LevelReachedWithinKlippersTolerance) {
  const Machine m = test_machine();
  const double h = 0.0125;
  for (const double short_mm : {0.5e-9, 5e-9}) {
    const double x1 = 10.5 * h - short_mm;  // 10 steps, the 11th level 'short_mm' away
    char g[128];
    std::snprintf(g, sizeof g, "G1 X%.17g F600\nG4 P100\nG1 X%.17g\n", x1, 20.0 * h);
    const StepRun r = run(g, m);
    const auto x = r.of(0);
    ASSERT_EQ(x.size(), 20u);
    const double end1 = r.moves[0].end_time_s();
    if (short_mm < kLevelToleranceMm) {
      EXPECT_NEAR(x[10].time_s, end1, 1e-9) << short_mm;
    } else {
      EXPECT_GT(x[10].time_s, end1 + 0.1) << short_mm;
    }
  }
}

TEST(Steps, StepDistanceIsKlippers) {
  machine::Stepper s{40.0 / (80.0 / 16.0), 32, 200};  // gear_ratio 80:16 folded in
  EXPECT_DOUBLE_EQ(machine::step_distance(s, "stepper_z"), 40.0 / (200.0 * 32.0 * 5.0));
}

TEST(Steps, BadMachinesNameTheParameter) {
  Machine m = test_machine();
  m.steppers.erase("y");
  m.steppers.erase("e");
  try {
    (void)machine::motors(m);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("stepper_y, extruder"), std::string::npos) << e.what();
  }
  m = test_machine();
  m.steppers["x"].rotation_distance_mm = 0.0;
  EXPECT_THROW((void)machine::motors(m), Error);
  try { (void)machine::motors(m); } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("stepper_x.rotation_distance"), std::string::npos);
  }
  m = test_machine();
  m.steppers["e"].microsteps = -4;
  try { (void)machine::motors(m); FAIL(); } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("extruder.microsteps"), std::string::npos);
  }
}

// The whole job on a Klipper reference input: a 20 mm square from (50, 50) and back.
TEST(Steps, GenerateStepsFileAndJson) {
  const Machine m = machine::load_machine(std::string(AMCTL_SOURCE_DIR) +
                                          "/tests/reference/klipper/ender3_cartesian.cfg");
  const StepsReport r = generate_steps_file(
      std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/syn_square.gcode", m, "");
  ASSERT_EQ(r.motors.size(), 4u);
  EXPECT_EQ(r.moves, 4u);
  for (std::uint32_t c = 0; c < 2; ++c) {
    const double h = r.motors[c].step_distance.value;
    EXPECT_EQ(r.stats[c].steps_positive, static_cast<std::uint64_t>(std::llround(20.0 / h)));
    EXPECT_EQ(r.stats[c].steps_negative, r.stats[c].steps_positive);
    EXPECT_EQ(r.stats[c].position_steps, 0);
  }
  EXPECT_EQ(r.total_steps(), r.stats[0].steps + r.stats[1].steps);
  const Json j = to_json(r);
  EXPECT_EQ(j["steppers"][0]["name"], "stepper_x");
  EXPECT_EQ(j["steppers"][3]["name"], "extruder");
  EXPECT_TRUE(j["steppers"][2]["peak_step_rate_steps_s"].is_null());
  EXPECT_TRUE(j["csv"].is_null());
  // The peak rate of X is the cruise rate of the fastest straight side: v / h.
  const double v = j["steppers"][0]["peak_step_rate_steps_s"].get<double>() * r.motors[0].step_distance.value;
  EXPECT_NEAR(v, 100.0, 1e-6);
}

TEST(Steps, CsvWrittenWholeOrNotAtAll) {
  const std::string path = std::string(AMCTL_BINARY_DIR) + "/steppers_test_steps.csv";
  std::remove(path.c_str());
  {
    StepsFile f(path, {"stepper_x"});
    const Step s{0.5, 0, 1};
    f.write(std::span<const Step>(&s, 1));
  }  // no commit: nothing left
  std::FILE* probe = std::fopen(path.c_str(), "rb");
  EXPECT_EQ(probe, nullptr);
  if (probe) std::fclose(probe);
  {
    StepsFile f(path, {"stepper_x"});
    const Step s[2] = {{0.5, 0, 1}, {0.75, 0, -1}};
    f.write(s);
    f.commit();
  }
  std::FILE* in = std::fopen(path.c_str(), "rb");
  ASSERT_NE(in, nullptr);
  char buf[256] = {};
  const std::size_t n = std::fread(buf, 1, sizeof buf - 1, in);
  std::fclose(in);
  EXPECT_EQ(std::string(buf, n), "stepper,time_s,direction\nstepper_x,0.5,1\nstepper_x,0.75,-1\n");
  std::remove(path.c_str());
}

}  // namespace
}  // namespace amctl::steppers
