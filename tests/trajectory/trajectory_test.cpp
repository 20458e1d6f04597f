#include "amctl/trajectory/trajectory.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/trajectory/build.hpp"
#include "amctl/trajectory/sampling.hpp"

namespace amctl::trajectory {
namespace {

using VP = plan::VelocityProfile;

// Seed 000 base path: 10 mm along X then 10 mm along Y, full stop at the corner.
std::vector<plan::PlannedMove> seed_path(VP p = VP::trapezoid, double v = 100.0,
                                         double a = 5000.0, double j = 1.0e6) {
  const std::vector<MoveSpec> specs{{{10, 0, 0, 0}, v, 0.0, 1}, {{10, 10, 0, 0}, v, 0.0, 2}};
  return chain_moves({0, 0, 0, 0}, specs, a, p, j);
}

TEST(Trajectory, SeedPathPositionsFollowHandComputedTrapezoid) {
  const Trajectory tr(seed_path());
  EXPECT_NEAR(tr.end_time_s(), 0.24, 1e-14);
  const AxisState a = tr.evaluate(0.01);  // accelerating: s = a t^2/2
  EXPECT_NEAR(a.pos_mm[0], 0.25, 1e-14);
  EXPECT_NEAR(a.vel_mm_s[0], 50.0, 1e-12);
  EXPECT_NEAR(a.acc_mm_s2[0], 5000.0, 1e-9);
  EXPECT_NEAR(a.pos_mm[1], 0.0, 1e-15);
  const AxisState c = tr.evaluate(0.07);  // cruising: 1 mm + 100 * 0.05
  EXPECT_NEAR(c.pos_mm[0], 6.0, 1e-13);
  EXPECT_NEAR(c.acc_mm_s2[0], 0.0, 1e-12);
  const AxisState d = tr.evaluate(0.23);  // second move decelerating, 0.01 s before its end
  EXPECT_NEAR(d.pos_mm[0], 10.0, 1e-14);
  EXPECT_NEAR(d.pos_mm[1], 10.0 - 0.25, 1e-12);
  EXPECT_NEAR(d.acc_mm_s2[1], -5000.0, 1e-9);
  const AxisState after = tr.evaluate(1.0);  // holds at the end
  EXPECT_NEAR(after.pos_mm[1], 10.0, 1e-13);
  EXPECT_EQ(after.vel_mm_s[1], 0.0);
}

TEST(Trajectory, CursorAgreesWithRandomAccessAndFiniteDifferences) {
  for (VP p : {VP::trapezoid, VP::scurve7, VP::bezier5}) {
    const Trajectory tr(seed_path(p, 120.0, 3000.0, 2.0e5));
    Cursor c = tr.cursor();
    for (double t = 0.003; t < tr.end_time_s(); t += 0.00731) {
      const AxisState a = c.evaluate(t), b = tr.evaluate(t);
      for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_NEAR(a.pos_mm[i], b.pos_mm[i], 1e-12);
        const double eps = 1e-6;
        const double fd = (tr.evaluate(t + eps).pos_mm[i] - tr.evaluate(t - eps).pos_mm[i]) / (2 * eps);
        EXPECT_NEAR(b.vel_mm_s[i], fd, 1e-5 * (1 + std::abs(fd)));
        const double fa = (tr.evaluate(t + eps).vel_mm_s[i] - tr.evaluate(t - eps).vel_mm_s[i]) / (2 * eps);
        if (std::abs(fa - b.acc_mm_s2[i]) > 1e-2 * (1 + std::abs(fa))) {
          // only allowed right at a phase boundary (trapezoid accel steps)
          EXPECT_EQ(p, VP::trapezoid) << "t " << t;
        }
      }
    }
  }
}

TEST(Trajectory, PathDerivativesAreTheTaylorCoefficientsOfTheBezierPiece) {
  const Trajectory tr(seed_path(VP::bezier5));
  Cursor c = tr.cursor();
  std::array<double, plan::kMaxPieceDegree + 1> d{};
  c.path_derivatives(0.01, d);  // inside the first accel ramp (T = 0.02)
  // s = dv T (5/2 u^4 - 3 u^5 + u^6): at u = 1/2, v = dv/2, a = 15/8 dv/T, jerk 0 (u = 1/2)
  EXPECT_NEAR(d[1], 50.0, 1e-10);
  EXPECT_NEAR(d[2], 1.875 * 5000.0, 1e-7);
  EXPECT_NEAR(d[3], 0.0, 1e-4);
  // d6 s/dt6 = 720 dv / T^5
  EXPECT_NEAR(d[6], 720.0 * 100.0 / std::pow(0.02, 5), 1e-3 * 720.0 * 100.0 / std::pow(0.02, 5));
}

TEST(Trajectory, DwellBetweenMovesHoldsPosition) {
  auto moves = seed_path();
  moves[1].start_time_s += 0.5;  // G4 P500 at the corner
  const Trajectory tr(moves);
  const AxisState s = tr.evaluate(0.3);
  EXPECT_NEAR(s.pos_mm[0], 10.0, 1e-13);
  EXPECT_EQ(s.pos_mm[1], 0.0);
  EXPECT_EQ(s.vel_mm_s[0], 0.0);
  EXPECT_NEAR(tr.evaluate(0.12 + 0.5 + 0.01).pos_mm[1], 0.25, 1e-12);
}

TEST(Trajectory, RejectsMovesOutOfTimeOrder) {
  auto moves = seed_path();
  std::swap(moves[0], moves[1]);
  EXPECT_THROW(Trajectory{moves}, Error);
}

TEST(Sampling, SeedStepCountFollowsEquation37) {
  // N = ceil(dt/h - 1): 0.02/0.005 = 4 -> 3 full steps + a last one of h (3.8).
  EXPECT_EQ(seed000_full_steps(0.02, 0.005), 3);
  EXPECT_EQ(seed000_full_steps(0.02, 0.003), 6);  // 6.67 -> 6 steps + 0.002
  EXPECT_EQ(seed000_full_steps(0.002, 0.005), 0);
  // base case: per move 0.02 + 0.08 + 0.02 s at h = 0.005 -> 4 + 16 + 4 steps; 2 moves + t=0
  const auto moves = seed_path();
  EXPECT_EQ(sample_seed000(moves, 0.005).size(), 49u);
}

TEST(Sampling, SeedInterpolationAgreesWithExactEvaluationToRoundOff) {
  for (double h : {0.01, 0.005, 0.003, 0.001, 0.0002}) {
    const auto moves = seed_path();
    const Trajectory tr(moves);
    double worst = 0.0;
    const auto samples = sample_seed000(moves, h);
    ASSERT_GT(samples.size(), 20u) << "h " << h;  // the comparison below must not be vacuous
    for (const PathSample& s : samples) {
      const AxisState e = tr.evaluate(s.t_s);
      worst = std::max({worst, std::abs(e.pos_mm[0] - s.pos_mm[0]), std::abs(e.pos_mm[1] - s.pos_mm[1])});
    }
    EXPECT_LT(worst, 1e-11) << "h " << h;
  }
}

TEST(Sampling, UniformGridRejectsEmptyRange) {
  const Trajectory tr(seed_path());
  EXPECT_EQ(sample_uniform(tr, 0.01, 0.0, 0.24).size(), 25u);
  EXPECT_THROW((void)sample_uniform(tr, 0.01, 0.2, 0.1), Error);
  EXPECT_THROW((void)sample_uniform(tr, 0.0, 0.0, 0.1), Error);
}

}  // namespace
}  // namespace amctl::trajectory
