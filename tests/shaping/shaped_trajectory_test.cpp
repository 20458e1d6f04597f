// Shaped motion against hand-computed weighted sums of the planned polynomial.
#include "amctl/shaping/shaped_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/trajectory/build.hpp"

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

TEST(ShapedCursor, ManyMovesWithADwellEqualTheWeightedSumOfRandomAccessEvaluations) {
  // 60 moves of 2..15 mm turning at random, junction speeds 2..40 mm/s, S-curve ramps, and a
  // 0.25 s dwell after move 30. Reference: sum_i a_i Trajectory::evaluate(t - d_i), a second
  // evaluator (binary search and a fresh cursor per call), with Klipper's pulses.
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<trajectory::MoveSpec> specs;
  std::array<double, 4> at{50, 50, 0.3, 0};
  double heading = 0.0;
  for (std::uint64_t i = 0; i < 60; ++i) {
    const double len = 2.0 + 13.0 * u01(rng);
    heading += (u01(rng) - 0.5) * 3.0;
    at[0] += len * std::cos(heading);
    at[1] += len * std::sin(heading);
    at[3] += 0.04 * len;
    specs.push_back({at, 120.0, i == 59 ? 0.0 : 2.0 + 38.0 * u01(rng), i + 1, 0, 0});
  }
  specs[30].end_v_mm_s = 0.0;  // the dwell follows a stop
  std::vector<plan::PlannedMove> moves = trajectory::chain_moves(
      {50, 50, 0.3, 0}, specs, 3000.0, machine::VelocityProfile::scurve7, 100000.0);
  for (std::size_t i = 0; i < moves.size(); ++i) moves[i].start_time_s += 0.5 + (i > 30 ? 0.25 : 0.0);
  const trajectory::Trajectory reference(moves);
  const Shaper sx = make_shaper("ei", 33.0, 0.1);
  const Shaper sy = make_shaper("mzv(n=5, t=1.0)", 47.0, 0.05);
  AxisShapers shapers;
  shapers.xyz[0] = sx;
  shapers.xyz[1] = sy;
  ShapedCursor shaped(moves, shapers);
  const AppliedPulses px = applied_pulses(sx);
  const AppliedPulses py = applied_pulses(sy);
  const double t_end = moves.back().end_time_s() + 0.1;
  std::size_t n = 0;
  double max_dpos = 0.0, max_dacc = 0.0, max_shaping_mm = 0.0;
  for (double t = 0.3; t < t_end; t += 0.00037, ++n) {
    const auto s = shaped.evaluate(t);
    trajectory::AxisState e;
    for (std::size_t i = 0; i < px.weights.size(); ++i) {
      const auto r = reference.evaluate(t - px.delays_s[i]);
      e.pos_mm[0] += px.weights[i] * r.pos_mm[0];
      e.vel_mm_s[0] += px.weights[i] * r.vel_mm_s[0];
      e.acc_mm_s2[0] += px.weights[i] * r.acc_mm_s2[0];
    }
    for (std::size_t i = 0; i < py.weights.size(); ++i) {
      const auto r = reference.evaluate(t - py.delays_s[i]);
      e.pos_mm[1] += py.weights[i] * r.pos_mm[1];
      e.vel_mm_s[1] += py.weights[i] * r.vel_mm_s[1];
      e.acc_mm_s2[1] += py.weights[i] * r.acc_mm_s2[1];
    }
    const auto plain = reference.evaluate(t);
    for (std::size_t a = 0; a < 2; ++a) {
      max_dpos = std::max(max_dpos, std::abs(s.pos_mm[a] - e.pos_mm[a]));
      max_dacc = std::max(max_dacc, std::abs(s.acc_mm_s2[a] - e.acc_mm_s2[a]));
      max_shaping_mm = std::max(max_shaping_mm, std::abs(s.pos_mm[a] - plain.pos_mm[a]));
      EXPECT_NEAR(s.pos_mm[a], e.pos_mm[a], 1e-10) << t << " axis " << a;
      EXPECT_NEAR(s.vel_mm_s[a], e.vel_mm_s[a], 1e-8) << t << " axis " << a;
      EXPECT_NEAR(s.acc_mm_s2[a], e.acc_mm_s2[a], 1e-6) << t << " axis " << a;
    }
    EXPECT_EQ(s.pos_mm[2], plain.pos_mm[2]);
    EXPECT_EQ(s.pos_mm[3], plain.pos_mm[3]);
  }
  EXPECT_GT(n, 10000u);
  EXPECT_GT(max_shaping_mm, 0.01);  // the shapers do move the path
  std::cout << "shaped vs reference over " << n << " samples, " << moves.size()
            << " moves: position " << max_dpos << " mm, acceleration " << max_dacc
            << " mm/s^2 (shaping moved the path by up to " << max_shaping_mm << " mm)\n";
}

}  // namespace
}  // namespace amctl::shaping
