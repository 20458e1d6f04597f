#pragma once
// Test-only reference integrator: Dormand-Prince 5(4) with adaptive steps, integrating the
// seed 000 (3.11) ODE in physical coordinates between the plan's piece boundaries, with the
// exact commanded position and velocity as input. Independent of the modal/matrix-exponential
// code under test.
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <vector>

#include "amctl/trajectory/trajectory.hpp"

namespace amctl::testing {

using State4 = std::array<double, 4>;  // x, x', y, y'

inline State4 axpy(const State4& a, double s, const State4& b) {
  State4 r;
  for (int i = 0; i < 4; ++i) r[i] = a[i] + s * b[i];
  return r;
}

/// Integrates from t0 to t1 (input smooth on (t0, t1)), rtol/atol per step.
template <class F>
State4 dopri5(const F& f, double t0, double t1, State4 x, double rtol = 1e-12, double atol = 1e-14) {
  static constexpr double c2 = 1. / 5, c3 = 3. / 10, c4 = 4. / 5, c5 = 8. / 9;
  static constexpr double a21 = 1. / 5, a31 = 3. / 40, a32 = 9. / 40, a41 = 44. / 45,
                          a42 = -56. / 15, a43 = 32. / 9, a51 = 19372. / 6561,
                          a52 = -25360. / 2187, a53 = 64448. / 6561, a54 = -212. / 729,
                          a61 = 9017. / 3168, a62 = -355. / 33, a63 = 46732. / 5247,
                          a64 = 49. / 176, a65 = -5103. / 18656, a71 = 35. / 384,
                          a73 = 500. / 1113, a74 = 125. / 192, a75 = -2187. / 6784,
                          a76 = 11. / 84;
  static constexpr double e1 = 71. / 57600, e3 = -71. / 16695, e4 = 71. / 1920,
                          e5 = -17253. / 339200, e6 = 22. / 525, e7 = -1. / 40;
  double t = t0, h = std::min(1e-4, t1 - t0);
  while (t < t1) {
    if (t + h > t1) h = t1 - t;
    const State4 k1 = f(t, x);
    State4 y;
    for (int i = 0; i < 4; ++i) y[i] = x[i] + h * a21 * k1[i];
    const State4 k2 = f(t + c2 * h, y);
    for (int i = 0; i < 4; ++i) y[i] = x[i] + h * (a31 * k1[i] + a32 * k2[i]);
    const State4 k3 = f(t + c3 * h, y);
    for (int i = 0; i < 4; ++i) y[i] = x[i] + h * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i]);
    const State4 k4 = f(t + c4 * h, y);
    for (int i = 0; i < 4; ++i)
      y[i] = x[i] + h * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
    const State4 k5 = f(t + c5 * h, y);
    for (int i = 0; i < 4; ++i)
      y[i] = x[i] + h * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i]);
    const State4 k6 = f(t + h, y);
    State4 xn;
    for (int i = 0; i < 4; ++i)
      xn[i] = x[i] + h * (a71 * k1[i] + a73 * k3[i] + a74 * k4[i] + a75 * k5[i] + a76 * k6[i]);
    const State4 k7 = f(t + h, xn);
    double err = 0.0;
    for (int i = 0; i < 4; ++i) {
      const double ei = h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * k7[i]);
      const double sc = atol + rtol * std::max(std::abs(x[i]), std::abs(xn[i]));
      err = std::max(err, std::abs(ei) / sc);
    }
    if (err <= 1.0) {
      t += h;
      x = xn;
    }
    h *= std::clamp(0.9 * std::pow(std::max(err, 1e-10), -0.2), 0.2, 5.0);
  }
  return x;
}

/// Reference response of seed 000 (3.11) with (w, z) on both axes, at the given times.
inline std::vector<State4> reference_response(const std::vector<plan::PlannedMove>& moves,
                                              double w, double z,
                                              const std::vector<double>& times) {
  const trajectory::Trajectory tr(moves);
  // Breakpoints: every piece boundary of every move.
  std::vector<double> bp;
  for (const auto& m : moves) {
    std::array<plan::PathPiece, 7> pieces;
    const std::size_t n = trajectory::move_pieces(m, pieces);
    double t = m.start_time_s;
    bp.push_back(t);
    for (std::size_t i = 0; i < n; ++i) bp.push_back(t += pieces[i].duration_s);
  }
  // Input is evaluated at the midpoint's side of each interval: use the piece covering (a, b).
  double lo = 0, hi = 0;
  auto f = [&](double t, const State4& x) {
    const double eps = 4e-15 * std::max(1.0, std::abs(t));
    const double tt = std::clamp(t, lo + eps, hi - eps);
    const trajectory::AxisState s = tr.evaluate(tt);
    // exact input extrapolated from the interval's own piece: evaluate with clamped time and
    // a Taylor step for the remainder (it is at most 1e-15 s).
    return State4{x[1], -2 * z * w * (x[1] - s.vel_mm_s[0]) - w * w * (x[0] - s.pos_mm[0]),
                  x[3], -2 * z * w * (x[3] - s.vel_mm_s[1]) - w * w * (x[2] - s.pos_mm[1])};
  };
  const trajectory::AxisState s0 = tr.evaluate(moves.front().start_time_s);
  State4 x{s0.pos_mm[0], s0.vel_mm_s[0], s0.pos_mm[1], s0.vel_mm_s[1]};
  std::vector<double> all = bp;
  all.insert(all.end(), times.begin(), times.end());
  std::sort(all.begin(), all.end());
  std::vector<State4> out;
  // Second pass to collect at requested times (simple: re-run per requested time).
  for (double tq : times) {
    State4 y{s0.pos_mm[0], s0.vel_mm_s[0], s0.pos_mm[1], s0.vel_mm_s[1]};
    double tc = moves.front().start_time_s;
    for (double b : all) {
      const double e = std::min(b, tq);
      if (e > tc) {
        lo = tc;
        hi = e;
        y = dopri5(f, tc, e, y);
        tc = e;
      }
      if (tc >= tq) break;
    }
    out.push_back(y);
  }
  return out;
}

}  // namespace amctl::testing
