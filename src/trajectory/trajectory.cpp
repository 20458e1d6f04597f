#include "amctl/trajectory/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::trajectory {

using plan::PathPiece;
using plan::PlannedMove;

plan::PathState evaluate_piece(const PathPiece& p, double tau) {
  // Horner with derivatives: d0 = P, d1 = P', d2 = P''/2, d3 = P'''/6.
  double d0 = 0, d1 = 0, d2 = 0, d3 = 0;
  for (int k = p.degree; k >= 0; --k) {
    d3 = d3 * tau + d2;
    d2 = d2 * tau + d1;
    d1 = d1 * tau + d0;
    d0 = d0 * tau + p.c[static_cast<std::size_t>(k)];
  }
  return plan::PathState{d0, d1, 2.0 * d2, 6.0 * d3};
}

namespace {

void check_duration(const PlannedMove& m, const char* what, double stored, double rebuilt) {
  if (std::abs(stored - rebuilt) > 1e-9 * (1.0 + std::abs(rebuilt))) {
    throw Error(SourceLocation{"", m.line, 0},
                fmt::format("planned move: {} is {} s but its speeds and limits give {} s",
                            what, stored, rebuilt));
  }
}

// Appends the pieces of the ramp v0 -> v1 (or nothing when the speeds are equal).
std::size_t append_ramp(const PlannedMove& m, double v0, double v1, double s0,
                        std::array<PathPiece, 7>& out, std::size_t n, double stored_t,
                        const char* what) {
  // A speed change within round-off of the speeds (planners leave ~1e-13 mm/s steps) is
  // no ramp: its duration is ~1e-16 s, and a Bezier ramp that short would have jerk ~1e20.
  // It becomes a constant-speed piece of the stored duration at the mean speed.
  if (std::abs(v1 - v0) <= 1e-9 * std::max({1.0, v0, v1})) {
    if (stored_t > 1e-6) check_duration(m, what, stored_t, 0.0);
    if (stored_t > 0.0) {
      PathPiece c;
      c.duration_s = stored_t;
      c.degree = 1;
      c.c[0] = s0;
      c.c[1] = 0.5 * (v0 + v1);
      out[n++] = c;
    }
    return n;
  }
  const plan::Ramp r = plan::make_ramp(m.profile, v0, v1, m.accel_mm_s2, m.jerk_mm_s3);
  check_duration(m, what, stored_t, r.duration_s);
  std::array<PathPiece, 3> tmp;
  const std::size_t k = plan::ramp_pieces(r, s0, tmp);
  for (std::size_t i = 0; i < k; ++i) out[n++] = tmp[i];
  return n;
}

double piece_end_s(const PathPiece& p) { return evaluate_piece(p, p.duration_s).s_mm; }

}  // namespace

std::size_t move_pieces(const PlannedMove& m, std::array<PathPiece, 7>& out) {
  std::size_t n = append_ramp(m, m.start_v_mm_s, m.cruise_v_mm_s, 0.0, out, 0, m.accel_t_s,
                              "accel_t_s");
  double s = n > 0 ? piece_end_s(out[n - 1]) : 0.0;
  if (m.cruise_t_s > 0.0) {
    PathPiece c;
    c.duration_s = m.cruise_t_s;
    c.degree = 1;
    c.c[0] = s;
    c.c[1] = m.cruise_v_mm_s;
    out[n++] = c;
    s += m.cruise_v_mm_s * m.cruise_t_s;
  }
  n = append_ramp(m, m.cruise_v_mm_s, m.end_v_mm_s, s, out, n, m.decel_t_s, "decel_t_s");
  return n;
}

// ---------------------------------------------------------------------------------------
Cursor::Cursor(std::span<const PlannedMove> moves) : moves_(moves) {
  hold_.duration_s = std::numeric_limits<double>::infinity();
  hold_.degree = 0;
}

void Cursor::load_move(std::size_t i) {
  if (loaded_move_ == i) return;
  piece_count_ = move_pieces(moves_[i], pieces_);
  loaded_move_ = i;
  piece_i_ = 0;
  piece_start_ = moves_[i].start_time_s;
}

