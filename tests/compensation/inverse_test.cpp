// Model inversion (docs/compensation.md, section 1), checked against independent computations:
// the dynamics simulator on the sampled command, and a Dormand-Prince integration of the
// one-mode inverse x_b = x + f / (2 z w), f' = -(w / 2z) f + x'' with 3.11 in physical
// coordinates (tests/dynamics/rk45.hpp), independent of the matrix exponentials.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "../dynamics/rk45.hpp"
#include "amctl/compensation/compensate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::compensation {
namespace {

const std::string kGcode = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner.gcode";
const std::string kPrinter = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner_printer.cfg";
constexpr double kW = 100.0;  // rad/s (seed base case)
constexpr double kZ = 0.5;

std::vector<plan::PlannedMove> seed_plan(const std::vector<std::string>& overrides) {
  const machine::Machine m = machine::load_machine(kPrinter, overrides);
  plan::PlanSource source(kGcode, m);
  plan::CollectSink collect;
  std::vector<plan::Sink*> sinks{&collect};
  plan::run_pipeline(source, sinks);
  return collect.moves;
}

CompensationOptions seed_options(Method method, double rate_hz) {
  CompensationOptions o;
  o.method = method;
  o.model_x = o.model_y = o.plant_x = o.plant_y = dynamics::AxisModel::belt_rad_s(kW, kZ);
  o.sample_rate_hz = rate_hz;
  return o;
}

TEST(Invert, SeedBaseCaseJerkLimitedPlanIsTrackedBelowOneNanometre) {
  // scurve7: the inverse's command acceleration is bounded; the sampled command (linear
  // between samples) differs from the exact inverse by O(h^2 x_b''), so sample at 100 kHz.
  const auto moves = seed_plan({"printer.profile=scurve7"});
  const CompensationResult r = compensate(moves, seed_options(Method::invert, 100000.0));
  EXPECT_EQ(r.status, compensation::CompensationStatus::ok) << r.message;
  EXPECT_LT(r.max_tracking_error_mm, 1e-6);
  EXPECT_GT(r.uncompensated_max_tracking_error_mm, 0.1);
  EXPECT_TRUE(std::isfinite(r.peak_command_accel_mm_s2));
  // First row at rest at the start, last row at rest at the end.
  EXPECT_NEAR(r.x_cmd_mm.front(), 0.0, 1e-12);
  EXPECT_NEAR(r.y_cmd_mm.front(), 0.0, 1e-12);
  EXPECT_NEAR(r.x_cmd_mm.back(), 10.0, 1e-9);
  EXPECT_NEAR(r.y_cmd_mm.back(), 10.0, 1e-9);
}

TEST(Invert, CommandEqualsIndependentRk45OfTheOneModeInverse) {
  const auto moves = seed_plan({"printer.profile=scurve7"});
  const CompensationResult r = compensate(moves, seed_options(Method::invert, 1000.0));
  ASSERT_EQ(r.status, compensation::CompensationStatus::ok);
  // State [f, xp, xp', unused] for X: f' = -p f + x'', plant 3.11 driven by
  // x_b = x + f/(2zw), x_b' = x' + (x'' - p f)/(2zw).
  const double p = kW / (2.0 * kZ), c = 2.0 * kZ * kW;
  const trajectory::Trajectory traj(moves);
  auto rhs = [&](double t, const testing::State4& s) {
    const trajectory::AxisState a = traj.evaluate(t);
    const double x = a.pos_mm[0], v = a.vel_mm_s[0], acc = a.acc_mm_s2[0];
    const double xb = x + s[0] / c, vb = v + (acc - p * s[0]) / c;
    return testing::State4{-p * s[0] + acc, s[2],
                           -kW * kW * (s[1] - xb) - c * (s[2] - vb), 0.0};
  };
  // Piece boundaries (x''' steps) as integration breaks, plus every sample time.
  std::vector<double> breaks;
  for (const auto& m : moves) {
    std::array<plan::PathPiece, 7> pcs;
    const std::size_t n = trajectory::move_pieces(m, pcs);
    double t = m.start_time_s;
    for (std::size_t i = 0; i < n; ++i) {
      breaks.push_back(t);
      t += pcs[i].duration_s;
    }
    breaks.push_back(t);
  }
  testing::State4 s{0.0, 0.0, 0.0, 0.0};
  double t = r.t_s.front(), max_cmd_diff = 0.0, max_track = 0.0;
  std::size_t bi = 0;
  for (std::size_t k = 1; k < r.t_s.size(); ++k) {
    const double tk = r.t_s[k];
    while (bi < breaks.size() && breaks[bi] <= t) ++bi;
    while (bi < breaks.size() && breaks[bi] < tk) {
      s = testing::dopri5(rhs, t, breaks[bi], s);
      t = breaks[bi++];
    }
    s = testing::dopri5(rhs, t, tk, s);
    t = tk;
    const trajectory::AxisState a = traj.evaluate(tk);
    max_cmd_diff = std::max(max_cmd_diff, std::abs(r.x_cmd_mm[k] - (a.pos_mm[0] + s[0] / c)));
    max_track = std::max(max_track, std::abs(s[1] - a.pos_mm[0]));
  }
  EXPECT_LT(max_cmd_diff, 1e-9);  // the command at the samples is the exact inverse
  EXPECT_LT(max_track, 1e-8);     // and the exact (continuous) inverse is tracked exactly
}

TEST(Invert, StaticDeflectionUnderConstantAccelerationIsAOverWSquared) {
  // Deep inside the constant-acceleration phase of a long move the inverse leads the path by
  // a / w^2 (the belt's static stretch): 5000 / 100^2 = 0.5 mm.
  const std::vector<plan::PlannedMove> moves = [] {
    const machine::Machine m = machine::load_machine(kPrinter, {"printer.max_accel=500"});
    plan::PlanSource source(std::string_view("G1 X0 Y0 F60000\nG1 X200 F60000\n"), "long", m);
    plan::CollectSink collect;
    std::vector<plan::Sink*> sinks{&collect};
    plan::run_pipeline(source, sinks);
    return collect.moves;
  }();
  const CompensationResult r = compensate(moves, seed_options(Method::invert, 1000.0));
  const double t = moves.front().start_time_s + 0.4;  // accel phase lasts 0.6 s at 500 mm/s^2
  const std::size_t k = static_cast<std::size_t>(std::llround((t - r.t_s.front()) * 1000.0));
  EXPECT_NEAR(r.x_cmd_mm[k] - r.x_des_mm[k], 500.0 / (kW * kW), 1e-9);
}

TEST(Invert, TrapezoidPlanReportsUnboundedCommandAcceleration) {
  const auto moves = seed_plan({});
  const CompensationResult r = compensate(moves, seed_options(Method::invert, 1000.0));
  EXPECT_EQ(r.status, compensation::CompensationStatus::unbounded_command_acceleration);
  EXPECT_TRUE(std::isinf(r.peak_command_accel_mm_s2));
  EXPECT_NE(r.message.find("scurve7"), std::string::npos);
  EXPECT_TRUE(to_json(r)["peak_command_accel_mm_s2"].is_null());
  // Still a meaningful command: far below the uncompensated error.
  EXPECT_LT(r.max_tracking_error_mm, 0.1 * r.uncompensated_max_tracking_error_mm);
}

TEST(Invert, UndampedTwoModeModelHasNoStableInverse) {
  CompensationOptions o = seed_options(Method::invert, 1000.0);
  o.model_x = o.model_y = dynamics::AxisModel::from_modes({{20.0, 0.0, 0.5}, {50.0, 0.0, 0.5}});
  o.plant_x = o.plant_y = o.model_x;
  EXPECT_THROW(compensate(seed_plan({}), o), Error);
}

TEST(Methods, EveryMethodParsesAndAnUnknownOneIsNamed) {
  for (const char* m : {"invert", "fbf", "lpfbf", "rfbf", "collocation"})
    EXPECT_STREQ(method_name(parse_method(m)), m);
  try {
    parse_method("bogus");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'bogus' is not a method"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amctl::compensation

namespace amctl::compensation {
namespace {

TEST(Invert, TwoDampedModesAreInvertedExactly) {
  // N(s) = D - s^2 P of two damped modes (participations 0.6 and 0.4): relative degree 1.
  CompensationOptions o = seed_options(Method::invert, 100000.0);
  o.model_x = o.model_y = o.plant_x = o.plant_y =
      dynamics::AxisModel::from_modes({{15.9, 0.5, 0.6}, {40.0, 0.3, 0.4}});
  const CompensationResult r = compensate(seed_plan({"printer.profile=scurve7"}), o);
  EXPECT_EQ(r.status, compensation::CompensationStatus::ok) << r.message;
  EXPECT_LT(r.max_tracking_error_mm, 1e-6);
  EXPECT_GT(r.uncompensated_max_tracking_error_mm, 0.2);
}

TEST(Invert, UndampedModeNeedsContinuousJerk) {
  // zeta = 0: x_b = x + x''/w^2 (relative degree 0). scurve7's jerk steps become command
  // velocity steps (status says so and points to bezier5); bezier5 is bounded.
  CompensationOptions o = seed_options(Method::invert, 1000.0);
  o.model_x = o.model_y = o.plant_x = o.plant_y = dynamics::AxisModel::belt_rad_s(kW, 0.0);
  const CompensationResult s = compensate(seed_plan({"printer.profile=scurve7"}), o);
  EXPECT_EQ(s.status, compensation::CompensationStatus::unbounded_command_acceleration);
  EXPECT_NE(s.message.find("bezier5"), std::string::npos) << s.message;
  const CompensationResult b = compensate(seed_plan({"printer.profile=bezier5"}), o);
  EXPECT_EQ(b.status, compensation::CompensationStatus::ok) << b.message;
  // Undamped: x_b - x = x''/w^2 exactly at every sample.
  const trajectory::Trajectory traj(seed_plan({"printer.profile=bezier5"}));
  double worst = 0.0;
  for (std::size_t k = 0; k < b.t_s.size(); ++k) {
    const trajectory::AxisState a = traj.evaluate(b.t_s[k]);
    worst = std::max(worst, std::abs(b.x_cmd_mm[k] - (a.pos_mm[0] + a.acc_mm_s2[0] / (kW * kW))));
  }
  EXPECT_LT(worst, 1e-9);
}

}  // namespace
}  // namespace amctl::compensation

namespace amctl::compensation {
namespace {

TEST(Invert, CornerVelocityStepsAreNamed) {
  const CompensationResult r = compensate(
      seed_plan({"printer.profile=scurve7", "printer.square_corner_velocity=5"}),
      seed_options(Method::invert, 1000.0));
  EXPECT_EQ(r.status, compensation::CompensationStatus::unbounded_command_acceleration);
  EXPECT_NE(r.message.find("square_corner_velocity=0"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace amctl::compensation
