#include "amctl/dynamics/simulate.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/trajectory/build.hpp"
#include "rk45.hpp"

namespace amctl::dynamics {
namespace {

using VP = plan::VelocityProfile;
using trajectory::MoveSpec;

std::vector<plan::PlannedMove> seed_path(VP p = VP::trapezoid, double junction_v = 0.0) {
  const std::vector<MoveSpec> specs{{{10, 0, 0, 0}, 100.0, junction_v, 1},
                                    {{10, 10, 0, 0}, 100.0, 0.0, 2}};
  return trajectory::chain_moves({0, 0, 0, 0}, specs, 5000.0, p, 2.0e5);
}

std::vector<SimSample> run(const std::vector<plan::PlannedMove>& moves, const AxisModel& mx,
                           const AxisModel& my, double rate, SimulationOptions o = {}) {
  o.sample_rate_hz = rate;
  std::vector<SimSample> out;
  (void)simulate(moves, mx, my, o, [&](const SimSample& s) { out.push_back(s); });
  return out;
}

TEST(Simulate, ConstantAccelerationMatchesClosedFormStepResponse) {
  // Commanded acceleration a from rest: e(t) = -(a/w^2)[1 - e^{-z w t}(cos wd t + z/sqrt(1-z^2) sin wd t)]
  const double a = 1000.0, f = 20.0, z = 0.1, w = 2 * std::numbers::pi * f;
  const double wd = w * std::sqrt(1 - z * z);
  const std::vector<MoveSpec> specs{{{200, 0, 0, 0}, 500.0, 0.0, 1}};
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, a, VP::trapezoid);
  const double t_acc = moves[0].accel_t_s;  // sqrt(a D)/a = 0.447 s
  const auto samples = run(moves, AxisModel::belt(f, z), AxisModel::belt(f, z), 1000.0);
  int checked = 0;
  for (const SimSample& s : samples) {
    if (s.t_s > t_acc) break;
    const double t = s.t_s;
    const double e = -(a / (w * w)) *
                     (1 - std::exp(-z * w * t) * (std::cos(wd * t) + z / std::sqrt(1 - z * z) * std::sin(wd * t)));
    EXPECT_NEAR(s.sim_mm[0] - s.cmd_mm[0], e, 1e-12) << "t " << t;
    ++checked;
  }
  EXPECT_GT(checked, 400);
}

TEST(Simulate, LinearAccelerationMatchesClosedFormRampResponse) {
  // S-curve jerk phase: a = j t. e(t) = -(j/w^2)[t - 2z/w + e^{-z w t}((2z/w) cos wd t + ((2z^2-1)/wd) sin wd t)]
  const double j = 2.0e4, amax = 5000.0, f = 25.0, z = 0.2, w = 2 * std::numbers::pi * f;
  const double wd = w * std::sqrt(1 - z * z);
  const std::vector<MoveSpec> specs{{{2000, 0, 0, 0}, 2000.0, 0.0, 1}};
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, amax, VP::scurve7, j);
  const double tj = amax / j;  // 0.25 s
  const auto samples = run(moves, AxisModel::belt(f, z), AxisModel::belt(f, z), 700.0);
  int checked = 0;
  for (const SimSample& s : samples) {
    if (s.t_s > tj) break;
    const double t = s.t_s;
    const double e = -(j / (w * w)) * (t - 2 * z / w +
                                       std::exp(-z * w * t) * ((2 * z / w) * std::cos(wd * t) +
                                                               ((2 * z * z - 1) / wd) * std::sin(wd * t)));
    EXPECT_NEAR(s.sim_mm[0] - s.cmd_mm[0], e, 1e-11) << "t " << t;
    ++checked;
  }
  EXPECT_GT(checked, 150);
}

TEST(Simulate, SeedBaseCaseMatchesScipyDop853) {
  // tests/reference/dynamics_reference.py, w = 100 rad/s, z = 0.5, trapezoid, full stop.
  const auto moves = seed_path();
  const AxisModel m = AxisModel::belt_rad_s(100.0, 0.5);
  const auto samples = run(moves, m, m, 1000.0);
  const std::vector<std::array<double, 3>> ref{{0.010, 0.079850076696, 0.0},
                                               {0.050, 4.024882100407, 0.0},
                                               {0.120, 10.424505482664, 0.0},
                                               {0.125, 10.460752157938, 0.010297263272},
                                               {0.200, 10.011626615468, 7.011641433614},
                                               {0.240, 9.998399500060, 10.424505482664},
                                               {0.300, 9.999955218924, 9.988162024869}};
  for (const auto& r : ref) {
    const auto k = static_cast<std::size_t>(std::lround(r[0] * 1000.0));
    ASSERT_LT(k, samples.size());
    EXPECT_NEAR(samples[k].t_s, r[0], 1e-12);
    EXPECT_NEAR(samples[k].sim_mm[0], r[1], 1e-9) << "t " << r[0];
    EXPECT_NEAR(samples[k].sim_mm[1], r[2], 1e-9) << "t " << r[0];
  }
}

