#pragma once
// Small statistics kit for the process module: Student t and F distributions and an
// ordinary least-squares straight line with its classical statistics.
#include <cstddef>
#include <span>

namespace amctl::process {

/// Regularized incomplete beta function I_x(a, b), a, b > 0, 0 <= x <= 1.
[[nodiscard]] double incomplete_beta(double a, double b, double x);

/// Cumulative distribution of Student's t with `dof` degrees of freedom.
[[nodiscard]] double student_t_cdf(double t, double dof);

/// Quantile of Student's t: the t with student_t_cdf(t, dof) == p, 0 < p < 1.
[[nodiscard]] double student_t_quantile(double p, double dof);

/// Upper tail probability P(F > f) of Fisher's F(d1, d2).
[[nodiscard]] double f_survival(double f, double d1, double d2);

/// y = slope * x + intercept fitted by ordinary least squares.
struct LineFit {
  std::size_t n = 0;            ///< points used
  double slope = 0.0;
  double intercept = 0.0;
  double slope_se = 0.0;        ///< standard error of the slope
  double intercept_se = 0.0;
  double covariance = 0.0;      ///< cov(slope, intercept)
  double residual_sd = 0.0;     ///< sqrt(SSE / (n - 2))
  double sse = 0.0;             ///< sum of squared residuals
  double r2 = 0.0;              ///< coefficient of determination (1 when y is constant and fitted exactly)
  double x_mean = 0.0;
  double sxx = 0.0;             ///< sum (x - x_mean)^2
  [[nodiscard]] std::size_t dof() const { return n - 2; }
};

/// Fits a line through (x[i], y[i]). Throws amctl::Error naming `what` when fewer than
/// three points are given (two parameters plus one degree of freedom for the statistics),
/// when the sizes differ, a value is not finite, or all x coincide (singular fit).
[[nodiscard]] LineFit fit_line(std::span<const double> x, std::span<const double> y,
                               const char* what = "line fit");

}  // namespace amctl::process
