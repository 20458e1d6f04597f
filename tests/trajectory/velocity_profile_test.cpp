#include "amctl/plan/velocity_profile.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl::plan {
namespace {

using VP = VelocityProfile;

TEST(VelocityProfile, TrapezoidRampFollowsSeedEquations) {
  // (3.2) d = (v1^2 - v0^2)/(2a), (3.4) dt = (v1 - v0)/a: 0 -> 100 mm/s at 5000 mm/s^2.
  const Ramp r = make_ramp(VP::trapezoid, 0.0, 100.0, 5000.0);
  EXPECT_NEAR(r.duration_s, 0.02, 1e-15);
  EXPECT_NEAR(r.distance_mm, 1.0, 1e-13);
  const PathState s = evaluate_ramp(r, 0.01);
  EXPECT_NEAR(s.s_mm, 0.25, 1e-14);  // a t^2 / 2
  EXPECT_NEAR(s.v_mm_s, 50.0, 1e-12);
  EXPECT_NEAR(s.a_mm_s2, 5000.0, 1e-9);
}

TEST(VelocityProfile, ScurveFullRampMatchesQuadrature) {
  // tests/reference/dynamics_reference.py: T = 0.025, d = 1.5 for 10 -> 110, a 5000, j 1e6.
  const Ramp r = make_ramp(VP::scurve7, 10.0, 110.0, 5000.0, 1.0e6);
  EXPECT_NEAR(r.duration_s, 0.025, 1e-15);
  EXPECT_NEAR(r.distance_mm, 1.5, 1e-13);
  EXPECT_NEAR(r.jerk_phase_t_s, 0.005, 1e-15);
  EXPECT_NEAR(r.const_accel_t_s, 0.015, 1e-15);
  EXPECT_NEAR(r.peak_accel_mm_s2, 5000.0, 1e-9);
  const PathState end = evaluate_ramp(r, r.duration_s);
  EXPECT_NEAR(end.s_mm, 1.5, 1e-13);
  EXPECT_NEAR(end.v_mm_s, 110.0, 1e-11);
  EXPECT_NEAR(end.a_mm_s2, 0.0, 1e-9);
}

TEST(VelocityProfile, ScurveReducesToTwoPhasesWhenAccelLimitIsNotReached) {
  // dv = 16 < a^2/j = 25: T = 2 sqrt(dv/j) = 0.008, d = 0.144, peak accel sqrt(dv j) = 4000.
  const Ramp r = make_ramp(VP::scurve7, 10.0, 26.0, 5000.0, 1.0e6);
  EXPECT_DOUBLE_EQ(r.const_accel_t_s, 0.0);
  EXPECT_NEAR(r.duration_s, 0.008, 1e-15);
  EXPECT_NEAR(r.distance_mm, 0.144, 1e-14);
  EXPECT_NEAR(r.peak_accel_mm_s2, 4000.0, 1e-9);
  std::array<PathPiece, 3> pieces;
  EXPECT_EQ(ramp_pieces(r, 0.0, pieces), 2u);
}

TEST(VelocityProfile, ScurveIsContinuousInPositionSpeedAndAcceleration) {
  const Ramp r = make_ramp(VP::scurve7, 80.0, 5.0, 3000.0, 2.0e5);
  for (double tb : {r.jerk_phase_t_s, r.jerk_phase_t_s + r.const_accel_t_s}) {
    const PathState a = evaluate_ramp(r, tb - 1e-9), b = evaluate_ramp(r, tb + 1e-9);
    EXPECT_NEAR(a.s_mm, b.s_mm, 1e-6);
    EXPECT_NEAR(a.v_mm_s, b.v_mm_s, 1e-4);
    EXPECT_NEAR(a.a_mm_s2, b.a_mm_s2, 1e-3);
  }
  EXPECT_NEAR(evaluate_ramp(r, r.duration_s).v_mm_s, 5.0, 1e-10);
  EXPECT_NEAR(evaluate_ramp(r, 0.5 * r.duration_s).a_mm_s2, -3000.0, 1e-6);
}

TEST(VelocityProfile, BezierKeepsTrapezoidTimingWithPeakAccelFifteenEighths) {
  const Ramp t = make_ramp(VP::trapezoid, 20.0, 120.0, 4000.0);
  const Ramp b = make_ramp(VP::bezier5, 20.0, 120.0, 4000.0);
  EXPECT_DOUBLE_EQ(b.duration_s, t.duration_s);
  EXPECT_NEAR(b.distance_mm, t.distance_mm, 1e-13);
  // v(u) = v0 + dv (10u^3 - 15u^4 + 6u^5): a(u) = dv/T 30 u^2 (1-u)^2, max 15/8 dv/T at u=1/2.
  const PathState mid = evaluate_ramp(b, 0.5 * b.duration_s);
  EXPECT_NEAR(mid.v_mm_s, 70.0, 1e-10);
  EXPECT_NEAR(mid.a_mm_s2, 1.875 * 4000.0, 1e-7);
  EXPECT_NEAR(b.peak_accel_mm_s2, 7500.0, 1e-9);
  // jerk(u) = dv/T^2 60 u (1-u)(1-2u), max at u = (3 - sqrt 3)/6 of 10/sqrt(3) dv/T^2.
  const double u = (3.0 - std::sqrt(3.0)) / 6.0;
  const PathState pj = evaluate_ramp(b, u * b.duration_s);
  const double T = b.duration_s;
  EXPECT_NEAR(pj.j_mm_s3, 10.0 / std::sqrt(3.0) * 100.0 / (T * T), 1e-3);
  EXPECT_NEAR(b.peak_jerk_mm_s3, pj.j_mm_s3, 1e-3);
  // zero acceleration and jerk at both ends
  EXPECT_NEAR(evaluate_ramp(b, 0.0).a_mm_s2, 0.0, 1e-12);
  EXPECT_NEAR(evaluate_ramp(b, T).a_mm_s2, 0.0, 1e-6);
}

TEST(VelocityProfile, MaxReachableSpeedInvertsRampDistance) {
  for (VP p : {VP::trapezoid, VP::scurve7, VP::bezier5}) {
    for (double v0 : {0.0, 5.0, 60.0}) {
      for (double d : {0.01, 0.1, 0.9, 5.0, 50.0}) {
        const double v1 = max_reachable_speed_mm_s(p, v0, d, 5000.0, 1.0e6);
        EXPECT_GT(v1, v0);
        EXPECT_NEAR(ramp_distance_mm(p, v0, v1, 5000.0, 1.0e6), d, 1e-9 * (1 + d))
            << "profile " << static_cast<int>(p) << " v0 " << v0 << " d " << d;
        // and symmetric: braking from v1 reaches v0 in the same distance
        EXPECT_NEAR(ramp_distance_mm(p, v1, v0, 5000.0, 1.0e6), d, 1e-9 * (1 + d));
      }
    }
  }
}

TEST(VelocityProfile, SeedBaseMoveHasThreePhasesByPeakSpeed) {
  // (3.1): v_p = sqrt((0 + 0)/2 + 5000 * 10) = 223.6 > 100 -> accelerate, cruise, decelerate.
  const MoveTiming m = time_move(VP::trapezoid, 10.0, 0.0, 100.0, 0.0, 5000.0);
  EXPECT_DOUBLE_EQ(m.cruise_v_mm_s, 100.0);
  EXPECT_NEAR(m.accel_t_s, 0.02, 1e-15);
  EXPECT_NEAR(m.cruise_t_s, 0.08, 1e-14);  // (3.3) 10 - 2 * 1 mm at 100 mm/s (3.5)
  EXPECT_NEAR(m.decel_t_s, 0.02, 1e-15);
  // Short move: two phases, peak sqrt(a D) (3.1)
  const MoveTiming s = time_move(VP::trapezoid, 1.0, 0.0, 100.0, 0.0, 5000.0);
  EXPECT_NEAR(s.cruise_v_mm_s, std::sqrt(5000.0), 1e-12);
  EXPECT_NEAR(s.cruise_t_s, 0.0, 1e-15);
}

TEST(VelocityProfile, ScurveMoveThatCannotCruiseFillsItsDistanceExactly) {
  const MoveTiming m = time_move(VP::scurve7, 2.0, 0.0, 300.0, 10.0, 5000.0, 1.0e6);
  EXPECT_LT(m.cruise_v_mm_s, 300.0);
  EXPECT_NEAR(m.accel.distance_mm + m.decel.distance_mm + m.cruise_v_mm_s * m.cruise_t_s, 2.0,
              1e-9);
  std::array<PathPiece, 7> pieces;
  const std::size_t n = move_pieces(m, pieces);
  double t = 0.0;
  for (std::size_t i = 0; i < n; ++i) t += pieces[i].duration_s;
  EXPECT_NEAR(t, m.duration_s(), 1e-15);
}

TEST(VelocityProfile, RejectsScurveWithoutJerkNamingIt) {
  try {
    (void)make_ramp(VP::scurve7, 0.0, 10.0, 1000.0, 0.0);
    FAIL() << "expected amctl::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("jerk_mm_s3"), std::string::npos);
  }
  EXPECT_THROW((void)make_ramp(VP::trapezoid, -1.0, 10.0, 1000.0), Error);
  EXPECT_THROW((void)time_move(VP::trapezoid, 1.0, 0.0, 100.0, 100.0, 1000.0), Error);
}

}  // namespace
}  // namespace amctl::plan
