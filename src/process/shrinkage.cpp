#include "amctl/process/shrinkage.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include <fmt/format.h>

namespace amctl::process {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Millimetres per unit for the units accepted in column names.
std::optional<double> unit_to_mm(std::string_view unit) {
  if (unit == "mm") return 1.0;
  if (unit == "um") return 1e-3;
  if (unit == "in") return 25.4;
  return std::nullopt;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

struct UnitColumn {
  std::size_t index = 0;
  std::string unit;
  double scale = 1.0;
};

std::optional<UnitColumn> find_unit_column(const CsvTable& t, std::string_view prefix) {
  std::optional<UnitColumn> found;
  for (std::size_t i = 0; i < t.header().size(); ++i) {
    const std::string h = lower(t.header()[i]);
    if (h.rfind(prefix, 0) != 0) continue;
    const std::string unit = h.substr(prefix.size());
    if (unit.find('_') != std::string::npos) continue;  // e.g. measured_sd_mm: another quantity
    const auto s = unit_to_mm(unit);
    if (!s) continue;  // e.g. nominal_id: not a length column
    if (found) {
      throw Error(SourceLocation{t.file(), 0, 0},
                  fmt::format("two columns start with '{}' ('{}' and '{}'); keep one",
                              prefix, t.header()[found->index], t.header()[i]));
    }
    found = UnitColumn{i, unit, *s};
  }
  return found;
}

RangeFit make_range(const std::vector<double>& x, const std::vector<double>& y,
                    const std::vector<double>& raw_x, const std::vector<double>& raw_y,
                    bool raw_fit, double confidence, char axis, int index) {
  const std::string what = fmt::format("shrink fit, axis {}, range {}", axis, index + 1);
  RangeFit r;
  r.line = fit_line(x, y, what.c_str());
  r.data_min_mm = *std::min_element(x.begin(), x.end());
  r.data_max_mm = *std::max_element(x.begin(), x.end());
  std::vector<double> levels(x);
  std::sort(levels.begin(), levels.end());
  levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
  r.levels = levels.size();
  const double a = r.line.slope;
  if (!(1.0 + a > 0.0)) {
    throw Error(fmt::format("{}: slope {} gives 1 + A <= 0, so the factor C = 1/(1+A) is "
                            "undefined; are nominal and measured swapped or in different units?",
                            what, a));
  }
  r.factor = 1.0 / (1.0 + a);
  r.factor_se = r.line.slope_se / ((1.0 + a) * (1.0 + a));
  const double t = student_t_quantile(0.5 + 0.5 * confidence, static_cast<double>(r.line.dof()));
  r.slope_ci_lo = a - t * r.line.slope_se;
  r.slope_ci_hi = a + t * r.line.slope_se;
  // C(A) is decreasing, so the slope interval maps to [C(hi), C(lo)] exactly; a lower slope
  // bound at or below -1 leaves the upper factor bound unbounded.
  r.factor_ci_lo = 1.0 / (1.0 + r.slope_ci_hi);
  r.factor_ci_hi = 1.0 + r.slope_ci_lo > 0.0 ? 1.0 / (1.0 + r.slope_ci_lo) : kInf;
  // Pure error from repeats: deviations of the raw points from their level means.
  std::map<double, std::pair<double, int>> sums;
  for (std::size_t i = 0; i < raw_x.size(); ++i) {
    auto& s = sums[raw_x[i]];
    s.first += raw_y[i];
    s.second += 1;
  }
  double ss_pe = 0.0;
  for (std::size_t i = 0; i < raw_x.size(); ++i) {
    const auto& s = sums[raw_x[i]];
    const double d = raw_y[i] - s.first / s.second;
    ss_pe += d * d;
  }
  const double df_pe = static_cast<double>(raw_x.size()) - static_cast<double>(sums.size());
  if (df_pe > 0) r.pure_error_sd_mm = std::sqrt(ss_pe / df_pe);
  if (raw_fit && df_pe > 0 && sums.size() > 2 && ss_pe > 0.0) {
    const double df_lof = static_cast<double>(sums.size()) - 2.0;
    const double ss_lof = std::max(0.0, r.line.sse - ss_pe);
    const double f = (ss_lof / df_lof) / (ss_pe / df_pe);
    r.lack_of_fit_p = f_survival(f, df_lof, df_pe);
  }
  return r;
}

}  // namespace

std::vector<ShrinkSample> read_shrink_samples(const CsvTable& t) {
  const auto nominal = find_unit_column(t, "nominal_");
  const auto measured = find_unit_column(t, "measured_");
  if (!nominal || !measured) {
    std::string cols;
    for (const auto& h : t.header()) cols += (cols.empty() ? "" : ", ") + h;
    throw Error(SourceLocation{t.file(), t.header_line(), 0},
                fmt::format("expected columns nominal_mm and measured_mm (or _um, _in in "
                            "both) in the header, found: {}",
                            cols));
  }
  if (nominal->unit != measured->unit) {
    throw Error(SourceLocation{t.file(), t.header_line(), 0},
                fmt::format("units do not match: '{}' is in {} but '{}' is in {}; give both "
                            "columns in the same unit",
                            t.header()[nominal->index], nominal->unit,
                            t.header()[measured->index], measured->unit));
  }
  const auto axis_col = t.find("axis");
  std::vector<ShrinkSample> out;
  out.reserve(t.rows());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    ShrinkSample s;
    s.line = t.where(r, 0).line;
    const double nom = t.number(r, nominal->index);
    const double meas = t.number(r, measured->index);
    if (!(nom > 0.0)) {
      throw Error(t.where(r, nominal->index),
                  fmt::format("nominal size must be > 0, got {}", nom));
    }
    if (meas < 0.0) {
      throw Error(t.where(r, measured->index),
                  fmt::format("measured size must be >= 0, got {} (a size cannot be negative; "
                              "give sizes, not errors)",
                              meas));
    }
    s.nominal_mm = nom * nominal->scale;
    s.measured_mm = meas * measured->scale;
    // A test part is not a kilometre long; larger values (1e308) overflow the fit's sums of
    // squares into a NaN slope and a factor of 0.
    constexpr double kMaxSize_mm = 1e6;
    if (s.nominal_mm > kMaxSize_mm || s.measured_mm > kMaxSize_mm) {
      const bool nominal_big = s.nominal_mm > kMaxSize_mm;
      throw Error(t.where(r, nominal_big ? nominal->index : measured->index),
                  fmt::format("{} size {} mm is out of range: expected at most 1e6 mm (1 km)",
                              nominal_big ? "nominal" : "measured",
                              nominal_big ? s.nominal_mm : s.measured_mm));
    }
    if (axis_col) {
      const std::string a = lower(t.text(r, *axis_col));
      if (a == "x" || a == "y" || a == "z") {
        s.axis = static_cast<char>(std::toupper(static_cast<unsigned char>(a[0])));
      } else {
        throw Error(t.where(r, *axis_col),
                    fmt::format("axis must be X, Y or Z, got '{}'", t.text(r, *axis_col)));
      }
    }
    out.push_back(s);
  }
  if (out.empty()) throw Error(SourceLocation{t.file(), 0, 0}, "no data rows");
  return out;
}

