// The speed level-of-detail sink: min/max per bucket against a direct computation over every
// move (dense sampling of the trapezoid written out here), bounded size, dominant feature.
#include "amctl/report/speed_lod.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/plan/stream.hpp"
#include "test_util.hpp"

namespace amctl::report {
namespace {

/// Trapezoid speed of m at print time t (independent of the sink's code).
double trapezoid_speed(const plan::PlannedMove& m, double t) {
  if (m.extrude_only) return 0.0;
  const double u = t - m.start_time_s;
  if (u <= m.accel_t_s) return m.start_v_mm_s + m.accel_mm_s2 * u;
  if (u <= m.accel_t_s + m.cruise_t_s) return m.cruise_v_mm_s;
  const double d = u - m.accel_t_s - m.cruise_t_s;
  return m.cruise_v_mm_s - m.accel_mm_s2 * d;
}

struct Direct {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  double covered_s = 0.0;
};

TEST(SpeedLod, MinMaxPerBucketMatchDenseSamplingOfEveryMove) {
  const machine::Machine m = test::klipper();
  const std::string text = test::polygons(30, 24);
  plan::PlanSource source(text, "poly.gcode", m);
  plan::CollectSink all;
  SpeedLodSink lod(64, 0.001);  // small: the width doubles many times
  plan::Sink* sinks[] = {&all, &lod};
  plan::run_pipeline(source, sinks);

  const double w = lod.bucket_s();
  const auto& b = lod.buckets();
  ASSERT_LE(b.size(), 64u);
  ASSERT_GE(b.size(), 32u);
  ASSERT_GE(w * static_cast<double>(b.size()), all.summary.end_time_s);
  std::vector<Direct> d(b.size());
  const double dt = 2e-5;
  for (const plan::PlannedMove& mv : all.moves) {
    // Samples every dt plus both ends; each sample goes to its bucket.
    const double t0 = mv.start_time_s, t1 = mv.end_time_s();
    const auto n = static_cast<long>(std::ceil((t1 - t0) / dt));
    for (long i = 0; i <= n; ++i) {
      const double t = std::min(t1, t0 + static_cast<double>(i) * dt);
      const auto k = std::min(static_cast<std::size_t>(t / w), b.size() - 1);
      const double v = trapezoid_speed(mv, t);
      d[k].lo = std::min(d[k].lo, v);
      d[k].hi = std::max(d[k].hi, v);
    }
    // Time covered per bucket.
    for (std::size_t k = static_cast<std::size_t>(t0 / w); k < b.size() && static_cast<double>(k) * w < t1; ++k) {
      d[k].covered_s += std::min(t1, static_cast<double>(k + 1) * w) - std::max(t0, static_cast<double>(k) * w);
    }
  }
  const double slack = m.max_accel_mm_s2 * dt + 1e-3;  // speed change between two samples
  for (std::size_t k = 0; k < b.size(); ++k) {
    SCOPED_TRACE(k);
    const double span = std::min(w, all.summary.end_time_s - static_cast<double>(k) * w);
    if (d[k].covered_s <= 0.0) {
      EXPECT_EQ(b[k].max_speed_mm_s, 0.0F);
      continue;
    }
    EXPECT_NEAR(b[k].max_speed_mm_s, d[k].hi, slack);
    const double lo = d[k].covered_s < span * (1 - 1e-6) ? 0.0 : d[k].lo;
    EXPECT_NEAR(b[k].min_speed_mm_s, lo, slack);
    EXPECT_NEAR(b[k].covered_s, d[k].covered_s, 1e-6 * w + 1e-9);
  }
}

TEST(SpeedLod, SizeStaysBoundedWhateverThePrintLength) {
  const machine::Machine m = test::klipper();
  for (int layers : {1, 5, 40}) {
    const std::string text = test::polygons(layers, 16);
    plan::PlanSource source(text, "poly.gcode", m);
    SpeedLodSink lod(128, 1e-4);
    plan::Sink* sinks[] = {&lod};
    const plan::StreamSummary& s = plan::run_pipeline(source, sinks);
    EXPECT_LE(lod.buckets().size(), 128u);
    EXPECT_GT(lod.buckets().size(), 64u);
    EXPECT_GE(lod.bucket_s() * static_cast<double>(lod.buckets().size()), s.end_time_s);
    EXPECT_LT(lod.bucket_s() * 64.0, s.end_time_s);
  }
}

TEST(SpeedLod, DominantFeatureIsTheOneWithMostTime) {
  SpeedBucket b;
  b.covered_s = 1.0;
  b.feature_time_s = {{2, 0.2F}, {5, 0.7F}, {1, 0.1F}};
  EXPECT_EQ(b.dominant_feature(), 5);
  EXPECT_EQ(SpeedBucket{}.dominant_feature(), -1);
}

TEST(SpeedLod, EmptyStreamHasNoBuckets) {
  plan::PlanSource source(std::string_view("G90\n; nothing\n"), "empty.gcode", test::klipper());
  SpeedLodSink lod;
  plan::Sink* sinks[] = {&lod};
  plan::run_pipeline(source, sinks);
  EXPECT_TRUE(lod.buckets().empty());
}

}  // namespace
}  // namespace amctl::report
