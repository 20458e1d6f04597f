// Steps with input shaping against a second method: the shaped position sampled by
// shaping::ShapedCursor (one trajectory::Cursor per impulse, no polynomial pieces), with the
// motors' positions written out here (corexy A = X + Y, B = X - Y; a delta carriage from the
// tower position and the arm length). Every step must sit on its half-step level, and at
// every sample time the steps taken so far must equal the motor's rounded position.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "amctl/machine/kinematics.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/shaped_pieces.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"
#include "amctl/steppers/shaped_steps.hpp"
#include "amctl/steppers/steps.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "pressure_advance_reference.hpp"
#include "step_run.hpp"

namespace amctl::steppers {
namespace {

using machine::Machine;

Machine cartesian(kinematics::Params k, machine::VelocityProfile p) {
  Machine m;
  m.kinematics = k;
  m.profile = p;
  m.max_jerk_mm_s3 = 1.0e5;
  m.steppers["x"] = {40.0, 16, 200};  // 0.0125 mm
  m.steppers["y"] = {40.0, 16, 200};
  m.steppers["z"] = {8.0, 16, 200};
  m.steppers["e"] = {22.857142857142858, 32, 200};
  return m;
}

constexpr double kRadius = 174.75, kArm = 333.0, kEndstop = 297.05;

Machine delta() {
  Machine m;
  kinematics::Delta d;
  d.radius_mm = kRadius;
  d.minimum_z_position_mm = -5.0;
  d.towers["a"] = {kArm, std::nullopt, kEndstop};
  m.kinematics = d;
  for (const char* t : {"a", "b", "c"}) m.steppers[t] = {40.0, 16, 200};
  m.steppers["e"] = {33.5, 16, 200};
  return m;
}

std::string zigzag(int moves) {
  std::string g = "G1 X5 Y5 F9000\n";
  std::uint64_t x = 12345;
  auto rnd = [&x] {
    x = x * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(x >> 11) / 9007199254740992.0;
  };
  double e = 0.0;
  for (int i = 0; i < moves; ++i) {
    e += 0.05 * rnd();
    g += "G1 X" + std::to_string(2.0 + 40.0 * rnd()) + " Y" + std::to_string(2.0 + 40.0 * rnd()) +
         " E" + std::to_string(e) + " F" + std::to_string(1200 + 12000 * rnd()) + "\n";
    if (i % 10 == 9) {
      g += "G1 E" + std::to_string(e - 0.8) + " F2400\nG1 Z" + std::to_string(0.2 * i / 9) +
           "\nG1 E" + std::to_string(e) + "\nG4 P30\n";
    }
  }
  return g;
}

struct ShapedRun {
  std::vector<kinematics::Motor> motors;
  std::vector<Step> steps;
  std::vector<plan::PlannedMove> moves;
  std::vector<StepperStats> stats;
};

ShapedRun run_shaped(const std::string& gcode, const Machine& m, const shaping::AxisShapers& s,
                     const shaping::PressureAdvance& pa = {}) {
  ShapedRun r;
  r.motors = machine::motors(m);
  plan::PlanSource source(std::string_view(gcode), "test", m);
  ShapedStepSink sink(r.motors, s, pa, [&](std::span<const Step> st) {
    r.steps.insert(r.steps.end(), st.begin(), st.end());
  });
  plan::CollectSink collect;
  plan::Sink* sinks[] = {&sink, &collect};
  plan::run_pipeline(source, sinks);
  r.moves = collect.moves;
  r.stats = sink.generator().stats();
  return r;
}

shaping::AxisShapers shapers(const char* tx, double fx, const char* ty, double fy) {
  shaping::AxisShapers s;
  s.xyz[0] = shaping::make_shaper(tx, fx, 0.1);
  s.xyz[1] = shaping::make_shaper(ty, fy, 0.1);
  return s;
}

// The motor positions, written out independently of the kinematics module.
double motor_position(const Machine& m, std::uint32_t c, const std::array<double, 4>& p) {
  if (kinematics::is<kinematics::Delta>(m.kinematics)) {
    if (c == 3) return p[3];
    const double angle = (210.0 + 120.0 * c) * std::numbers::pi / 180.0;
    const double tx = kRadius * std::cos(angle), ty = kRadius * std::sin(angle);
    return p[2] + std::sqrt(kArm * kArm - (p[0] - tx) * (p[0] - tx) - (p[1] - ty) * (p[1] - ty));
  }
  if (kinematics::is<kinematics::CoreXY>(m.kinematics)) {
    if (c == 0) return p[0] + p[1];
    if (c == 1) return p[0] - p[1];
  }
  return p[c];
}

// Each step on its level (to `tol_mm`), and the step count so far equal to the rounded motor
// position at every sample 0.1 ms apart (skipping samples within 1e-6 step of a level).
void check_against_sampling(const ShapedRun& r, const Machine& m, const shaping::AxisShapers& s,
                            double tol_mm, std::uint32_t motors = 99) {
  ASSERT_FALSE(r.moves.empty());
  for (std::uint32_t c = 0; c < std::min<std::uint32_t>(motors, r.motors.size()); ++c) {
    const double step = r.motors[c].step_distance.value;
    std::vector<Step> mine;
    for (const Step& st : r.steps) if (st.stepper == c) mine.push_back(st);
    shaping::ShapedCursor on_steps(r.moves, s);
    shaping::ShapedCursor sampled(r.moves, s);
    const double t0 = r.moves.front().start_time_s + on_steps.min_delay_s();
    const double origin = motor_position(m, c, on_steps.evaluate(t0).pos_mm);
    long n = 0;
    for (const Step& st : mine) {
      const double level = origin + (static_cast<double>(n) + 0.5 * st.direction) * step;
      n += st.direction;
      const double q = motor_position(m, c, on_steps.evaluate(st.time_s).pos_mm);
      ASSERT_NEAR(q, level, tol_mm) << r.motors[c].name << " t=" << st.time_s;
    }
    EXPECT_EQ(n, r.stats[c].position_steps);
    const double t_end = r.moves.back().end_time_s() + sampled.max_delay_s() + 0.01;
    std::size_t k = 0;
    long taken = 0;
    std::size_t checked = 0;
    for (double t = t0; t < t_end; t += 1e-4) {
      while (k < mine.size() && mine[k].time_s <= t) taken += mine[k++].direction;
      const double u = (motor_position(m, c, sampled.evaluate(t).pos_mm) - origin) / step;
      if (std::abs(u - std::floor(u) - 0.5) < 1e-6) continue;
      ASSERT_EQ(taken, std::lround(u)) << r.motors[c].name << " t=" << t;
      ++checked;
    }
    EXPECT_GT(checked, 1000u);
  }
}

// Pressure advance's extruder position by quadrature (pressure_advance_reference.hpp), with
// one advance for every move.
double extruder_by_quadrature(const trajectory::Trajectory& traj, double pa, double h, double t) {
  return test::extruder_by_quadrature(traj, traj.moves(), [pa](std::size_t) { return pa; }, h, t);
}

// The extruder's steps on their levels of the quadrature, and its step count at samples.
void check_extruder(const ShapedRun& r, double pa, double h) {
  const trajectory::Trajectory traj(r.moves);
  const std::uint32_t c = 3;
  const double step = r.motors[c].step_distance.value;
  const double origin = traj.evaluate(r.moves.front().start_time_s).pos_mm[3];
  long n = 0;
  std::vector<Step> mine;
  for (const Step& st : r.steps) if (st.stepper == c) mine.push_back(st);
  ASSERT_GT(mine.size(), 200u);
  for (const Step& st : mine) {
    const double level = origin + (static_cast<double>(n) + 0.5 * st.direction) * step;
    n += st.direction;
    ASSERT_NEAR(extruder_by_quadrature(traj, pa, h, st.time_s), level, 1e-9) << " t=" << st.time_s;
  }
  std::size_t k = 0;
  long taken = 0;
  for (double t = r.moves.front().start_time_s; t < traj.end_time_s() + h; t += 2e-4) {
    while (k < mine.size() && mine[k].time_s <= t) taken += mine[k++].direction;
    const double u = (extruder_by_quadrature(traj, pa, h, t) - origin) / step;
    if (std::abs(u - std::floor(u) - 0.5) < 1e-6) continue;
    ASSERT_EQ(taken, std::lround(u)) << " t=" << t;
  }
}

// Extrusions at changing speeds, retracts (no advance), a Z hop and an extrude-only prime.
std::string extrusions() {
  return "G1 X5 Y5 F6000\nG1 X25 Y5 E1.2 F3000\nG1 X25 Y9 E1.5\nG1 X5 Y30 E3.1 F9000\n"
         "G1 E2.3 F2400\nG1 Z0.4\nG1 X30 Y30 F12000\nG1 Z0.2\nG1 E3.1 F2400\n"
         "G1 X30 Y10 E4.0 F1800\nG1 X31 Y10 E4.05\nG1 X31 Y11 E4.1\nG1 X10 Y11 E5.5 F7200\n"
         "G4 P50\nG1 E6.5 F300\nG1 X40 Y40 E8.0 F6000\n";
}

TEST(PressureAdvanceSteps, ExtruderAgainstQuadrature) {
  for (const auto p : {machine::VelocityProfile::trapezoid, machine::VelocityProfile::scurve7}) {
    const Machine m = cartesian(kinematics::Cartesian{}, p);
    for (const auto& [pa, smooth] : {std::pair{0.05, 0.04}, std::pair{0.5, 0.2}, std::pair{0.02, 0.01}}) {
      const ShapedRun r = run_shaped(extrusions(), m, {}, shaping::PressureAdvance{pa, smooth});
      check_extruder(r, pa, 0.5 * smooth);
      // The other motors are the plain generator's (no shaper).
      const test::StepRun plain = test::run(extrusions(), m);
      for (std::uint32_t c = 0; c < 3; ++c) EXPECT_EQ(r.stats[c].steps, plain.stats[c].steps);
      EXPECT_EQ(r.stats[3].position_steps, plain.stats[3].position_steps);
    }
  }
}

TEST(PressureAdvanceSteps, WithInputShapingOnCoreXY) {
  const Machine m = cartesian(kinematics::CoreXY{}, machine::VelocityProfile::trapezoid);
  const auto s = shapers("mzv", 45.0, "ei", 38.0);
  const ShapedRun r = run_shaped(extrusions(), m, s, shaping::PressureAdvance{0.04, 0.04});
  check_against_sampling(r, m, s, 1e-9, 3);
  check_extruder(r, 0.04, 0.02);
}

// Without a shaper the shaped generator is the plain one: same steps, same times.
TEST(ShapedSteps, NoShaperEqualsThePlainGenerator) {
  for (const kinematics::Params& k :
       {kinematics::Params{kinematics::Cartesian{}}, kinematics::Params{kinematics::CoreXY{}}}) {
    for (const auto p : {machine::VelocityProfile::trapezoid, machine::VelocityProfile::scurve7,
                         machine::VelocityProfile::bezier5}) {
      const Machine m = cartesian(k, p);
      const std::string g = zigzag(40);
      const test::StepRun plain = test::run(g, m);
      const ShapedRun shaped = run_shaped(g, m, shaping::AxisShapers{});
      ASSERT_EQ(plain.steps.size(), shaped.steps.size());
      for (std::size_t i = 0; i < plain.steps.size(); ++i) {
        ASSERT_EQ(plain.steps[i].stepper, shaped.steps[i].stepper) << i;
        ASSERT_EQ(plain.steps[i].direction, shaped.steps[i].direction) << i;
        ASSERT_NEAR(plain.steps[i].time_s, shaped.steps[i].time_s, 1e-9) << i;
      }
    }
  }
}

TEST(ShapedSteps, CartesianAndCoreXYAgainstSampledShapedPosition) {
  for (const kinematics::Params& k :
       {kinematics::Params{kinematics::Cartesian{}}, kinematics::Params{kinematics::CoreXY{}}}) {
    for (const auto p : {machine::VelocityProfile::trapezoid, machine::VelocityProfile::scurve7}) {
      const Machine m = cartesian(k, p);
      for (const auto& s : {shapers("mzv", 40.0, "ei", 35.0), shapers("2hump_ei", 55.0, "zv", 62.0),
                            shapers("3hump_ei", 70.0, "zvd", 30.0)}) {
        const ShapedRun r = run_shaped(zigzag(16), m, s);
        check_against_sampling(r, m, s, 1e-9);
        EXPECT_GT(r.stats[0].steps, 1000u);
      }
    }
  }
}

// A motor reverses within a shaped piece near the end of a fast move into a reversal: the
// shaped motion overshoots nothing (the shaped position is a weighted mean of the plan's), so
// every reversal is one of the plan's, smeared over the shaper's span.
TEST(ShapedSteps, ReversalsAreStepsBackNotLost) {
  const Machine m = cartesian(kinematics::Cartesian{}, machine::VelocityProfile::trapezoid);
  const auto s = shapers("mzv", 25.0, "mzv", 25.0);
  const ShapedRun r = run_shaped("G1 X10 F12000\nG1 X0.03\nG1 X10\nG1 X0\n", m, s);
  check_against_sampling(r, m, s, 1e-9);
  EXPECT_EQ(r.stats[0].position_steps, 0);
  EXPECT_GT(r.stats[0].steps_negative, 1500u);
}

TEST(ShapedSteps, DeltaAgainstSampledShapedPosition) {
  const Machine m = delta();
  const auto s = shapers("mzv", 40.0, "ei", 45.0);
  const ShapedRun r = run_shaped(
      "SET_KINEMATIC_POSITION X=0 Y=0 Z=10\nG1 X60 Y0 F6000\nG1 X60 Y60 E1\nG1 X-50 Y-20 Z12 E2\n"
      "G2 X50 Y-20 I50 J0 E3\n",
      m, s);
  check_against_sampling(r, m, s, 1e-8);
}

TEST(ShapedSteps, RealRootsOfAPolynomial) {
  // (x - 0.1)(x - 0.3)(x - 0.7)(x + 2), expanded from its roots: (0, 1) holds three.
  const double r[] = {0.1, 0.3, 0.7, -2.0};
  double c[5] = {1.0, 0, 0, 0, 0};
  int deg = 0;
  for (double root : r) {  // multiply by (x - root)
    for (int k = deg + 1; k >= 0; --k) c[k] = (k > 0 ? c[k - 1] : 0.0) - root * c[k];
    ++deg;
  }
  std::vector<double> out;
  detail::real_roots(c, 4, 0.0, 1.0, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_NEAR(out[0], 0.1, 1e-14);
  EXPECT_NEAR(out[1], 0.3, 1e-14);
  EXPECT_NEAR(out[2], 0.7, 1e-14);
}

// The Taylor shift against direct evaluation.
TEST(ShapedSteps, TaylorShift) {
  const double c[4] = {1.0, -2.0, 0.5, 3.0};
  double out[4];
  shaping::taylor_shift(c, 3, 0.37, out);
  for (double x : {-1.0, 0.0, 0.2, 1.5}) {
    const double direct = 1.0 - 2.0 * (x + 0.37) + 0.5 * std::pow(x + 0.37, 2) + 3.0 * std::pow(x + 0.37, 3);
    EXPECT_NEAR(out[0] + x * (out[1] + x * (out[2] + x * out[3])), direct, 1e-13);
  }
}

}  // namespace
}  // namespace amctl::steppers