TEST(Simulate, AgreesWithAdaptiveRk45ForEveryProfileAndSplitSteps) {
  const double w = 2 * std::numbers::pi * 37.0, z = 0.07;
  const AxisModel m = AxisModel::belt(37.0, z);
  for (VP p : {VP::trapezoid, VP::scurve7, VP::bezier5}) {
    for (double jv : {0.0, 20.0}) {  // full stop, and a 90-degree corner taken at 20 mm/s
      const auto moves = seed_path(p, jv);
      const double rate = 1300.0;  // steps straddle piece boundaries
      const auto samples = run(moves, m, m, rate);
      std::vector<double> times;
      for (std::size_t k = 3; k < samples.size(); k += 37) times.push_back(samples[k].t_s);
      ASSERT_GT(times.size(), 10u) << "too few samples to compare";
      const auto ref = testing::reference_response(moves, w, z, times);
      std::size_t i = 0;
      for (std::size_t k = 3; k < samples.size(); k += 37, ++i) {
        EXPECT_NEAR(samples[k].sim_mm[0], ref[i][0], 2e-9)
            << "profile " << static_cast<int>(p) << " junction " << jv << " t " << times[i];
        EXPECT_NEAR(samples[k].sim_mm[1], ref[i][2], 2e-9);
      }
    }
  }
}

TEST(Simulate, CoreXYMotorSpaceWithEqualMotorsEqualsCartesian) {
  const auto moves = seed_path(VP::scurve7, 10.0);
  const AxisModel m = AxisModel::from_modes({Mode{30.0, 0.1, 0.8}, Mode{95.0, 0.03, 0.2}});
  SimulationOptions o;
  o.motor_rows = {{{1.0, 1.0, 0.0}, {1.0, -1.0, 0.0}}};  // CoreXY A = X + Y, B = X - Y
  o.motor_space = true;
  const auto a = run(moves, m, m, 2000.0, o);
  const auto b = run(moves, m, m, 2000.0);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 100u);
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_NEAR(a[k].sim_mm[0], b[k].sim_mm[0], 1e-11);
    EXPECT_NEAR(a[k].sim_mm[1], b[k].sim_mm[1], 1e-11);
  }
}

TEST(Simulate, RigidModelFollowsTheCommandExactly) {
  const auto moves = seed_path(VP::bezier5);
  const auto s = run(moves, AxisModel::rigid(), AxisModel::rigid(), 500.0);
  ASSERT_GT(s.size(), 10u);
  for (const auto& x : s) {
    EXPECT_EQ(x.sim_mm[0], x.cmd_mm[0]);
    EXPECT_EQ(x.sim_mm[1], x.cmd_mm[1]);
  }
}

TEST(Simulate, SampleRateBelowNyquistIsAnErrorNamingIt) {
  const auto moves = seed_path();
  const AxisModel m = AxisModel::belt(60.0, 0.1);
  try {
    (void)run(moves, m, m, 100.0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sample_rate_hz"), std::string::npos);
  }
}

TEST(Simulate, ResidualVibrationAmplitudeDecaysAtTheModalRate) {
  // After the last move the command is at rest, so the free amplitude decays as e^{-z w t}.
  const auto moves = seed_path();
  const double f = 20.0, z = 0.05, w = 2 * std::numbers::pi * f;
  SimulationOptions o;
  o.settle_s = 0.5;
  o.vibration_per_sample = true;
  const auto s = run(moves, AxisModel::belt(f, z), AxisModel::belt(f, z), 1000.0, o);
  const auto k0 = static_cast<std::size_t>(std::lround(0.3 * 1000)), k1 = k0 + 200;
  // amplitude sqrt(e^2 + (e'/w)^2) decays by e^{-zw dt} up to an O(z) ripple
  const double ratio = s[k1].vibration_mm[1] / s[k0].vibration_mm[1];
  EXPECT_NEAR(ratio, std::exp(-z * w * 0.2), 0.06 * std::exp(-z * w * 0.2));
}

}  // namespace
}  // namespace amctl::dynamics
