#include "amctl/dynamics/metrics.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/trajectory/build.hpp"

namespace amctl::dynamics {
namespace {

using VP = plan::VelocityProfile;
using trajectory::MoveSpec;

QualityReport measure(const std::vector<plan::PlannedMove>& moves, const AxisModel& m,
                      double rate, MetricsOptions mo = {}) {
  QualityMeter meter(moves, mo);
  SimulationOptions o;
  o.sample_rate_hz = rate;
  (void)simulate(moves, m, m, o, [&](const SimSample& s) { meter.add(s); });
  return meter.finish();
}

TEST(Metrics, LagAlongAStraightLineIsNotContourError) {
  const std::vector<MoveSpec> specs{{{100, 0, 0, 0}, 150.0, 0.0, 7}};
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, 3000.0, VP::trapezoid);
  const AxisModel m = AxisModel::belt(25.0, 0.1);
  // Until 10 ms before the stop: after that the nozzle runs past the line's end, which is a
  // real contour error (distance beyond the end point), not a lag.
  MetricsOptions mo;
  mo.t_end_s = moves[0].end_time_s() - 0.01;
  QualityMeter meter(moves, mo);
  double max_lag = 0.0;
  SimulationOptions o;
  (void)simulate(moves, m, m, o, [&](const SimSample& s) {
    max_lag = std::max(max_lag, std::abs(s.sim_mm[0] - s.cmd_mm[0]));
    meter.add(s);
  });
  const QualityReport r = meter.finish();
  EXPECT_GT(max_lag, 0.05);
  EXPECT_LT(r.max_contour_error_mm, 1e-12);
}

// The contour error is the distance to the nozzle's own wall, not to the next perimeter: a
// square loop, then a second loop 0.45 mm inside it (as a slicer's perimeters). A nozzle
// 0.35 mm inside the first wall, mid-way along its first side (commanded point (5, 0)), is
// 0.35 mm off its contour by hand, although the inner wall at y = 0.45 is only 0.10 mm away.
// (The definition compensation used before searched 64 moves either side without the
// along-path radius and gave 0.10.)
TEST(Metrics, ContourErrorIsToTheOwnWallNotTheNextPerimeter) {
  const std::vector<MoveSpec> specs{{{10, 0, 0, 0}, 100.0, 0.0, 1},     {{10, 10, 0, 0}, 100.0, 0.0, 2},
                                    {{0, 10, 0, 0}, 100.0, 0.0, 3},     {{0, 0.45, 0, 0}, 100.0, 0.0, 4},
                                    {{9.55, 0.45, 0, 0}, 100.0, 0.0, 5}, {{9.55, 9.55, 0, 0}, 100.0, 0.0, 6}};
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, 3000.0, VP::trapezoid);
  const double lag = 0.35;  // |nozzle - command|
  EXPECT_NEAR(distance_to_path(moves, 0, 5.0, 0.35, 2.0 * lag + 0.05), 0.35, 1e-12);
  // Searched without the radius (all 64 neighbours), the inner wall would be found.
  EXPECT_NEAR(distance_to_path(moves, 0, 5.0, 0.35, 1e9), 0.10, 1e-12);
  // The same through the segment form (a caller's own window of the path).
  const auto seg = [&](std::size_t i) {
    const auto& m = moves[i];
    return PathSegment{m.start_mm[0], m.start_mm[1], m.start_mm[0] + m.axes_r[0] * m.distance_mm,
                       m.start_mm[1] + m.axes_r[1] * m.distance_mm};
  };
  EXPECT_EQ(distance_to_segments(seg, moves.size(), 0, 5.0, 0.35, 2.0 * lag + 0.05),
            distance_to_path(moves, 0, 5.0, 0.35, 2.0 * lag + 0.05));
}

