#include "amctl/trajectory/sampling.hpp"

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::trajectory {

long seed000_full_steps(double dt, double h) {
  double x = dt / h;
  const double r = std::round(x);
  if (std::abs(x - r) <= 1e-9 * std::max(1.0, x)) x = r;
  const double n = std::ceil(x - 1.0);  // (3.7)
  return n < 0 ? 0L : static_cast<long>(n);
}

std::vector<AxisState> sample_uniform(const Trajectory& traj, double step_s, double t0,
                                      double t1) {
  require_positive("sample step_s", step_s);
  require_finite("t0_s", t0);
  require_finite("t1_s", t1);
  if (t1 < t0) {
    throw Error(fmt::format("empty time range: t1_s {} is before t0_s {}", t1, t0));
  }
  const auto n = static_cast<std::size_t>(std::floor((t1 - t0) / step_s * (1.0 + 1e-12))) + 1;
  std::vector<AxisState> out;
  out.reserve(n);
  Cursor c = traj.cursor();
  for (std::size_t k = 0; k < n; ++k) out.push_back(c.evaluate(t0 + static_cast<double>(k) * step_s));
  return out;
}

std::vector<PathSample> sample_seed000(std::span<const plan::PlannedMove> moves, double h) {
  require_positive("interpolation step_s", h);
  std::vector<PathSample> out;
  if (moves.empty()) return out;
  PathSample cur;
  cur.t_s = moves[0].start_time_s;
  cur.pos_mm = moves[0].start_mm;
  cur.line = moves[0].line;
  out.push_back(cur);
  std::array<plan::PathPiece, 7> pieces;
  for (std::size_t mi = 0; mi < moves.size(); ++mi) {
    const plan::PlannedMove& m = moves[mi];
    // A dwell before the move is a phase of zero speed.
    const double gap = m.start_time_s - cur.t_s;
    if (gap > 1e-12) {
      const long n = seed000_full_steps(gap, h);
      for (long k = 0; k <= n; ++k) {
        cur.t_s += k < n ? h : gap - h * static_cast<double>(n);
        out.push_back(cur);
      }
    }
    cur.pos_mm = m.start_mm;  // position accumulation restarts at each G-code target
    cur.line = m.line;
    const std::size_t np = move_pieces(m, pieces);
    for (std::size_t pi = 0; pi < np; ++pi) {
      const plan::PathPiece& p = pieces[pi];
      const long n = seed000_full_steps(p.duration_s, h);  // (3.7)
      const double last = p.duration_s - h * static_cast<double>(n);  // (3.8)
      double v = p.c[1];
      const double a = 2.0 * p.c[2];
      double tau = 0.0;
      for (long k = 0; k <= n; ++k) {
        const double dt = k < n ? h : last;
        double ds;
        if (p.degree <= 2) {
          ds = v * dt + 0.5 * a * dt * dt;  // (3.9)
          v += a * dt;                      // (3.10) accumulated speed
        } else {
          ds = evaluate_piece(p, tau + dt).s_mm - evaluate_piece(p, tau).s_mm;
          v = evaluate_piece(p, tau + dt).v_mm_s;
        }
        tau += dt;
        cur.t_s += dt;
        for (std::size_t i = 0; i < kAxes; ++i) cur.pos_mm[i] += m.axes_r[i] * ds;  // (3.10)
        cur.speed_mm_s = v;
        out.push_back(cur);
      }
    }
  }
  return out;
}

}  // namespace amctl::trajectory
