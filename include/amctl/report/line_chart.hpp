#pragma once
// A line chart as a standalone SVG file: one or more panels side by side sharing their axes,
// each with named series of (x, y) points, a linear x axis and a linear or logarithmic y axis.
// No script, no external resource: the file opens in any browser and embeds in Markdown.
// Used for `amctl stepper sweep --svg` (error against speed per controller, docs/closedloop.md).
//
// Layout (pixels; what tests compute positions from): each panel is kPanelWidth x kHeight with
// the plot area inset by kMarginLeft, kMarginRight, kMarginTop, kMarginBottom; a value x maps to
// left + (x - x0) / (x1 - x0) * plot_width, a value y to bottom - (f(y) - f(y0)) / (f(y1) - f(y0))
// * plot_height with f = log10 on a log axis, identity otherwise. The axis ranges [x0, x1] and
// [y0, y1] are the data's, widened to whole ticks (whole decades on a log axis).
#include <string>
#include <vector>

namespace amctl::report {

struct ChartSeries {
  std::string name;
  std::vector<double> x, y;
};

struct ChartPanel {
  std::string title;
  std::vector<ChartSeries> series;
};

struct LineChart {
  std::string title;
  std::string x_label, y_label;
  bool log_y = false;
  std::vector<ChartPanel> panels;
};

inline constexpr double kPanelWidth = 460.0, kHeight = 360.0;
inline constexpr double kMarginLeft = 70.0, kMarginRight = 20.0, kMarginTop = 80.0,
                        kMarginBottom = 50.0;

/// The axis range a chart uses: the data's extent widened to whole ticks.
struct ChartRange {
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
};
/// Throws amctl::Error when there is no point, a value is not finite, x and y differ in length,
/// or log_y has a y <= 0.
[[nodiscard]] ChartRange chart_range(const LineChart& chart);

/// The SVG document (UTF-8 text). Same validation as chart_range.
[[nodiscard]] std::string to_svg(const LineChart& chart);

}  // namespace amctl::report
