// The SVG line chart: where a point lands (from the layout constants documented in
// line_chart.hpp, computed here by hand), the axis ranges widened to whole ticks, escaping,
// and bad data refused.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/report/line_chart.hpp"

namespace amctl::report {
namespace {

LineChart one_series(bool log_y, std::vector<double> x, std::vector<double> y) {
  LineChart c;
  c.title = "t";
  c.log_y = log_y;
  c.panels = {{"p", {{"s", std::move(x), std::move(y)}}}};
  return c;
}

TEST(LineChart, APointLandsWhereTheLayoutPutsIt) {
  // x in [0, 10], y in [1, 100] on a log axis: (5, 10) is the middle of the plot area.
  // Plot area: left 70, width 460 - 70 - 20 = 370; bottom 360 - 50 = 310, height 360 - 80 - 50
  // = 230. Middle: (70 + 185, 310 - 115) = (255, 195); (0, 1) is (70, 310), (10, 100) (440, 80).
  const std::string svg = to_svg(one_series(true, {0, 5, 10}, {1, 10, 100}));
  EXPECT_NE(svg.find("points=\"70.00,310.00 255.00,195.00 440.00,80.00\""), std::string::npos) << svg;
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

TEST(LineChart, RangesWidenToWholeTicksAndDecades) {
  // 0.3 .. 9.7: a step of nice(9.4 / 5 = 1.88) = 2, so [0, 10]; y 0.02 .. 3 on a log axis:
  // [0.01, 10].
  const ChartRange r = chart_range(one_series(true, {0.3, 9.7}, {0.02, 3}));
  EXPECT_DOUBLE_EQ(r.x0, 0.0);
  EXPECT_DOUBLE_EQ(r.x1, 10.0);
  EXPECT_NEAR(r.y0, 0.01, 1e-15);
  EXPECT_NEAR(r.y1, 10.0, 1e-12);
  // Linear y 12 .. 47: step nice(7) = 10 -> [10, 50].
  const ChartRange l = chart_range(one_series(false, {30, 150}, {12, 47}));
  EXPECT_DOUBLE_EQ(l.y0, 10.0);
  EXPECT_DOUBLE_EQ(l.y1, 50.0);
  // x 30 .. 150: a step of nice(120 / 5 = 24) = 50, so [0, 150].
  EXPECT_DOUBLE_EQ(l.x0, 0.0);
  EXPECT_DOUBLE_EQ(l.x1, 150.0);
}

TEST(LineChart, NamesAreEscaped) {
  LineChart c = one_series(false, {0, 1}, {0, 1});
  c.panels[0].series[0].name = "a<b & \"c\"";
  const std::string svg = to_svg(c);
  EXPECT_NE(svg.find("data-name=\"a&lt;b &amp; &quot;c&quot;\""), std::string::npos);
}

TEST(LineChart, BadDataIsRefused) {
  EXPECT_THROW((void)to_svg(LineChart{}), Error);
  EXPECT_THROW((void)to_svg(one_series(false, {0, 1}, {0, std::nan("")})), Error);
  EXPECT_THROW((void)to_svg(one_series(true, {0, 1}, {1, 0})), Error);
  EXPECT_THROW((void)to_svg(one_series(false, {0, 1}, {0})), Error);
}

}  // namespace
}  // namespace amctl::report
