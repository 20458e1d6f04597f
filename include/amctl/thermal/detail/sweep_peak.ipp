#pragma once
// Implementation of amctl::thermal::sweep_peak (included from robust_margin.hpp).
#include <cmath>
#include <algorithm>
#include <limits>
#include <vector>

namespace amctl::thermal {

template <class F>
PeakResult sweep_peak(F&& f, const SweepOptions& opt) {
  const double l0 = std::log10(opt.w_min_rad_s), l1 = std::log10(opt.w_max_rad_s);
  const int n = std::max(3, int(std::ceil((l1 - l0) * opt.points_per_decade)) + 1);
  PeakResult res;
  auto mag = [&](double lw) {
    ++res.evaluations;
    return std::abs(f(std::complex<double>(0.0, std::pow(10.0, lw))));
  };
  std::vector<double> m(static_cast<std::size_t>(n));
  const double step = (l1 - l0) / (n - 1);
  for (int i = 0; i < n; ++i) m[std::size_t(i)] = mag(l0 + step * i);
  res.peak = m[0];
  res.omega_rad_s = opt.w_min_rad_s;
  for (int i = 0; i < n; ++i) {
    const auto iu = std::size_t(i);
    const bool left_ok = i == 0 || m[iu] >= m[iu - 1];
    const bool right_ok = i == n - 1 || m[iu] >= m[iu + 1];
    if (!(left_ok && right_ok)) continue;
    double best = m[iu], best_lw = l0 + step * i;
    if (i > 0 && i < n - 1) {
      // Golden-section search for the maximum of |f| on [l_{i-1}, l_{i+1}] (log w).
      const double g = (std::sqrt(5.0) - 1.0) / 2.0;
      double a = l0 + step * (i - 1), b = l0 + step * (i + 1);
      double c = b - g * (b - a), d = a + g * (b - a);
      double fc = mag(c), fd = mag(d);
      while (b - a > opt.rel_tol) {
        if (fc > fd) {
          b = d; d = c; fd = fc; c = b - g * (b - a); fc = mag(c);
        } else {
          a = c; c = d; fc = fd; d = a + g * (b - a); fd = mag(d);
        }
      }
      const double lm = 0.5 * (a + b), fm = mag(lm);
      if (fm > best) { best = fm; best_lw = lm; }
    }
    if (best > res.peak) {
      res.peak = best;
      res.omega_rad_s = std::pow(10.0, best_lw);
    }
  }
  if (res.omega_rad_s >= opt.w_max_rad_s * (1.0 - 1e-12))
    res.omega_rad_s = std::numeric_limits<double>::infinity();
  return res;
}

}  // namespace amctl::thermal
