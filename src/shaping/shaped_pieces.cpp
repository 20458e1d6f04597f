// The shaped plan as per-axis polynomial pieces (shaped_pieces.hpp).
#include "amctl/shaping/shaped_pieces.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "amctl/core/error.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::shaping {

void taylor_shift(const double* c, int degree, double h, double* out) {
  for (int k = 0; k <= degree; ++k) out[k] = c[k];
  if (h == 0.0) return;
  // Repeated synthetic division by (tau - (-h)): O(degree^2), exact up to round-off.
  for (int i = 0; i < degree; ++i) {
    for (int j = degree - 1; j >= i; --j) out[j] += h * out[j + 1];
  }
}

ShapedPieceStream::ShapedPieceStream(const AxisShapers& shapers, const PressureAdvance& pa)
    : pa_(pa) {
  if (pa_.active()) half_smooth_s_ = 0.5 * pa_.smooth_time_s;
  const auto tap_at = [&](double delay) -> Tap& {
    for (Tap& t : taps_) {
      if (t.delay_s == delay) return t;
    }
    taps_.push_back(Tap{delay, {}, 0});
    return taps_.back();
  };
  for (std::size_t axis = 0; axis < 4; ++axis) {
    const Shaper* s = axis < 3 && shapers.xyz[axis] ? &*shapers.xyz[axis] : nullptr;
    if (s == nullptr) {
      // The extruder under pressure advance is integrated (smoothed_extruder), not tapped.
      if (!(axis == 3 && half_smooth_s_ > 0.0)) tap_at(0.0).weight[axis] += 1.0;
      continue;
    }
    const AppliedPulses p = applied_pulses(*s);
    for (std::size_t i = 0; i < p.weights.size(); ++i) {
      tap_at(p.delays_s[i]).weight[axis] += p.weights[i];
    }
  }
  if (half_smooth_s_ > 0.0) {
    // Taps of zero weight whose breaks bound the integral: at t - h, t and t + h.
    const auto index_of = [&](double delay) {
      tap_at(delay);
      for (std::size_t i = 0; i < taps_.size(); ++i) {
        if (taps_[i].delay_s == delay) return i;
      }
      return std::size_t{0};
    };
    tap_behind_ = index_of(half_smooth_s_);
    tap_now_ = index_of(0.0);
    tap_ahead_ = index_of(-half_smooth_s_);
  }
  for (const Tap& t : taps_) {
    max_delay_s_ = std::max(max_delay_s_, t.delay_s);
    min_delay_s_ = std::min(min_delay_s_, t.delay_s);
  }
}

void ShapedPieceStream::append_source(const Source& s) { sources_.push_back(s); }

void ShapedPieceStream::append_rest(double t0, double t1) {
  Source s;
  s.t0_s = t0;
  s.t1_s = t1;
  s.degree = 0;
  for (std::size_t a = 0; a < 4; ++a) s.c[a][0] = end_mm_[a];
  s.e_pa[0] = end_mm_[3];
  s.line = sources_.size() == head_ ? 0 : sources_.back().line;
  sources_.push_back(s);
}

void ShapedPieceStream::push(const plan::PlannedMove& move, std::vector<AxisPiece>& out) {
  const std::size_t count = trajectory::move_pieces(move, pieces_);
  if (!started_) {
    started_ = true;
    for (std::size_t a = 0; a < 4; ++a) end_mm_[a] = move.start_mm[a];
    const double span = max_delay_s_ - min_delay_s_;
    append_rest(move.start_time_s - span - 1.0, move.start_time_s);
    base_ = 0;
    for (Tap& t : taps_) t.index = 0;
    out_t_s_ = move.start_time_s + min_delay_s_;
  } else {
    for (std::size_t a = 0; a < 4; ++a) {
      const double p = move.start_mm[a] + offset_mm_[a];
      if (std::abs(p - end_mm_[a]) > 1e-9 * (1.0 + std::abs(end_mm_[a]))) {
        offset_mm_[a] += end_mm_[a] - p;
      }
    }
    const double last = sources_.back().t1_s;
    if (move.start_time_s > last) append_rest(last, move.start_time_s);
  }
  double t = std::max(move.start_time_s, sources_.back().t1_s);
  double s_end = 0.0;
  for (std::size_t j = 0; j < count; ++j) {
    const plan::PathPiece& p = pieces_[j];
    double s1 = 0.0;
    for (int k = p.degree; k >= 0; --k) s1 = s1 * p.duration_s + p.c[static_cast<std::size_t>(k)];
    s_end = s1;
    if (!(p.duration_s > 0.0)) continue;
    Source src;
    src.t0_s = t;
    src.t1_s = t + p.duration_s;
    src.degree = p.degree;
    src.line = static_cast<std::int64_t>(move.line);
    for (std::size_t a = 0; a < 4; ++a) {
      const double r = move.axes_r[a];
      src.c[a][0] = move.start_mm[a] + offset_mm_[a] + r * p.c[0];
      for (int k = 1; k <= p.degree; ++k) {
        src.c[a][static_cast<std::size_t>(k)] = r * p.c[static_cast<std::size_t>(k)];
      }
    }
    // Klipper applies pressure advance to moves that extrude while moving in X or Y.
    const bool advance = half_smooth_s_ > 0.0 && !move.extrude_only && move.axes_r[3] > 0.0 &&
                         (move.axes_r[0] != 0.0 || move.axes_r[1] != 0.0);
    src.e_pa = src.c[3];
    if (advance) {
      for (int k = 0; k < p.degree; ++k) {
        src.e_pa[static_cast<std::size_t>(k)] +=
            pa_.advance_s * (k + 1) * src.c[3][static_cast<std::size_t>(k + 1)];
      }
    }
    for (int k = 1; k <= p.degree; ++k) {
      if (src.e_pa[static_cast<std::size_t>(k)] != 0.0) src.e_degree = k;
    }
    append_source(src);
    t = src.t1_s;
  }
  for (std::size_t a = 0; a < 4; ++a) {
    end_mm_[a] = move.start_mm[a] + offset_mm_[a] + move.axes_r[a] * s_end;
  }
  generate(out, false);
}

