// Calibration on a synthetic trapezoid-time estimator; reference values from
// tests/reference/process_calibrate_reference.py (scipy.optimize.least_squares).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/process/calibrate.hpp"

namespace pr = amctl::process;

namespace {

const std::vector<std::vector<double>> kFiles = {
    {2, 5, 10, 40}, {1, 1, 1, 1, 1, 1, 80}, {3, 30, 120},
    {0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5,
     0.5, 0.5, 15},
    {200, 4, 4}};

// Rest-to-rest move: accelerate, cruise at v, decelerate; triangle when too short.
double move_time(double L, double a, double v) {
  return L >= v * v / a ? L / v + v / a : 2.0 * std::sqrt(L / a);
}

std::vector<double> durations(const std::vector<double>& p) {
  std::vector<double> out;
  for (const auto& f : kFiles) {
    double t = 0;
    for (double L : f) t += move_time(L, p[0], p[1]);
    out.push_back(t);
  }
  return out;
}

std::vector<pr::CalibrationParameter> params() {
  return {{"accel_mm_s2", 1000.0, 10.0, 1e6}, {"max_velocity_mm_s", 60.0, 1.0, 2000.0}};
}

}  // namespace

TEST(Calibrate, RecoversTrueLimitsFromNoiseFreeDurations) {
  const auto measured = durations({2500.0, 120.0});
  // Hand check of the first file: 2 and 5 mm are triangles (v^2/a = 5.76 mm), 10 and 40 cruise.
  EXPECT_NEAR(measured[0], 0.658677928261582, 1e-12);
  const auto r = pr::calibrate_durations(durations, measured, params());
  EXPECT_TRUE(r.converged);
  EXPECT_NEAR(r.values[0], 2500.0, 1e-3);
  EXPECT_NEAR(r.values[1], 120.0, 1e-5);
  EXPECT_LT(r.rms_s, 1e-9);
}

TEST(Calibrate, NoisyDurationsMatchScipyEstimateAndStandardErrors) {
  auto measured = durations({2500.0, 120.0});
  const double noise[5] = {0.01, -0.02, 0.015, -0.005, 0.0};
  for (int i = 0; i < 5; ++i) measured[i] *= 1 + noise[i];
  const auto r = pr::calibrate_durations(durations, measured, params());
  EXPECT_NEAR(r.values[0], 2529.11344378, 1e-3);
  EXPECT_NEAR(r.values[1], 119.568018974, 1e-5);
  // Finite-difference Jacobian: standard errors to 0.1 %.
  EXPECT_NEAR(r.std_errors[0], 83.2041295222, 0.1);
  EXPECT_NEAR(r.std_errors[1], 1.5068620619, 0.002);
  EXPECT_NEAR(r.correlation[0][1], -0.522790015074, 1e-3);
  EXPECT_EQ(r.dof, 3u);
  EXPECT_LT(r.ci_lo[0], r.values[0]);
  EXPECT_GT(r.ci_hi[0], r.values[0]);
  ASSERT_EQ(r.residual_s.size(), 5u);
}

TEST(Calibrate, ParameterWithoutEffectIsReportedNotFitted) {
  const auto measured = durations({2500.0, 120.0});
  auto est = [](const std::vector<double>& p) { return durations({p[0], p[1]}); };
  auto ps = params();
  ps.push_back({"square_corner_velocity_mm_s", 5.0, 0.1, 100.0});
  const auto r = pr::calibrate_durations(est, measured, ps);
  EXPECT_FALSE(r.identifiable[2]);
  EXPECT_DOUBLE_EQ(r.values[2], 5.0);
  EXPECT_NEAR(r.values[0], 2500.0, 1e-2);
}

TEST(Calibrate, TooFewPrintsOrBadMeasurementsAreRejected) {
  const auto measured = durations({2500.0, 120.0});
  EXPECT_THROW((void)pr::calibrate_durations(durations, {measured[0]}, params()), amctl::Error);
  auto bad = measured;
  bad[2] = -1.0;
  EXPECT_THROW((void)pr::calibrate_durations(durations, bad, params()), amctl::Error);
  auto ps = params();
  ps[0].initial = 1e7;  // outside its bounds
  EXPECT_THROW((void)pr::calibrate_durations(durations, measured, ps), amctl::Error);
}