TEST(Metrics, SeedCornerOvershootMatchesScipyAndBoundsContourError) {
  // tests/reference/dynamics_reference.py: max x past the corner = 0.463612915 mm.
  const std::vector<MoveSpec> specs{{{10, 0, 0, 0}, 100.0, 0.0, 1}, {{10, 10, 0, 0}, 100.0, 0.0, 2}};
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, 5000.0, VP::trapezoid);
  const QualityReport r = measure(moves, AxisModel::belt_rad_s(100.0, 0.5), 20000.0);
  ASSERT_EQ(r.corners.size(), 1u);
  EXPECT_NEAR(r.corners[0].overshoot_mm, 0.463612915, 2e-6);  // sampled max at 20 kHz
  EXPECT_NEAR(r.corners[0].angle_deg, 90.0, 1e-9);
  EXPECT_EQ(r.corners[0].line, 1u);
  // the worst contour error is the overshoot past the corner (distance to the Y segment)
  EXPECT_NEAR(r.max_contour_error_mm, 0.463612915, 1e-4);
  ASSERT_FALSE(r.worst.empty());
  EXPECT_GT(r.rms_contour_error_mm, 0.0);
  EXPECT_LT(r.rms_contour_error_mm, r.max_contour_error_mm);
  EXPECT_NEAR(r.motion_time_s, 0.24, 1e-12);
}

TEST(Metrics, RingingWavelengthIsSpeedTimesDampedPeriod) {
  // 90-degree corner at 50 mm/s constant speed: the velocity jump rings at wd; the outgoing
  // wall shows a wavelength of v * 2 pi / wd.
  const double f = 40.0, z = 0.05, v = 50.0;
  std::vector<plan::PlannedMove> moves;
  moves.push_back(trajectory::timed_move({0, 0, 0, 0}, MoveSpec{{20, 0, 0, 0}, v, v, 3}, v, 0.0,
                                         5000.0, VP::trapezoid, 0.0));
  moves.push_back(trajectory::timed_move({20, 0, 0, 0}, MoveSpec{{20, 30, 0, 0}, v, v, 4}, v,
                                         moves[0].end_time_s(), 5000.0, VP::trapezoid, 0.0));
  const QualityReport r = measure(moves, AxisModel::belt(f, z), 20000.0);
  ASSERT_EQ(r.corners.size(), 1u);
  const double w = 2 * std::numbers::pi * f, wd = w * std::sqrt(1 - z * z);
  EXPECT_NEAR(r.corners[0].ringing_wavelength_mm, v * 2 * std::numbers::pi / wd, 0.005);
  EXPECT_NEAR(r.corners[0].ringing_period_s, 2 * std::numbers::pi / wd, 1e-4);
  // x error after the jump: e_x = (v/wd) e^{-s t} sin(wd t), s = z w; across the outgoing wall
  // the deviation is -e_x: first maximum where tan(wd t) = wd/s on the negative lobe, the
  // next minimum half a period later; amplitude = half that swing.
  const double sg = z * w, t1 = (std::atan(wd / sg) + std::numbers::pi) / wd;
  const double t2 = t1 + std::numbers::pi / wd;
  const double amp = 0.5 * v / wd *
                     (std::exp(-sg * t1) * std::abs(std::sin(wd * t1)) +
                      std::exp(-sg * t2) * std::abs(std::sin(wd * t2)));
  EXPECT_NEAR(r.corners[0].ringing_amplitude_mm, amp, 0.01 * amp);
  EXPECT_NEAR(r.ringing_wavelength_mm, r.corners[0].ringing_wavelength_mm, 1e-12);
}

TEST(Metrics, GroupsPerLayerAndFeatureAndListsWorstLines) {
  std::vector<MoveSpec> specs;
  for (int i = 0; i < 8; ++i) {
    const double x = (i % 2 == 0) ? 20.0 : 0.0;
    specs.push_back(MoveSpec{{x, 0.5 * (i + 1), 0, static_cast<double>(i + 1)}, 120.0, 0.0,
                             static_cast<std::uint64_t>(10 + i), i / 4,
                             static_cast<std::uint16_t>(i % 2)});
  }
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, 4000.0, VP::trapezoid);
  MetricsOptions mo;
  mo.worst_count = 3;
  const QualityReport r = measure(moves, AxisModel::belt(30.0, 0.1), 2000.0, mo);
  EXPECT_EQ(r.per_layer.size(), 2u);
  EXPECT_EQ(r.per_feature.size(), 2u);
  ASSERT_EQ(r.worst.size(), 3u);
  EXPECT_GE(r.worst[0].contour_error_mm, r.worst[1].contour_error_mm);
  EXPECT_GE(r.worst[0].line, 10u);
  double mx = 0.0;
  for (const auto& [layer, g] : r.per_layer) mx = std::max(mx, g.max_contour_error_mm);
  EXPECT_DOUBLE_EQ(mx, r.max_contour_error_mm);
  EXPECT_GT(r.max_contour_error_printing_mm, 0.0);
}

}  // namespace
}  // namespace amctl::dynamics