void ShapedPieceStream::finish(std::vector<AxisPiece>& out) {
  if (!started_) return;
  append_rest(sources_.back().t1_s, std::numeric_limits<double>::infinity());
  generate(out, true);
}

void ShapedPieceStream::generate(std::vector<AxisPiece>& out, bool final) {
  const std::size_t end_index = base_ + (sources_.size() - head_);
  while (true) {
    double next = std::numeric_limits<double>::infinity();
    bool all_rest = true;
    for (Tap& tap : taps_) {
      while (source(tap.index).t1_s + tap.delay_s <= out_t_s_) {
        if (tap.index + 1 >= end_index) return;  // the next move decides what follows
        ++tap.index;
      }
      const Source& s = source(tap.index);
      if (std::isfinite(s.t1_s)) all_rest = false;
      next = std::min(next, s.t1_s + tap.delay_s);
    }
    if (final && all_rest) break;
    if (!std::isfinite(next)) break;
    if (next > out_t_s_) {
      AxisPiece& piece = out.emplace_back();  // built in place
      piece.t0_s = out_t_s_;
      piece.duration_s = next - out_t_s_;
      std::array<double, kAxisPieceCoeffs> shifted{};
      for (const Tap& tap : taps_) {
        const Source& s = source(tap.index);
        piece.line = std::max(piece.line, s.line);
        const double h = out_t_s_ - tap.delay_s - s.t0_s;
        piece.degree = std::max(piece.degree, s.degree);
        for (std::size_t a = 0; a < 4; ++a) {
          const double w = tap.weight[a];
          if (w == 0.0) continue;
          if (s.degree == 0) {
            piece.c[a][0] += w * s.c[a][0];
            continue;
          }
          if (s.degree == 2) {  // the trapezoid's pieces: taylor_shift's operations, inline
            const double* c = s.c[a].data();
            const double c1 = c[1] + h * c[2];
            piece.c[a][0] += w * (c[0] + h * c1);
            piece.c[a][1] += w * (c1 + h * c[2]);
            piece.c[a][2] += w * c[2];
            continue;
          }
          taylor_shift(s.c[a].data(), s.degree, h, shifted.data());
          for (int k = 0; k <= s.degree; ++k) {
            piece.c[a][static_cast<std::size_t>(k)] += w * shifted[static_cast<std::size_t>(k)];
          }
        }
      }
      if (half_smooth_s_ > 0.0) {
        int deg = 0;
        smoothed_extruder(out_t_s_, piece.c[3].data(), deg);
        piece.degree = std::max(piece.degree, deg);
      }
    }
    out_t_s_ = next;
    std::size_t lowest = end_index;
    for (const Tap& tap : taps_) lowest = std::min(lowest, tap.index);
    if (base_ < lowest) {
      head_ += lowest - base_;
      base_ = lowest;
      if (head_ >= 32 && 2 * head_ >= sources_.size()) {
        sources_.erase(sources_.begin(), sources_.begin() + static_cast<std::ptrdiff_t>(head_));
        head_ = 0;
      }
    }
  }
}