std::vector<std::size_t> best_segmentation(const std::vector<double>& x,
                                           const std::vector<double>& y, int k,
                                           int min_points) {
  AMCTL_CHECK(x.size() == y.size(), "segmentation sizes differ");
  AMCTL_CHECK(std::is_sorted(x.begin(), x.end()), "segmentation needs sorted x");
  if (k < 1) throw Error(fmt::format("number of ranges must be >= 1, got {}", k));
  min_points = std::max(min_points, 3);
  const std::size_t n = x.size();
  // Block boundaries: indices where a new distinct x starts, plus n.
  std::vector<std::size_t> bounds{0};
  for (std::size_t i = 1; i < n; ++i) {
    if (x[i] != x[i - 1]) bounds.push_back(i);
  }
  bounds.push_back(n);
  const std::size_t nb = bounds.size() - 1;
  // Prefix sums about a shift for accuracy.
  const double shift = n ? x[n / 2] : 0.0;
  std::vector<double> s1(n + 1, 0), sx(n + 1, 0), sy(n + 1, 0), sxx(n + 1, 0), sxy(n + 1, 0),
      syy(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const double u = x[i] - shift;
    s1[i + 1] = s1[i] + 1;
    sx[i + 1] = sx[i] + u;
    sy[i + 1] = sy[i] + y[i];
    sxx[i + 1] = sxx[i] + u * u;
    sxy[i + 1] = sxy[i] + u * y[i];
    syy[i + 1] = syy[i] + y[i] * y[i];
  }
  auto cost = [&](std::size_t ba, std::size_t bb) {  // blocks [ba, bb)
    if (bb - ba < 2) return kInf;
    const std::size_t a = bounds[ba], b = bounds[bb];
    const double m = s1[b] - s1[a];
    if (m < min_points) return kInf;
    const double mx = sx[b] - sx[a], my = sy[b] - sy[a];
    const double cxx = (sxx[b] - sxx[a]) - mx * mx / m;
    const double cxy = (sxy[b] - sxy[a]) - mx * my / m;
    const double cyy = (syy[b] - syy[a]) - my * my / m;
    if (!(cxx > 0)) return kInf;
    return std::max(0.0, cyy - cxy * cxy / cxx);
  };
  const auto K = static_cast<std::size_t>(k);
  std::vector<std::vector<double>> best(K + 1, std::vector<double>(nb + 1, kInf));
  std::vector<std::vector<std::size_t>> from(K + 1, std::vector<std::size_t>(nb + 1, 0));
  best[0][0] = 0.0;
  for (std::size_t s = 1; s <= K; ++s) {
    for (std::size_t j = 1; j <= nb; ++j) {
      for (std::size_t i = 0; i < j; ++i) {
        if (!std::isfinite(best[s - 1][i])) continue;
        const double c = best[s - 1][i] + cost(i, j);
        if (c < best[s][j]) {
          best[s][j] = c;
          from[s][j] = i;
        }
      }
    }
  }
  if (!std::isfinite(best[K][nb])) {
    throw Error(fmt::format(
        "cannot split {} points with {} distinct nominal values into {} range(s) of at least "
        "{} points and 2 distinct values each",
        n, nb, k, min_points));
  }
  std::vector<std::size_t> starts;
  std::size_t j = nb;
  for (std::size_t s = K; s >= 1; --s) {
    const std::size_t i = from[s][j];
    if (s > 1) starts.push_back(bounds[i]);
    j = i;
  }
  std::reverse(starts.begin(), starts.end());
  return starts;
}

