#pragma once
// Internal to the steppers module: root finding on a move's polynomial pieces.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>

#include "amctl/plan/planned_move.hpp"

namespace amctl::steppers::detail {

/// s(tau) of a piece and its derivative, by Horner.
inline double horner(const plan::PathPiece& p, double tau, double& deriv) {
  double d0 = 0.0, d1 = 0.0;
  for (int k = p.degree; k >= 0; --k) {
    d1 = d1 * tau + d0;
    d0 = d0 * tau + p.c[static_cast<std::size_t>(k)];
  }
  deriv = d1;
  return d0;
}

/// Path distance at the end of the move made of `count` pieces.
inline double end_distance(const std::array<plan::PathPiece, 7>& pieces, std::size_t count) {
  if (count == 0) return 0.0;
  double dummy = 0.0;
  return horner(pieces[count - 1], pieces[count - 1].duration_s, dummy);
}

/// Maps path distances, visited in increasing order, to times over a move's pieces.
class PieceCursor {
 public:
  PieceCursor(const std::array<plan::PathPiece, 7>& pieces, std::size_t count, double t0);
  double time_at(double s_target);

 private:
  const std::array<plan::PathPiece, 7>& pieces_;
  std::size_t count_;
  std::size_t i_ = 0;
  double t0_;
  double end_s_ = 0.0;
  double lo_ = 0.0;
};

/// The steps of a motor whose position q(s) (s: path distance) is monotone on each interval
/// of `bounds`: the levels n +- 1/2 crossed on each, as for a linear motor, each crossing
/// found by safeguarded Newton on g(s) = dir (q(s) - level) with `slope` = q'. St is the
/// generator's per-motor state (origin_mm, n); emit(t, dir) records the step and moves st.n.
template <class St, class Q, class Slope, class Emit>
void step_monotone_intervals(St& st, std::span<const double> bounds, const Q& q,
                             const Slope& slope, double offset, double step, double s_end,
                             PieceCursor& cursor, const Emit& emit) {
  constexpr int kMaxIterations = 200;
  for (std::size_t seg = 0; seg + 1 < bounds.size(); ++seg) {
    const double sa = bounds[seg], sb = bounds[seg + 1];
    const double u_end = (q(sb) + offset - st.origin_mm) / step;
    std::int64_t n_end = st.n;
    const double up = std::floor(u_end + 0.5), down = std::ceil(u_end - 0.5);
    if (static_cast<double>(st.n) < up) n_end = static_cast<std::int64_t>(up);
    else if (static_cast<double>(st.n) > down) n_end = static_cast<std::int64_t>(down);
    if (n_end == st.n) continue;
    const int dir = n_end > st.n ? 1 : -1;
    double lo = sa;
    while (st.n != n_end) {
      const double level = st.origin_mm + (static_cast<double>(st.n) + 0.5 * dir) * step - offset;
      double a = lo, b = sb, sv = lo;
      if (dir * (q(a) - level) < 0.0) {
        for (int it = 0; it < kMaxIterations; ++it) {
          const double g = dir * (q(sv) - level);
          if (g == 0.0) break;
          (g < 0.0 ? a : b) = sv;
          const double d = dir * slope(sv);
          double next = d > 0.0 ? sv - g / d : 0.5 * (a + b);
          if (!(next > a && next < b)) next = 0.5 * (a + b);
          if (std::abs(next - sv) <= 1e-14 * (1.0 + s_end) || b - a <= 1e-13 * (1.0 + s_end)) {
            sv = next;
            break;
          }
          sv = next;
        }
        sv = std::clamp(sv, lo, sb);
      }
      lo = sv;
      emit(std::max(cursor.time_at(sv), st.last_step_s), dir);
    }
  }
}

}  // namespace amctl::steppers::detail
