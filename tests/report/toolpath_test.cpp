// The toolpath sink: decimation keeps the endpoints and every change of kind, stays within
// its caps, and error samples land on the segment they were taken on.
#include "amctl/report/toolpath.hpp"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/plan/stream.hpp"
#include "test_util.hpp"

namespace amctl::report {
namespace {

ToolpathVertex vx(float x, float y, std::int32_t kind, float speed = 10.0F) {
  ToolpathVertex v;
  v.x_mm = x;
  v.y_mm = y;
  v.kind = kind;
  v.speed_mm_s = speed;
  return v;
}

TEST(Toolpath, DecimateKeepsEndpointsAndKindChanges) {
  std::vector<ToolpathVertex> in{vx(0, 0, -2)};
  for (int i = 1; i <= 100; ++i) in.push_back(vx(0.01F * static_cast<float>(i), 0, 3, static_cast<float>(i)));
  in.push_back(vx(1.05F, 0, -1));  // travel
  for (int i = 1; i <= 50; ++i) in.push_back(vx(1.05F, 0.01F * static_cast<float>(i), 4));
  const std::vector<ToolpathVertex> out = decimate(in, 0.1);
  ASSERT_GE(out.size(), 4u);
  EXPECT_LT(out.size(), 30u);
  EXPECT_EQ(out.front().kind, -2);
  EXPECT_FLOAT_EQ(out.back().x_mm, 1.05F);
  EXPECT_FLOAT_EQ(out.back().y_mm, 0.5F);
  // The vertex before the travel (end of the kind-3 run) is kept exactly, with the run's top speed.
  bool found = false;
  for (std::size_t i = 1; i < out.size(); ++i) {
    if (out[i].kind == -1) {
      EXPECT_FLOAT_EQ(out[i - 1].x_mm, 1.0F);
      EXPECT_EQ(out[i - 1].kind, 3);
      EXPECT_FLOAT_EQ(out[i - 1].speed_mm_s, 100.0F);
      found = true;
    }
  }
  EXPECT_TRUE(found);
  // Consecutive kept vertices of one kind are at least the tolerance apart, but for the last
  // of a run (kept because the kind changes after it, or the polyline ends).
  for (std::size_t i = 1; i + 2 < out.size(); ++i) {
    if (out[i].kind == out[i + 1].kind && out[i + 2].kind == out[i + 1].kind) {
      EXPECT_GE(std::hypot(out[i + 1].x_mm - out[i].x_mm, out[i + 1].y_mm - out[i].y_mm), 0.1 - 1e-6);
    }
  }
}

/// One layer: a spiral of n tiny extruding segments.
std::string spiral(int n) {
  std::string g = "G90\nM83\n;LAYER_CHANGE\n;Z:0.2\nG1 Z0.2 F600\nG0 X100 Y100 F6000\n;TYPE:Perimeter\n";
  for (int i = 1; i <= n; ++i) {
    const double a = 0.05 * i, r = 1.0 + 0.002 * i;
    g += "G1 X" + std::to_string(100 + r * std::cos(a)) + " Y" + std::to_string(100 + r * std::sin(a)) + " E0.01 F1800\n";
  }
  return g;
}

TEST(Toolpath, LayerCapBoundsThePointsAndKeepsBothEnds) {
  ToolpathOptions o;
  o.tolerance_mm = 0.01;
  o.max_points_per_layer = 500;
  o.max_points = 10000;
  ToolpathSink tp(o);
  plan::CollectSink all;
  const std::string text = spiral(20000);
  plan::PlanSource source(text, "spiral.gcode", test::klipper());
  plan::Sink* sinks[] = {&all, &tp};
  plan::run_pipeline(source, sinks);
  ASSERT_FALSE(tp.layers().empty());
  const ToolpathLayer& l = tp.layers().back();
  EXPECT_LE(l.vertices.size(), 500u);
  EXPECT_GT(l.vertices.size(), 50u);
  EXPECT_TRUE(tp.capped());
  EXPECT_FALSE(l.truncated);
  EXPECT_GT(l.tolerance_mm, 0.01);
  const plan::PlannedMove& last = all.moves.back();
  EXPECT_NEAR(l.vertices.back().x_mm, last.start_mm[0] + last.axes_r[0] * last.distance_mm, 1e-4);
  EXPECT_NEAR(l.vertices.back().y_mm, last.start_mm[1] + last.axes_r[1] * last.distance_mm, 1e-4);
  // The first vertex is where the layer's first XY move starts.
  const plan::PlannedMove* first = nullptr;
  for (const auto& mv : all.moves) {
    if (mv.layer == l.layer && !mv.extrude_only && (mv.axes_r[0] != 0 || mv.axes_r[1] != 0)) {
      first = &mv;
      break;
    }
  }
  ASSERT_NE(first, nullptr);
  EXPECT_NEAR(l.vertices.front().x_mm, first->start_mm[0], 1e-4);
  EXPECT_NEAR(l.vertices.front().y_mm, first->start_mm[1], 1e-4);
  std::size_t n = 0;
  for (const auto& layer : tp.layers()) n += layer.vertices.size();
  EXPECT_EQ(tp.points(), n);
}

TEST(Toolpath, TotalCapBoundsAllLayers) {
  ToolpathOptions o;
  o.tolerance_mm = 0.01;
  o.max_points_per_layer = 400;
  o.max_points = 1000;
  ToolpathSink tp(o);
  const std::string text = test::polygons(60, 48);
  plan::PlanSource source(text, "poly.gcode", test::klipper());
  plan::Sink* sinks[] = {&tp};
  plan::run_pipeline(source, sinks);
  std::size_t n = 0;
  for (const auto& l : tp.layers()) n += l.vertices.size();
  EXPECT_EQ(n, tp.points());
  EXPECT_LE(n, 1000u);
  EXPECT_TRUE(tp.capped());
  EXPECT_EQ(tp.layers().size(), 60u);
}

TEST(Toolpath, UncappedKeepsEveryVertexOfLongMoves) {
  ToolpathSink tp;
  const std::string text = test::polygons(3, 12);
  plan::PlanSource source(text, "poly.gcode", test::klipper());
  plan::Sink* sinks[] = {&tp};
  plan::run_pipeline(source, sinks);
  ASSERT_EQ(tp.layers().size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    // Layer 0: start, the travel to the polygon, 12 sides. Later layers start where the
    // polygon closed (their travel has no length): start and 12 sides.
    const ToolpathLayer& l = tp.layers()[k];
    const std::size_t travel = k == 0 ? 1 : 0;
    EXPECT_EQ(l.vertices.size(), 13u + travel);
    EXPECT_EQ(l.vertices[0].kind, -2);
    if (travel) EXPECT_EQ(l.vertices[1].kind, -1);
    for (std::size_t i = 1 + travel; i < l.vertices.size(); ++i) EXPECT_GE(l.vertices[i].kind, 0);
  }
  EXPECT_FALSE(tp.capped());
}

TEST(Toolpath, ErrorSamplesLandOnTheirSegment) {
  ToolpathSink tp;
  const std::string text = test::polygons(2, 6);
  plan::PlanSource source(text, "poly.gcode", test::klipper());
  plan::Sink* sinks[] = {&tp};
  plan::run_pipeline(source, sinks);
  ASSERT_EQ(tp.layers()[1].vertices.size(), 7u);
  const ToolpathVertex& v = tp.layers()[1].vertices[4];
  const ToolpathVertex& w = tp.layers()[1].vertices[5];
  tp.add_error_sample(0.0, 0.001);  // before: the first segment of layer 0 (travel) or none
  tp.add_error_sample(0.5 * (v.t0_s + v.t1_s), 0.25);
  tp.add_error_sample(0.5 * (v.t0_s + v.t1_s) + 1e-6, 0.125);
  tp.add_error_sample(0.5 * (w.t0_s + w.t1_s), std::nan(""));  // ignored
  EXPECT_FLOAT_EQ(tp.layers()[1].vertices[4].error_mm, 0.25F);
  EXPECT_LT(tp.layers()[1].vertices[5].error_mm, 0.0F);
  EXPECT_LT(tp.layers()[1].vertices[3].error_mm, 0.0F);
}

}  // namespace
}  // namespace amctl::report