AxisShrinkFit fit_shrinkage_axis(const std::vector<ShrinkSample>& samples,
                                 const ShrinkFitOptions& opt) {
  if (samples.empty()) throw Error("shrink fit: no samples");
  if (!(opt.confidence > 0.0 && opt.confidence < 1.0)) {
    throw Error(fmt::format("confidence must lie strictly between 0 and 1, got {}",
                            opt.confidence));
  }
  const char axis = samples.front().axis;
  // Sort by nominal; error = measured - nominal.
  std::vector<std::pair<double, double>> raw;
  raw.reserve(samples.size());
  for (const auto& s : samples) {
    AMCTL_CHECK(s.axis == axis, "fit_shrinkage_axis got mixed axes");
    raw.emplace_back(s.nominal_mm, s.measured_mm - s.nominal_mm);
  }
  std::stable_sort(raw.begin(), raw.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<double> rx, ry;
  for (const auto& [h, e] : raw) {
    rx.push_back(h);
    ry.push_back(e);
  }
  std::vector<double> px, py;  // points fitted
  if (opt.average_repeats) {
    for (std::size_t i = 0; i < rx.size();) {
      std::size_t j = i;
      double s = 0.0;
      while (j < rx.size() && rx[j] == rx[i]) s += ry[j++];
      px.push_back(rx[i]);
      py.push_back(s / static_cast<double>(j - i));
      i = j;
    }
  } else {
    px = rx;
    py = ry;
  }

  AxisShrinkFit out;
  out.axis = axis;
  out.confidence = opt.confidence;
  std::vector<double> breaks;  // upper bounds of all ranges but the last
  if (!opt.breaks_mm.empty()) {
    for (std::size_t i = 0; i < opt.breaks_mm.size(); ++i) {
      const double b = opt.breaks_mm[i];
      if (!std::isfinite(b) || b <= 0.0) {
        throw Error(fmt::format("breakpoint {} must be a finite number > 0 mm, got {}", i + 1, b));
      }
      if (i > 0 && !(b > opt.breaks_mm[i - 1])) {
        throw Error(fmt::format("breakpoints must be strictly increasing: breakpoint {} = {} "
                                "follows {}",
                                i + 1, b, opt.breaks_mm[i - 1]));
      }
    }
    breaks = opt.breaks_mm;
  } else {
    int k = opt.ranges;
    if (k < 0) throw Error(fmt::format("number of ranges must be >= 0 (0 = auto), got {}", k));
    if (k == 0) {
      // Bayesian information criterion over k = 1..max: n ln(SSE/n) + (3k - 1) ln n
      // (two line parameters per range plus k - 1 breakpoints).
      const double n = static_cast<double>(px.size());
      double best_bic = kInf;
      int best_k = 1;
      for (int kk = 1; kk <= std::max(1, opt.max_auto_ranges); ++kk) {
        std::vector<std::size_t> starts;
        try {
          starts = best_segmentation(px, py, kk, opt.min_points_per_range);
        } catch (const Error&) {
          if (kk == 1) throw;
          break;
        }
        double sse = 0.0;
        std::vector<std::size_t> edges{0};
        edges.insert(edges.end(), starts.begin(), starts.end());
        edges.push_back(px.size());
        for (std::size_t s = 0; s + 1 < edges.size(); ++s) {
          std::vector<double> sx(px.begin() + edges[s], px.begin() + edges[s + 1]);
          std::vector<double> sy(py.begin() + edges[s], py.begin() + edges[s + 1]);
          sse += fit_line(sx, sy).sse;
        }
        const double bic = n * std::log(std::max(sse, 1e-300) / n) + (3.0 * kk - 1.0) * std::log(n);
        if (bic < best_bic) {
          best_bic = bic;
          best_k = kk;
        }
      }
      k = best_k;
    }
    if (k > 1) {
      const auto starts = best_segmentation(px, py, k, opt.min_points_per_range);
      for (const std::size_t s : starts) breaks.push_back(0.5 * (px[s - 1] + px[s]));
      out.breaks_from_data = true;
    }
  }
  // Assign points to ranges: range r holds breaks[r-1] < h <= breaks[r].
  const std::size_t nr = breaks.size() + 1;
  for (std::size_t r = 0; r < nr; ++r) {
    const double lo = r == 0 ? -kInf : breaks[r - 1];
    const double hi = r + 1 == nr ? kInf : breaks[r];
    std::vector<double> x, y, wx, wy;
    for (std::size_t i = 0; i < px.size(); ++i) {
      if (px[i] > lo && px[i] <= hi) {
        x.push_back(px[i]);
        y.push_back(py[i]);
      }
    }
    for (std::size_t i = 0; i < rx.size(); ++i) {
      if (rx[i] > lo && rx[i] <= hi) {
        wx.push_back(rx[i]);
        wy.push_back(ry[i]);
      }
    }
    if (x.size() < 3) {
      const std::string span =
          nr == 1 ? std::string("all data")
                  : fmt::format("{} < h <= {} mm", r == 0 ? 0.0 : lo,
                                std::isfinite(hi) ? fmt::format("{}", hi) : std::string("inf"));
      throw Error(fmt::format(
          "shrink fit, axis {}: range {} of {} ({}) holds {} point(s); fitting 2 parameters "
          "with standard errors needs at least 3",
          axis, r + 1, nr, span, x.size()));
    }
    RangeFit rf = make_range(x, y, wx, wy, !opt.average_repeats, opt.confidence, axis,
                             static_cast<int>(r));
    rf.lower_mm = r == 0 ? 0.0 : lo;
    rf.upper_mm = hi;
    out.total_sse += rf.line.sse;
    out.ranges.push_back(rf);
  }
  return out;
}

std::vector<AxisShrinkFit> fit_shrinkage(const std::vector<ShrinkSample>& samples,
                                         const ShrinkFitOptions& options) {
  std::vector<AxisShrinkFit> out;
  for (const char axis : {'X', 'Y', 'Z'}) {
    std::vector<ShrinkSample> sub;
    for (const auto& s : samples) {
      if (s.axis == axis) sub.push_back(s);
    }
    if (!sub.empty()) out.push_back(fit_shrinkage_axis(sub, options));
  }
  if (out.empty()) throw Error("shrink fit: no samples");
  return out;
}

}  // namespace amctl::process
