#include "amctl/report/line_chart.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::report {
namespace {

// 1, 2 or 5 times a power of ten, the smallest not below `raw`.
double nice_step(double raw) {
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * p >= raw * (1.0 - 1e-12)) return m * p;
  }
  return 10.0 * p;
}

struct Linear {
  double lo, hi, step;
};

Linear linear_axis(double lo, double hi) {
  if (hi == lo) {
    const double pad = lo == 0.0 ? 1.0 : 0.1 * std::abs(lo);
    lo -= pad;
    hi += pad;
  }
  const double step = nice_step((hi - lo) / 5.0);
  return {std::floor(lo / step + 1e-9) * step, std::ceil(hi / step - 1e-9) * step, step};
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string tick_label(double v) {
  if (v != 0.0 && (std::abs(v) >= 1e5 || std::abs(v) < 1e-3)) return fmt::format("{:g}", v);
  std::string s = fmt::format("{:.6f}", v);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

// Colour-blind-safe palette (Okabe and Ito).
constexpr const char* kColours[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                    "#E69F00", "#56B4E9", "#000000", "#F0E442"};

}  // namespace

ChartRange chart_range(const LineChart& c) {
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin;
  double ymin = xmin, ymax = -xmin;
  std::size_t points = 0;
  for (const ChartPanel& p : c.panels) {
    for (const ChartSeries& s : p.series) {
      if (s.x.size() != s.y.size()) {
        throw Error(fmt::format("chart series '{}': {} x values but {} y values", s.name,
                                s.x.size(), s.y.size()));
      }
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
          throw Error(fmt::format("chart series '{}': point {} is not finite", s.name, i));
        }
        if (c.log_y && s.y[i] <= 0.0) {
          throw Error(fmt::format(
              "chart series '{}': y = {} at point {} cannot be drawn on a logarithmic axis",
              s.name, s.y[i], i));
        }
        xmin = std::min(xmin, s.x[i]);
        xmax = std::max(xmax, s.x[i]);
        ymin = std::min(ymin, s.y[i]);
        ymax = std::max(ymax, s.y[i]);
        ++points;
      }
    }
  }
  if (points == 0) throw Error("chart: no point to draw");
  ChartRange r;
  const Linear lx = linear_axis(xmin, xmax);
  r.x0 = lx.lo;
  r.x1 = lx.hi;
  if (c.log_y) {
    r.y0 = std::pow(10.0, std::floor(std::log10(ymin) + 1e-12));
    r.y1 = std::pow(10.0, std::ceil(std::log10(ymax) - 1e-12));
    if (r.y1 <= r.y0) r.y1 = r.y0 * 10.0;
  } else {
    const Linear ly = linear_axis(ymin, ymax);
    r.y0 = ly.lo;
    r.y1 = ly.hi;
  }
  return r;
}

std::string to_svg(const LineChart& c) {
  const ChartRange r = chart_range(c);
  const double pw = kPanelWidth - kMarginLeft - kMarginRight;
  const double ph = kHeight - kMarginTop - kMarginBottom;
  const double width = kPanelWidth * static_cast<double>(c.panels.size());
  auto fy = [&](double y) { return c.log_y ? std::log10(y) : y; };
  const double fy0 = fy(r.y0), fy1 = fy(r.y1);
  std::string out = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\" font-family=\"sans-serif\" font-size=\"12\">\n"
      "<rect width=\"{0}\" height=\"{1}\" fill=\"white\"/>\n"
      "<text x=\"{2}\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">{3}</text>\n",
      width, kHeight, width / 2, escape(c.title));
  const Linear xt = linear_axis(r.x0, r.x1);
  for (std::size_t pi = 0; pi < c.panels.size(); ++pi) {
    const ChartPanel& panel = c.panels[pi];
    const double left = kPanelWidth * static_cast<double>(pi) + kMarginLeft;
    const double bottom = kHeight - kMarginBottom;
    auto px = [&](double x) { return left + (x - r.x0) / (r.x1 - r.x0) * pw; };
    auto py = [&](double y) { return bottom - (fy(y) - fy0) / (fy1 - fy0) * ph; };
    out += fmt::format("<g class=\"panel\">\n<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" "
                       "font-size=\"13\">{}</text>\n",
                       left + pw / 2, kMarginTop - 34, escape(panel.title));
    // Grid and ticks.
    for (double x = xt.lo; x <= xt.hi + 1e-9 * xt.step; x += xt.step) {
      out += fmt::format("<line x1=\"{0:.2f}\" y1=\"{1}\" x2=\"{0:.2f}\" y2=\"{2}\" stroke=\"#ddd\"/>"
                         "<text x=\"{0:.2f}\" y=\"{3}\" text-anchor=\"middle\">{4}</text>\n",
                         px(x), kMarginTop, bottom, bottom + 16, tick_label(x));
    }
    if (c.log_y) {
      for (double d = fy0; d <= fy1 + 1e-9; d += 1.0) {
        const double y = std::pow(10.0, d);
        out += fmt::format("<line x1=\"{0}\" y1=\"{1:.2f}\" x2=\"{2}\" y2=\"{1:.2f}\" stroke=\"#ddd\"/>"
                           "<text x=\"{3}\" y=\"{4:.2f}\" text-anchor=\"end\">{5}</text>\n",
                           left, py(y), left + pw, left - 6, py(y) + 4, tick_label(y));
      }
    } else {
      const Linear yt = linear_axis(r.y0, r.y1);
      for (double y = yt.lo; y <= yt.hi + 1e-9 * yt.step; y += yt.step) {
        out += fmt::format("<line x1=\"{0}\" y1=\"{1:.2f}\" x2=\"{2}\" y2=\"{1:.2f}\" stroke=\"#ddd\"/>"
                           "<text x=\"{3}\" y=\"{4:.2f}\" text-anchor=\"end\">{5}</text>\n",
                           left, py(y), left + pw, left - 6, py(y) + 4, tick_label(y));
      }
    }
    out += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" "
                       "stroke=\"#444\"/>\n",
                       left, kMarginTop, pw, ph);
    out += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", left + pw / 2,
                       kHeight - 12, escape(c.x_label));
    out += fmt::format("<text transform=\"translate({},{}) rotate(-90)\" text-anchor=\"middle\">{}"
                       "</text>\n",
                       left - 52, kMarginTop + ph / 2, escape(c.y_label));
    for (std::size_t si = 0; si < panel.series.size(); ++si) {
      const ChartSeries& s = panel.series[si];
      const char* colour = kColours[si % std::size(kColours)];
      std::string pts;
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        pts += fmt::format("{}{:.2f},{:.2f}", i ? " " : "", px(s.x[i]), py(s.y[i]));
      }
      out += fmt::format("<polyline class=\"series\" data-name=\"{}\" points=\"{}\" fill=\"none\" "
                         "stroke=\"{}\" stroke-width=\"2\"/>\n",
                         escape(s.name), pts, colour);
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        out += fmt::format("<circle cx=\"{:.2f}\" cy=\"{:.2f}\" r=\"3\" fill=\"{}\"/>\n",
                           px(s.x[i]), py(s.y[i]), colour);
      }
      // Legend: one row between the panel's title and its plot area.
      const double lx = left + 90.0 * static_cast<double>(si);
      const double ly = kMarginTop - 12;
      out += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"{3}\" "
                         "stroke-width=\"2\"/><text x=\"{4}\" y=\"{5}\">{6}</text>\n",
                         lx, ly, lx + 20, colour, lx + 25, ly + 4, escape(s.name));
    }
    out += "</g>\n";
  }
  out += "</svg>\n";
  return out;
}

}  // namespace amctl::report