void ShapedPieceStream::smoothed_extruder(double u0, double* out, int& degree) {
  constexpr int N = kAxisPieceCoeffs;
  const double h = half_smooth_s_;
  const std::size_t iL = taps_[tap_behind_].index, iM = taps_[tap_now_].index,
                    iR = taps_[tap_ahead_].index;
  SmoothCache& cache = smooth_cache_;
  if (cache.valid && cache.iL == iL && cache.iM == iM && cache.iR == iR) {
    // The same polynomial in t: re-expanded about the new start.
    taylor_shift(cache.c.data(), cache.degree, u0 - cache.u0, out);
    for (int k = cache.degree + 1; k < N; ++k) out[k] = 0.0;
    degree = cache.degree;
    cache.u0 = u0;
    std::copy(out, out + N, cache.c.begin());
    return;
  }
  bool moving = false;
  for (std::size_t j = iL; j <= iR; ++j) moving = moving || source(j).e_degree > 0;
  for (int k = 0; k < N; ++k) out[k] = 0.0;
  degree = 0;
  if (!moving) {  // at rest over the whole window: the weights integrate to one
    out[0] = source(iM).e_pa[0];
    return;
  }
  std::array<double, N> P{}, Q0{}, Q1{}, tmp{}, D0{}, D1{};
  // Only the first qdeg + 1 coefficients of each array are written and read: every loop stops
  // at the degree at hand (the terms above it are zeros).
  // Q(l0 + l1 sigma) as a polynomial in sigma (l1 is 0 or 1), coefficients 0..qdeg.
  const auto at = [&](const std::array<double, N>& Q, int qdeg, double l0, double l1,
                      std::array<double, N>& r) {
    if (l1 == 0.0) {
      double v = 0.0;
      for (int k = qdeg; k >= 0; --k) v = v * l0 + Q[static_cast<std::size_t>(k)];
      for (int k = 1; k <= qdeg; ++k) r[static_cast<std::size_t>(k)] = 0.0;
      r[0] = v;
    } else {
      taylor_shift(Q.data(), qdeg, l0, r.data());
    }
  };
  // One half of the kernel over source j between the limits (a0 + a1 sigma, b0 + b1 sigma).
  const auto half = [&](const Source& s, double a0, double a1, double b0, double b1, bool left) {
    const int d = s.e_degree;
    const int m = std::min(d + 3, N);  // coefficients of this half's terms: degree d + 2
    taylor_shift(s.e_pa.data(), d, a0 - s.t0_s, P.data());  // y = x - a0
    Q0[0] = 0.0;
    Q1[0] = 0.0;
    Q1[1] = 0.0;
    for (int k = 0; k <= d; ++k) {
      Q0[static_cast<std::size_t>(k + 1)] = P[static_cast<std::size_t>(k)] / (k + 1);
      Q1[static_cast<std::size_t>(k + 2)] = P[static_cast<std::size_t>(k)] / (k + 2);
    }
    at(Q0, d + 1, b0 - a0, b1, D0);
    at(Q0, d + 1, 0.0, a1, tmp);
    for (int k = 0; k <= d + 1; ++k) D0[static_cast<std::size_t>(k)] -= tmp[static_cast<std::size_t>(k)];
    D0[static_cast<std::size_t>(d + 2)] = 0.0;
    at(Q1, d + 2, b0 - a0, b1, D1);
    at(Q1, d + 2, 0.0, a1, tmp);
    for (int k = 0; k < m; ++k) D1[static_cast<std::size_t>(k)] -= tmp[static_cast<std::size_t>(k)];
    // left: weight x - t + h = y + (cL - sigma); right: t + h - x = -y + (cR + sigma).
    const double sign = left ? 1.0 : -1.0;
    const double c = left ? a0 - u0 + h : u0 + h - a0;
    for (int k = 0; k < m; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      out[k] += sign * D1[kk] + c * D0[kk] - (k > 0 ? sign * D0[kk - 1] : 0.0);
    }
    degree = std::max(degree, d + 2);
  };
  for (std::size_t j = iL; j <= iR; ++j) {
    const Source& s = source(j);
    if (j <= iM) {
      const bool lo_t = j == iL, hi_t = j == iM;
      half(s, lo_t ? u0 - h : s.t0_s, lo_t ? 1.0 : 0.0, hi_t ? u0 : s.t1_s, hi_t ? 1.0 : 0.0, true);
    }
    if (j >= iM) {
      const bool lo_t = j == iM, hi_t = j == iR;
      half(s, lo_t ? u0 : s.t0_s, lo_t ? 1.0 : 0.0, hi_t ? u0 + h : s.t1_s, hi_t ? 1.0 : 0.0, false);
    }
  }
  const double inv = 1.0 / (h * h);
  for (int k = 0; k < N; ++k) out[k] *= inv;
  degree = std::min(degree, N - 1);
  cache.valid = true;
  cache.iL = iL;
  cache.iM = iM;
  cache.iR = iR;
  cache.u0 = u0;
  cache.degree = degree;
  std::copy(out, out + N, cache.c.begin());
}

}  // namespace amctl::shaping
