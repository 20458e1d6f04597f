#include "amctl/process/stats.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::process {
namespace {

// Continued fraction for I_x(a, b) (modified Lentz evaluation of the classical expansion
// x^a (1-x)^b / (a B(a,b)) * 1/(1+ d1/(1+ d2/(1+...))), d_{2m+1} = -(a+m)(a+b+m)x/((a+2m)(a+2m+1)),
// d_{2m} = m(b-m)x/((a+2m-1)(a+2m))).
double beta_continued_fraction(double a, double b, double x) {
  constexpr double tiny = 1e-300;
  constexpr double eps = 1e-15;
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::fabs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 10000; ++m) {
    const double m2 = 2.0 * m;
    double num = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
    d = 1.0 + num * d;
    if (std::fabs(d) < tiny) d = tiny;
    c = 1.0 + num / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    h *= d * c;
    num = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
    d = 1.0 + num * d;
    if (std::fabs(d) < tiny) d = tiny;
    c = 1.0 + num / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double step = d * c;
    h *= step;
    if (std::fabs(step - 1.0) < eps) break;
  }
  return h;
}

}  // namespace

double incomplete_beta(double a, double b, double x) {
  AMCTL_CHECK(a > 0.0 && b > 0.0, "incomplete beta needs positive shape parameters");
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double log_front =
      std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double front = std::exp(log_front);
  // The continued fraction converges fast for x < (a+1)/(a+b+2); use symmetry otherwise.
  if (x < (a + 1.0) / (a + b + 2.0)) return front * beta_continued_fraction(a, b, x) / a;
  return 1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b;
}

double student_t_cdf(double t, double dof) {
  AMCTL_CHECK(dof > 0.0, "Student t needs positive degrees of freedom");
  if (std::isinf(t)) return t > 0 ? 1.0 : 0.0;
  const double tail = 0.5 * incomplete_beta(0.5 * dof, 0.5, dof / (dof + t * t));
  return t >= 0.0 ? 1.0 - tail : tail;
}

double student_t_quantile(double p, double dof) {
  if (!(p > 0.0 && p < 1.0)) {
    throw Error(fmt::format("probability must lie strictly between 0 and 1, got {}", p));
  }
  if (p < 0.5) return -student_t_quantile(1.0 - p, dof);
  // Bracket then bisect: the cdf is monotone, and 200 halvings reach double precision.
  double lo = 0.0;
  double hi = 1.0;
  while (student_t_cdf(hi, dof) < p) {
    hi *= 2.0;
    if (hi > 1e12) return hi;
  }
  for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (student_t_cdf(mid, dof) < p) lo = mid; else hi = mid;
  }
  return 0.5 * (lo + hi);
}

double f_survival(double f, double d1, double d2) {
  if (!(f > 0.0)) return 1.0;
  return incomplete_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

LineFit fit_line(std::span<const double> x, std::span<const double> y, const char* what) {
  if (x.size() != y.size()) {
    throw Error(fmt::format("{}: {} x values but {} y values", what, x.size(), y.size()));
  }
  const std::size_t n = x.size();
  if (n < 3) {
    throw Error(fmt::format(
        "{}: {} point(s) given, need at least 3 (2 parameters plus 1 degree of freedom for the "
        "standard errors)",
        what, n));
  }
  double sx = 0.0, sy = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {
      throw Error(fmt::format("{}: point {} is not finite ({}, {})", what, i + 1, x[i], y[i]));
    }
    sx += x[i];
    sy += y[i];
  }
  const double xm = sx / static_cast<double>(n);
  const double ym = sy / static_cast<double>(n);
  double sxx = 0.0, sxy = 0.0, syy = 0.0, xscale = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = x[i] - xm;
    const double dy = y[i] - ym;
    sxx += dx * dx;
    sxy += dx * dy;
    syy += dy * dy;
    xscale = std::max(xscale, std::fabs(x[i]));
  }
  // Singular when the x spread vanishes relative to the magnitude of x (all x equal).
  if (!(sxx > 1e-20 * static_cast<double>(n) * (xscale * xscale + 1e-300))) {
    throw Error(fmt::format(
        "{}: singular fit, all {} points have the same abscissa {} (need at least two distinct "
        "values)",
        what, n, xm));
  }
  LineFit f;
  f.n = n;
  f.slope = sxy / sxx;
  f.intercept = ym - f.slope * xm;
  f.x_mean = xm;
  f.sxx = sxx;
  double sse = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = y[i] - (f.slope * x[i] + f.intercept);
    sse += r * r;
  }
  f.sse = sse;
  const double s2 = sse / static_cast<double>(n - 2);
  f.residual_sd = std::sqrt(s2);
  f.slope_se = std::sqrt(s2 / sxx);
  f.intercept_se = std::sqrt(s2 * (1.0 / static_cast<double>(n) + xm * xm / sxx));
  f.covariance = -xm * s2 / sxx;
  f.r2 = syy > 0.0 ? 1.0 - sse / syy : 1.0;
  return f;
}

}  // namespace amctl::process
