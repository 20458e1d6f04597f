#pragma once
// Test helper (shaped_steps_test.cpp, tuned_steps_test.cpp): pressure advance's extruder
// position by quadrature, the second method the step generator's closed-form smoothing is
// checked against. E(t) = (1 / h^2) integral (h - |x - t|) (e(x) + pa v_e(x)) dx over
// [t - h, t + h], pa applied on the moves that extrude while moving in X or Y (Klipper's rule),
// each stretch between the plan's piece breaks integrated by 5-point Gauss-Legendre (exact
// for the plan's polynomial degrees), the plan read through trajectory::Trajectory.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include "amctl/plan/planned_move.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::steppers::test {

/// E(t) with half smoothing time h (0: e(t) itself); `moves` give the breaks and, through
/// advance_of(j), the pressure advance of move j [s].
template <class AdvanceOf>
double extruder_by_quadrature(const trajectory::Trajectory& traj,
                              std::span<const plan::PlannedMove> moves,
                              const AdvanceOf& advance_of, double h, double t) {
  if (h == 0.0) return traj.evaluate(t).pos_mm[3];
  std::vector<double> br{t - h, t, t + h};
  std::array<plan::PathPiece, 7> pieces{};
  for (const plan::PlannedMove& mv : moves) {
    if (mv.end_time_s() < t - h || mv.start_time_s > t + h) continue;
    double at = mv.start_time_s;
    br.push_back(at);
    const std::size_t n = trajectory::move_pieces(mv, pieces);
    for (std::size_t i = 0; i < n; ++i) br.push_back(at += pieces[i].duration_s);
  }
  std::sort(br.begin(), br.end());
  const double x5[] = {0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                       0.9061798459386640};
  const double w5[] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                       0.2369268850561891, 0.2369268850561891};
  double sum = 0.0;
  for (std::size_t i = 0; i + 1 < br.size(); ++i) {
    const double a = std::max(br[i], t - h), b = std::min(br[i + 1], t + h);
    if (!(b > a)) continue;
    const double mid = 0.5 * (a + b);
    double pa = 0.0;
    for (std::size_t j = 0; j < moves.size(); ++j) {
      const plan::PlannedMove& mv = moves[j];
      if (mv.start_time_s <= mid && mid < mv.end_time_s()) {
        const bool advance = !mv.extrude_only && mv.axes_r[3] > 0.0 &&
                             (mv.axes_r[0] != 0.0 || mv.axes_r[1] != 0.0);
        pa = advance ? advance_of(j) : 0.0;
      }
    }
    for (int k = 0; k < 5; ++k) {
      const double x = mid + 0.5 * (b - a) * x5[k];
      const trajectory::AxisState st = traj.evaluate(x);
      sum += 0.5 * (b - a) * w5[k] * (h - std::abs(x - t)) * (st.pos_mm[3] + pa * st.vel_mm_s[3]);
    }
  }
  return sum / (h * h);
}

}  // namespace amctl::steppers::test