const Cursor::Location& Cursor::locate(double t) {
  if (moves_.empty()) {
    hold_.c[0] = 0.0;
    loc_ = Location{0, &hold_, -std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity(), true};
    return loc_;
  }
  if (t < last_t_) {  // not monotone: restart from the beginning
    next_move_ = 0;
    loaded_move_ = static_cast<std::size_t>(-1);
    loc_valid_ = false;
  } else if (loc_valid_ && t < loc_.piece_end_s) {
    last_t_ = t;
    return loc_;  // still inside the piece found last time
  }
  last_t_ = t;
  loc_valid_ = true;
  while (next_move_ < moves_.size() && moves_[next_move_].start_time_s <= t) ++next_move_;
  const double inf = std::numeric_limits<double>::infinity();
  if (next_move_ == 0) {  // before the first move: hold at its start
    hold_.c[0] = 0.0;
    loc_ = Location{0, &hold_, -inf, moves_[0].start_time_s, true};
    return loc_;
  }
  const std::size_t m = next_move_ - 1;
  load_move(m);
  // Advance within the move (pieces are visited in order for monotone t).
  double start = piece_start_;
  while (piece_i_ < piece_count_ && t >= start + pieces_[piece_i_].duration_s) {
    start += pieces_[piece_i_].duration_s;
    ++piece_i_;
  }
  piece_start_ = start;
  const double next_start = next_move_ < moves_.size() ? moves_[next_move_].start_time_s : inf;
  if (piece_i_ < piece_count_) {
    const double end = std::min(start + pieces_[piece_i_].duration_s, next_start);
    loc_ = Location{m, &pieces_[piece_i_], start, end, false};
    return loc_;
  }
  // Past the last piece: hold at the end of the move until the next one starts.
  hold_.c[0] = piece_count_ > 0 ? piece_end_s(pieces_[piece_count_ - 1]) : 0.0;
  loc_ = Location{m, &hold_, start, next_start, true};
  return loc_;
}

AxisState Cursor::evaluate(double t) {
  const Location& l = locate(t);
  AxisState s;
  s.t_s = t;
  const PlannedMove& m = moves_.empty() ? PlannedMove{} : moves_[l.move_index];
  const plan::PathState ps = l.holding ? plan::PathState{l.piece->c[0], 0, 0, 0}
                                       : evaluate_piece(*l.piece, t - l.piece_t0_s);
  for (std::size_t i = 0; i < kAxes; ++i) {
    s.pos_mm[i] = m.start_mm[i] + m.axes_r[i] * ps.s_mm;
    s.vel_mm_s[i] = m.axes_r[i] * ps.v_mm_s;
    s.acc_mm_s2[i] = m.axes_r[i] * ps.a_mm_s2;
    s.jerk_mm_s3[i] = m.axes_r[i] * ps.j_mm_s3;
  }
  return s;
}

void Cursor::path_derivatives(double t, std::array<double, plan::kMaxPieceDegree + 1>& d) {
  path_derivatives(locate(t), t, d);
}

void Cursor::path_derivatives(const Location& l, double t,
                              std::array<double, plan::kMaxPieceDegree + 1>& d) {
  d.fill(0.0);
  if (l.holding) {
    d[0] = l.piece->c[0];
    return;
  }
  const PathPiece& p = *l.piece;
  const double tau = t - l.piece_t0_s;
  if (p.degree <= 3) {  // trapezoid, cruise and scurve7 pieces: direct form
    const double c1 = p.c[1], c2 = p.c[2], c3 = p.degree == 3 ? p.c[3] : 0.0;
    d[0] = p.c[0] + tau * (c1 + tau * (c2 + tau * c3));
    d[1] = c1 + tau * (2.0 * c2 + tau * 3.0 * c3);
    d[2] = 2.0 * c2 + 6.0 * c3 * tau;
    d[3] = 6.0 * c3;
    return;
  }
  // d[k] = sum_{m >= k} c_m m!/(m-k)! tau^(m-k)  (Taylor shift by repeated synthetic division)
  std::array<double, plan::kMaxPieceDegree + 1> c = p.c;
  const int n = p.degree;
  for (int k = 0; k <= n; ++k) {
    for (int m = n - 1; m >= k; --m) c[static_cast<std::size_t>(m)] += tau * c[static_cast<std::size_t>(m + 1)];
  }
  double fact = 1.0;
  for (int k = 0; k <= n; ++k) {
    if (k > 0) fact *= k;
    d[static_cast<std::size_t>(k)] = c[static_cast<std::size_t>(k)] * fact;
  }
}

// ---------------------------------------------------------------------------------------
Trajectory::Trajectory(std::vector<PlannedMove> moves) : moves_(std::move(moves)) {
  for (std::size_t i = 1; i < moves_.size(); ++i) {
    if (moves_[i].start_time_s < moves_[i - 1].start_time_s) {
      throw Error(SourceLocation{"", moves_[i].line, 0},
                  fmt::format("planned moves must be time-ordered: move {} starts at {} s, "
                              "before move {} at {} s",
                              i, moves_[i].start_time_s, i - 1, moves_[i - 1].start_time_s));
    }
  }
}

double Trajectory::start_time_s() const {
  return moves_.empty() ? 0.0 : moves_.front().start_time_s;
}
double Trajectory::end_time_s() const {
  double e = 0.0;
  for (auto it = moves_.rbegin(); it != moves_.rend(); ++it) {
    e = std::max(e, it->end_time_s());
    break;
  }
  return e;
}

AxisState Trajectory::evaluate(double t) const {
  auto it = std::upper_bound(moves_.begin(), moves_.end(), t,
                             [](double tt, const PlannedMove& m) { return tt < m.start_time_s; });
  std::size_t first = it == moves_.begin() ? 0 : static_cast<std::size_t>(it - moves_.begin()) - 1;
  Cursor c(std::span<const PlannedMove>(moves_).subspan(first));
  return c.evaluate(t);
}

}  // namespace amctl::trajectory
