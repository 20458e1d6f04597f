#pragma once
// Implementation of amctl::thermal::sweep_peak (included from robust_margin.hpp).
#include <cmath>
#include <algorithm>
#include <limits>
#include <vector>

#include "amctl/numerics/scalar_search.hpp"

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
      numerics::GoldenSectionStop stop;
      stop.width = opt.rel_tol;
      const numerics::GoldenSectionBracket br = numerics::golden_section_minimize(
          [&](double lw) { return -mag(lw); }, l0 + step * (i - 1), l0 + step * (i + 1), stop);
      const double lm = br.midpoint(), fm = mag(lm);
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

template <class F>
int nyquist_closed_loop_rhp_poles(F&& loop, int open_loop_rhp_poles, double eps, double big_r) {
  using cd = std::complex<double>;
  const double pi = 3.14159265358979323846;
  auto f = [&](cd s) { return 1.0 + loop(s); };
  double total = 0.0;
  // Accumulates the continuous change of arg f(s(t)) for t in [t0, t1].
  auto track = [&](auto&& path, double t0, double t1) {
    struct Seg { double a, b; cd fa, fb; int depth; };
    std::vector<Seg> stack{{t0, t1, f(path(t0)), f(path(t1)), 0}};
    while (!stack.empty()) {
      Seg sg = stack.back();
      stack.pop_back();
      const double d = std::arg(sg.fb / sg.fa);
      if (std::abs(d) > 0.3 && sg.depth < 60) {
        const double m = 0.5 * (sg.a + sg.b);
        const cd fm = f(path(m));
        stack.push_back({m, sg.b, fm, sg.fb, sg.depth + 1});
        stack.push_back({sg.a, m, sg.fa, fm, sg.depth + 1});
        continue;
      }
      total += d;
    }
  };
  const double l_eps = std::log10(eps), l_r = std::log10(big_r);
  const int pieces = int(std::ceil((l_r - l_eps) * 20));
  // Up the negative imaginary axis: s = -j 10^u, u from log R down to log eps.
  auto neg = [&](double u) { return cd(0.0, -std::pow(10.0, u)); };
  for (int i = 0; i < pieces; ++i)
    track(neg, l_r - (l_r - l_eps) * i / pieces, l_r - (l_r - l_eps) * (i + 1) / pieces);
  // Indentation to the right of s = 0.
  auto ind = [&](double th) { return eps * cd(std::cos(th), std::sin(th)); };
  for (int i = 0; i < 16; ++i) track(ind, -pi / 2 + pi * i / 16, -pi / 2 + pi * (i + 1) / 16);
  // Up the positive imaginary axis.
  auto pos = [&](double u) { return cd(0.0, std::pow(10.0, u)); };
  for (int i = 0; i < pieces; ++i)
    track(pos, l_eps + (l_r - l_eps) * i / pieces, l_eps + (l_r - l_eps) * (i + 1) / pieces);
  // Large arc, clockwise from +j R to -j R.
  auto arc = [&](double th) { return big_r * cd(std::cos(th), std::sin(th)); };
  for (int i = 0; i < 16; ++i) track(arc, pi / 2 - pi * i / 16, pi / 2 - pi * (i + 1) / 16);
  // The contour is clockwise; Z - P = number of clockwise turns of f = -total/(2 pi).
  const int n_cw = int(std::lround(-total / (2.0 * pi)));
  return n_cw + open_loop_rhp_poles;
}

}  // namespace amctl::thermal
