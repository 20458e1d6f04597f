// The compensated command's check simulation (simulate_command, simulate_command_foh) on the
// plant engine, against closed-form responses of a second-order mode.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "amctl/compensation/compensate.hpp"

namespace amctl::compensation {
namespace {

constexpr double kPi = std::numbers::pi;

// Linear between samples: a ramp x = v t from rest is a velocity step v at t = 0:
// e(t) = -(v / wd) exp(-z w t) sin(wd t).
TEST(SimulateCommand, LinearRampIsTheVelocityStepResponse) {
  const double f = 30.0, z = 0.08, v = 40.0, rate = 1000.0;
  const double w = 2 * kPi * f, wd = w * std::sqrt(1 - z * z);
  const auto plant = dynamics::AxisModel::belt(f, z);
  std::vector<double> t, x, y;
  for (int k = 0; k <= 300; ++k) {
    t.push_back(0.5 + k / rate);
    x.push_back(2.0 + v * k / rate);
    y.push_back(-1.0);
  }
  std::vector<double> xs, ys;
  simulate_command(t, x, y, plant, plant, rate, xs, ys);
  ASSERT_EQ(xs.size(), t.size());
  double worst = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    const double tt = t[k] - t[0];
    const double e = -(v / wd) * std::exp(-z * w * tt) * std::sin(wd * tt);
    worst = std::max(worst, std::abs(xs[k] - x[k] - e));
    EXPECT_NEAR(ys[k], -1.0, 1e-15);
  }
  EXPECT_LT(worst, 1e-12);
}

// Acceleration linear between samples, here a constant a from rest (x = a t^2 / 2):
// e(t) = -(a / w^2) [1 - exp(-z w t) (cos wd t + (z w / wd) sin wd t)].
TEST(SimulateCommand, FirstOrderHoldConstantAccelerationIsTheStepResponse) {
  const double f = 25.0, z = 0.1, a = 2500.0, rate = 1000.0;
  const double w = 2 * kPi * f, wd = w * std::sqrt(1 - z * z);
  const auto plant = dynamics::AxisModel::belt(f, z);
  std::vector<double> x, y, ax, ay;
  for (int k = 0; k <= 250; ++k) {
    const double t = k / rate;
    x.push_back(a * t * t / 2);
    y.push_back(0.0);
    ax.push_back(a);
    ay.push_back(0.0);
  }
  std::vector<double> xs, ys;
  simulate_command_foh(x, y, ax, ay, plant, plant, rate, xs, ys);
  double worst = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double t = k / rate;
    const double e = -(a / (w * w)) * (1 - std::exp(-z * w * t) * (std::cos(wd * t) + z * w / wd * std::sin(wd * t)));
    worst = std::max(worst, std::abs(xs[k] - x[k] - e));
    EXPECT_EQ(ys[k], 0.0);
  }
  EXPECT_LT(worst, 1e-12);
}

}  // namespace
}  // namespace amctl::compensation