namespace amctl::dynamics {
namespace {

std::vector<plan::PlannedMove> zigzag(int n) {
  std::vector<MoveSpec> specs;
  for (int i = 0; i < n; ++i) {
    const double x = (i % 2 == 0) ? 12.0 + (i % 7) : 1.0 + (i % 3);
    specs.push_back(MoveSpec{{x, 0.3 * (i + 1), 0.2 * (i / 50), 0.05 * (i + 1)}, 150.0,
                             (i % 5 == 0) ? 0.0 : 4.0, static_cast<std::uint64_t>(100 + i), i / 50,
                             static_cast<std::uint16_t>(i % 3)});
  }
  return trajectory::chain_moves({0, 0, 0, 0}, specs, 6000.0, VP::trapezoid);
}

TEST(StreamingSimulation, SmallWindowsGiveTheSameReportAsTheWholePlan) {
  const auto moves = zigzag(600);
  const AxisModel m = AxisModel::belt(35.0, 0.08);
  SimulationOptions so;
  so.sample_rate_hz = 2000.0;
  MetricsOptions mo;
  mo.worst_count = 5;
  QualityMeter whole(moves, mo);
  (void)simulate(moves, m, m, so, [&](const SimSample& s) { whole.add(s); },
                 [&](std::size_t i, double t, const std::array<double, 2>& v) { whole.on_move_end(i, t, v); });
  const QualityReport a = whole.finish();

  mo.keep_per_move = false;
  StreamingSimulation stream(m, m, so, mo, nullptr, 80);
  for (const auto& mv : moves) stream.push(mv);
  const QualityReport b = stream.finish();
  EXPECT_LE(stream.max_window_moves(), 240u);

  EXPECT_EQ(a.samples, b.samples);
  EXPECT_DOUBLE_EQ(a.max_contour_error_mm, b.max_contour_error_mm);
  EXPECT_NEAR(a.rms_contour_error_mm, b.rms_contour_error_mm, 1e-15);
  EXPECT_DOUBLE_EQ(a.max_residual_vibration_mm, b.max_residual_vibration_mm);
  EXPECT_DOUBLE_EQ(a.final_residual_vibration_mm, b.final_residual_vibration_mm);
  EXPECT_DOUBLE_EQ(a.max_corner_overshoot_mm, b.max_corner_overshoot_mm);
  EXPECT_EQ(a.corners.size(), b.corner_count);
  EXPECT_EQ(b.corners.size(), 5u);
  ASSERT_EQ(a.worst.size(), b.worst.size());
  ASSERT_FALSE(a.worst.empty());
  for (std::size_t i = 0; i < a.worst.size(); ++i) EXPECT_EQ(a.worst[i].line, b.worst[i].line);
  ASSERT_EQ(a.per_layer.size(), b.per_layer.size());
  ASSERT_FALSE(a.per_layer.empty());
  for (const auto& [layer, g] : a.per_layer) {
    EXPECT_DOUBLE_EQ(g.max_contour_error_mm, b.per_layer.at(layer).max_contour_error_mm);
    EXPECT_EQ(g.samples, b.per_layer.at(layer).samples);
  }
  EXPECT_NEAR(a.ringing_wavelength_mm, b.ringing_wavelength_mm, 0.001);
  EXPECT_EQ(a.per_move.size(), moves.size());
  EXPECT_TRUE(b.per_move.empty());
}

TEST(Metrics, LayerRangeCountsOnlyItsMoves) {
  const auto moves = zigzag(200);
  MetricsOptions mo;
  mo.layer_begin = 1;
  mo.layer_end = 2;
  const QualityReport r = measure(moves, AxisModel::belt(35.0, 0.08), 1000.0, mo);
  ASSERT_FALSE(r.per_layer.empty());
  EXPECT_EQ(r.per_layer.begin()->first, 1);
  EXPECT_EQ(r.per_layer.rbegin()->first, 2);
}

}  // namespace
}  // namespace amctl::dynamics
