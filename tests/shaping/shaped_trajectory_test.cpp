// Shaped motion against hand-computed weighted sums of the planned polynomial.
#include "amctl/shaping/shaped_trajectory.hpp"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

namespace amctl::shaping {
namespace {

/// One trapezoid move from rest to rest: 2000 mm/s^2 up to 100 mm/s, 1 s of cruise.
/// Starts at t0 = 0.1 s at (10, 20, 0.2, 5) along (0.6, 0.8) in XY, extruding 0.03 mm/mm.
plan::PlannedMove trapezoid() {
  plan::PlannedMove m;
  m.start_time_s = 0.1;
  m.start_mm = {10.0, 20.0, 0.2, 5.0};
  m.axes_r = {0.6, 0.8, 0.0, 0.03};
  m.start_v_mm_s = 0.0;
  m.cruise_v_mm_s = 100.0;
  m.end_v_mm_s = 0.0;
  m.accel_mm_s2 = 2000.0;
  m.accel_t_s = 0.05;
  m.cruise_t_s = 1.0;
  m.decel_t_s = 0.05;
  m.distance_mm = 2.5 + 100.0 + 2.5;
  return m;
}

AxisShapers xy(const Shaper& s) {
  AxisShapers a;
  a.xyz[0] = s;
  a.xyz[1] = s;
  return a;
}

TEST(AppliedPulses, WeightsSumToOneAndAreCentred) {
  for (std::string_view name : shaper_type_names()) {
    const AppliedPulses p = applied_pulses(make_shaper(name, 37.0, 0.1));
    double sum = 0.0, moment = 0.0;
    for (std::size_t i = 0; i < p.weights.size(); ++i) {
      sum += p.weights[i];
      moment += p.weights[i] * p.delays_s[i];
    }
    EXPECT_NEAR(sum, 1.0, 1e-15) << name;
    EXPECT_NEAR(moment, 0.0, 1e-17) << name;
    EXPECT_LT(p.delays_s.front(), 0.0) << name;
    EXPECT_GT(p.delays_s.back(), 0.0) << name;
  }
}

TEST(ShapedCursor, ConstantVelocityIsTheSameLineNotDelayed) {
  const std::vector<plan::PlannedMove> moves = {trapezoid()};
  for (std::string_view name : shaper_type_names()) {
    const Shaper s = make_shaper(name, 25.0, 0.1);
    ShapedCursor shaped(moves, xy(s));
    trajectory::Cursor plain(moves);
    // The cruise runs over [0.15, 1.15] s; keep every tap inside it.
    const double t_begin = 0.15 + shaped.max_delay_s() + 1e-9;
    const double t_end = 1.15 + shaped.min_delay_s() - 1e-9;
    ASSERT_LT(t_begin, t_end);
    for (double t = t_begin; t <= t_end; t += 0.0137) {
      const auto a = shaped.evaluate(t);
      const auto b = plain.evaluate(t);
      for (std::size_t i = 0; i < trajectory::kAxes; ++i) {
        EXPECT_NEAR(a.pos_mm[i], b.pos_mm[i], 1e-11) << name << " t " << t << " axis " << i;
        EXPECT_NEAR(a.vel_mm_s[i], b.vel_mm_s[i], 1e-11) << name;
        EXPECT_NEAR(a.acc_mm_s2[i], 0.0, 1e-11) << name;
      }
    }
  }
}

TEST(ShapedCursor, StepInAccelerationIsTheHandWeightedSum) {
  // ZV at 40 Hz, zeta 0.1: weights 1/(1+K), K/(1+K) at delays -t_s and T1 - t_s,
  // T1 = 1 / (2 f sqrt(1 - zeta^2)), t_s = K T1 / (1 + K). At the start of the move the planned
  // X is 10 + 0.6 * 1000 (t - 0.1)^2 for t >= 0.1 and 10 before: a step of 1200 mm/s^2 in X.
  const double zeta = 0.1;
  const double K = std::exp(-zeta * M_PI / std::sqrt(1.0 - zeta * zeta));
  const double T1 = 1.0 / (2.0 * 40.0 * std::sqrt(1.0 - zeta * zeta));
  const double ts = K * T1 / (1.0 + K);
  const double w[2] = {1.0 / (1.0 + K), K / (1.0 + K)};
  const double d[2] = {-ts, T1 - ts};
  const std::vector<plan::PlannedMove> moves = {trapezoid()};
  ShapedCursor shaped(moves, xy(make_shaper("zv", 40.0, zeta)));
  for (double t = 0.05; t < 0.12; t += 0.0011) {
    double x = 0.0, v = 0.0, a = 0.0, y = 0.0;
    for (int i = 0; i < 2; ++i) {
      const double tau = std::max(0.0, t - d[i] - 0.1);  // time into the accel phase
      x += w[i] * (10.0 + 0.6 * 1000.0 * tau * tau);
      y += w[i] * (20.0 + 0.8 * 1000.0 * tau * tau);
      v += w[i] * 0.6 * 2000.0 * tau;
      a += w[i] * (t - d[i] >= 0.1 ? 0.6 * 2000.0 : 0.0);
    }
    const auto s = shaped.evaluate(t);
    EXPECT_NEAR(s.pos_mm[0], x, 1e-12) << t;
    EXPECT_NEAR(s.pos_mm[1], y, 1e-12) << t;
    EXPECT_NEAR(s.vel_mm_s[0], v, 1e-10) << t;
    EXPECT_NEAR(s.acc_mm_s2[0], a, 1e-9) << t;
    // Z and E are not shaped: Z holds, E follows the plan.
    const double tau = std::max(0.0, t - 0.1);
    EXPECT_EQ(s.pos_mm[2], 0.2);
    EXPECT_NEAR(s.pos_mm[3], 5.0 + 0.03 * 1000.0 * tau * tau, 1e-12) << t;
  }
}

TEST(ShapedCursor, StartsAndEndsWhereThePlanDoes) {
  const std::vector<plan::PlannedMove> moves = {trapezoid()};
  ShapedCursor shaped(moves, xy(make_shaper("3hump_ei", 30.0, 0.1)));
  const auto before = shaped.evaluate(0.1 + shaped.min_delay_s() - 1e-6);
  const auto after = shaped.evaluate(1.2 + shaped.max_delay_s() + 1e-6);
  EXPECT_EQ(before.pos_mm[0], 10.0);
  EXPECT_EQ(before.pos_mm[1], 20.0);
  EXPECT_NEAR(after.pos_mm[0], 10.0 + 0.6 * 105.0, 1e-12);
  EXPECT_NEAR(after.pos_mm[1], 20.0 + 0.8 * 105.0, 1e-12);
  EXPECT_EQ(after.vel_mm_s[0], 0.0);
}

TEST(ShapedCursor, PerAxisShapersAndNoShaperLeaveThePlan) {
  const std::vector<plan::PlannedMove> moves = {trapezoid()};
  ShapedCursor none(moves, AxisShapers{});
  EXPECT_EQ(none.max_delay_s(), 0.0);
  AxisShapers only_y;
  only_y.xyz[1] = make_shaper("mzv", 45.0, 0.1);
  ShapedCursor y(moves, only_y);
  trajectory::Cursor plain(moves);
  trajectory::Cursor plain2(moves);
  for (double t = 0.0; t < 1.4; t += 0.0093) {
    const auto a = none.evaluate(t);
    const auto b = plain.evaluate(t);
    const auto c = y.evaluate(t);
    const auto p = plain2.evaluate(t);
    for (std::size_t i = 0; i < trajectory::kAxes; ++i) EXPECT_EQ(a.pos_mm[i], b.pos_mm[i]);
    EXPECT_EQ(c.pos_mm[0], p.pos_mm[0]);
    EXPECT_EQ(c.pos_mm[3], p.pos_mm[3]);
  }
}

}  // namespace
}  // namespace amctl::shaping
