// Crossing times on a move's polynomial pieces (docs/steppers.md section 2).
#include "amctl/steppers/steps.hpp"
#include "step_solver.hpp"

namespace amctl::steppers {

using detail::horner;
using plan::PathPiece;

double solve_crossing_s(const PathPiece& p, double s_target, double lo) {
  const double T = p.duration_s;
  double tau = lo;
  if (p.degree == 1) {
    if (p.c[1] > 0.0) tau = (s_target - p.c[0]) / p.c[1];
  } else if (p.degree == 2) {
    // c2 tau^2 + c1 tau - D = 0 with c1 = v(0) >= 0: tau = 2D / (c1 + sqrt(c1^2 + 4 c2 D)),
    // free of cancellation for both signs of c2.
    const double D = s_target - p.c[0];
    const double disc = std::max(0.0, p.c[1] * p.c[1] + 4.0 * p.c[2] * D);
    const double den = p.c[1] + std::sqrt(disc);
    if (den > 0.0) tau = 2.0 * D / den;
  } else if (p.degree >= 3) {
    double a = lo, b = T, v = 0.0;
    const double fa = horner(p, a, v) - s_target;
    if (fa >= 0.0) return a;
    tau = v > 0.0 ? a - fa / v : 0.5 * (a + b);
    for (int it = 0; it < 200; ++it) {
      if (!(tau > a && tau < b)) tau = 0.5 * (a + b);
      const double f = horner(p, tau, v) - s_target;
      if (f == 0.0) return tau;
      if (f > 0.0) b = tau; else a = tau;
      const double step = v > 0.0 ? f / v : 0.0;
      const double next = tau - step;
      if (v > 0.0 && std::abs(step) <= 1e-14 * (1.0 + T)) {
        tau = std::clamp(next, a, b);
        break;
      }
      if (b - a <= 1e-13) {
        tau = 0.5 * (a + b);
        break;
      }
      tau = v > 0.0 ? next : 0.5 * (a + b);
    }
  }
  return std::clamp(tau, lo, T);
}

namespace detail {

PieceCursor::PieceCursor(const std::array<PathPiece, 7>& pieces, std::size_t count, double t0)
    : pieces_(pieces), count_(count), t0_(t0) {
  double d = 0.0;
  end_s_ = horner(pieces_[0], pieces_[0].duration_s, d);
}

double PieceCursor::time_at(double s_target) {
  double d = 0.0;
  while (i_ + 1 < count_ && s_target > end_s_) {
    t0_ += pieces_[i_].duration_s;
    ++i_;
    end_s_ = horner(pieces_[i_], pieces_[i_].duration_s, d);
    lo_ = 0.0;
  }
  lo_ = solve_crossing_s(pieces_[i_], s_target, lo_);
  return t0_ + lo_;
}

}  // namespace detail
}  // namespace amctl::steppers
