#include "amctl/dynamics/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace amctl::dynamics {

namespace {

struct Seg {
  double ax, ay, bx, by, len;
};

Seg xy_segment(const plan::PlannedMove& m) {
  const double ax = m.start_mm[0], ay = m.start_mm[1];
  const double bx = ax + m.axes_r[0] * m.distance_mm, by = ay + m.axes_r[1] * m.distance_mm;
  return {ax, ay, bx, by, std::sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay))};
}

double point_segment_distance2(const Seg& s, double x, double y) {
  const double dx = s.bx - s.ax, dy = s.by - s.ay;
  const double l2 = dx * dx + dy * dy;
  double u = 0.0;
  if (l2 > 0.0) u = std::clamp(((x - s.ax) * dx + (y - s.ay) * dy) / l2, 0.0, 1.0);
  const double ex = x - (s.ax + u * dx), ey = y - (s.ay + u * dy);
  return ex * ex + ey * ey;  // squared
}

void accumulate(GroupMetrics& g, const MoveMetrics& m) {
  g.max_contour_error_mm = std::max(g.max_contour_error_mm, m.max_contour_error_mm);
  // rms_contour_error_mm holds the running sum of squares until finalise().
  g.rms_contour_error_mm += m.sum_sq_contour_error_mm2;
  g.samples += m.samples;
}

void finalise(GroupMetrics& g) {
  g.rms_contour_error_mm = g.samples ? std::sqrt(g.rms_contour_error_mm / static_cast<double>(g.samples)) : 0.0;
}

}  // namespace

double distance_to_path(std::span<const plan::PlannedMove> moves, std::size_t center, double x,
                        double y, double radius) {
  if (moves.empty()) return 0.0;
  center = std::min(center, moves.size() - 1);
  Seg s = xy_segment(moves[center]);
  double best = point_segment_distance2(s, x, y);
  constexpr std::size_t kMaxMoves = 64;
  double along = 0.0;
  for (std::size_t k = 1; k <= kMaxMoves && k <= center; ++k) {
    const Seg sk = xy_segment(moves[center - k]);
    best = std::min(best, point_segment_distance2(sk, x, y));
    along += sk.len;
    if (along > radius) break;
  }
  along = 0.0;
  for (std::size_t k = 1; k <= kMaxMoves && center + k < moves.size(); ++k) {
    const Seg sk = xy_segment(moves[center + k]);
    best = std::min(best, point_segment_distance2(sk, x, y));
    along += sk.len;
    if (along > radius) break;
  }
  return std::sqrt(best);
}

QualityMeter::QualityMeter(std::span<const plan::PlannedMove> moves, MetricsOptions options)
    : moves_(moves), opt_(options) {
  const std::size_t n = moves.size();
  rep_.per_move.resize(n);
  corner_angle_.assign(n, -1.0);
  next_xy_.assign(n, n);
  std::size_t next = n;
  for (std::size_t i = n; i-- > 0;) {
    next_xy_[i] = next;
    const Seg si = xy_segment(moves[i]);
    if (si.len > 1e-9) {
      if (next < n) {
        const Seg sj = xy_segment(moves[next]);
        const double c = ((si.bx - si.ax) * (sj.bx - sj.ax) + (si.by - si.ay) * (sj.by - sj.ay)) /
                         (si.len * sj.len);
        const double ang = std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / std::numbers::pi;
        if (ang > opt_.corner_angle_deg) corner_angle_[i] = ang;
      }
      next = i;
    }
  }
  if (n > 0) {
    double end = moves.front().start_time_s;
    for (const auto& m : moves) end = std::max(end, m.end_time_s());
    rep_.motion_time_s = end - moves.front().start_time_s;
  }
  ring_.reserve(1024);
}

void QualityMeter::close_corner() {
  if (!corner_open_) return;
  corner_open_ = false;
  // Local maxima of the deviation across the outgoing wall.
  std::vector<std::size_t> maxima;
  for (std::size_t k = 1; k + 1 < ring_.size(); ++k) {
    if (ring_[k].dev_mm > ring_[k - 1].dev_mm && ring_[k].dev_mm >= ring_[k + 1].dev_mm) {
      maxima.push_back(k);
    }
  }
  if (maxima.size() >= 2) {
    const std::size_t a = maxima[0], b = maxima[1];
    double lo = ring_[a].dev_mm;
    for (std::size_t k = a; k <= b; ++k) lo = std::min(lo, ring_[k].dev_mm);
    const double amp = 0.5 * (ring_[a].dev_mm - lo);
    if (amp > 1e-6) {
      corner_res_.ringing_amplitude_mm = amp;
      corner_res_.ringing_wavelength_mm = ring_[b].sigma_mm - ring_[a].sigma_mm;
      corner_res_.ringing_period_s = ring_[b].t_s - ring_[a].t_s;
    }
  }
  rep_.corners.push_back(corner_res_);
  ring_.clear();
}

double QualityMeter::add(const SimSample& s) {
  if (s.t_s < opt_.t_begin_s || s.t_s > opt_.t_end_s || moves_.empty()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  ++rep_.samples;
  const std::size_t mi = std::min(s.move_index, moves_.size() - 1);
  const double lx = s.sim_mm[0] - s.cmd_mm[0], ly = s.sim_mm[1] - s.cmd_mm[1];
  const double lag = std::sqrt(lx * lx + ly * ly);
  const double d = distance_to_path(moves_, mi, s.sim_mm[0], s.sim_mm[1], 2.0 * lag + 0.05);
  MoveMetrics& mm = rep_.per_move[mi];
  if (d > mm.max_contour_error_mm || mm.samples == 0) {
    mm.max_contour_error_mm = std::max(mm.max_contour_error_mm, d);
    if (d >= mm.max_contour_error_mm) {
      mm.worst_t_s = s.t_s;
      mm.worst_x_mm = s.sim_mm[0];
      mm.worst_y_mm = s.sim_mm[1];
    }
  }
  mm.sum_sq_contour_error_mm2 += d * d;
  ++mm.samples;
  rep_.max_contour_error_mm = std::max(rep_.max_contour_error_mm, d);
  sum_sq_ += d * d;
  if (!s.holding && moves_[mi].is_extruding()) {
    rep_.max_contour_error_printing_mm = std::max(rep_.max_contour_error_printing_mm, d);
    sum_sq_print_ += d * d;
    ++n_print_;
  }
  const double vib = std::hypot(s.vibration_mm[0], s.vibration_mm[1]);
  last_vib_ = vib;

  // Moves that ended by now: residual vibration, and open the corner window they end in.
  while (next_end_ < moves_.size() && s.t_s >= moves_[next_end_].end_time_s() - 1e-12) {
    const std::size_t i = next_end_++;
    if (!exact_ends_) {
      rep_.per_move[i].residual_vibration_mm = vib;
      rep_.max_residual_vibration_mm = std::max(rep_.max_residual_vibration_mm, vib);
      if (i + 1 == moves_.size()) rep_.final_residual_vibration_mm = vib;
    }
    if (corner_angle_[i] >= 0.0) {
      close_corner();
      const Seg si = xy_segment(moves_[i]);
      const Seg sj = xy_segment(moves_[next_xy_[i]]);
      corner_ = Corner{};
      corner_.angle_deg = corner_angle_[i];
      corner_.p[0] = si.bx;
      corner_.p[1] = si.by;
      corner_.din[0] = (si.bx - si.ax) / si.len;
      corner_.din[1] = (si.by - si.ay) / si.len;
      corner_.dout[0] = (sj.bx - sj.ax) / sj.len;
      corner_.dout[1] = (sj.by - sj.ay) / sj.len;
      corner_res_ = CornerResult{};
      corner_res_.move_index = i;
      corner_res_.line = moves_[i].line;
      corner_res_.angle_deg = corner_angle_[i];
      corner_res_.junction_speed_mm_s = moves_[i].end_v_mm_s;
      corner_open_ = true;
      corner_move_ = i;
      corner_t0_ = moves_[i].end_time_s();
    }
  }
  if (corner_open_ && s.t_s > corner_t0_ + opt_.corner_window_s) close_corner();
  if (corner_open_) {
    const double sx = s.sim_mm[0] - corner_.p[0], sy = s.sim_mm[1] - corner_.p[1];
    const double cx = s.cmd_mm[0] - corner_.p[0], cy = s.cmd_mm[1] - corner_.p[1];
    const double past = sx * corner_.din[0] + sy * corner_.din[1];
    const double cmd_past = std::max(0.0, cx * corner_.din[0] + cy * corner_.din[1]);
    corner_res_.overshoot_mm = std::max(corner_res_.overshoot_mm, past - cmd_past);
    rep_.max_corner_overshoot_mm = std::max(rep_.max_corner_overshoot_mm, past - cmd_past);
    const double nx = -corner_.dout[1], ny = corner_.dout[0];
    ring_.push_back(RingSample{cx * corner_.dout[0] + cy * corner_.dout[1], s.t_s,
                               (sx - cx) * nx + (sy - cy) * ny});
  }
  return d;
}

void QualityMeter::on_move_end(std::size_t i, double t_s, const std::array<double, 2>& v) {
  if (i >= moves_.size() || t_s < opt_.t_begin_s || t_s > opt_.t_end_s) return;
  exact_ends_ = true;
  const double vib = std::hypot(v[0], v[1]);
  rep_.per_move[i].residual_vibration_mm = vib;
  rep_.max_residual_vibration_mm = std::max(rep_.max_residual_vibration_mm, vib);
  if (i + 1 == moves_.size()) rep_.final_residual_vibration_mm = vib;
}

QualityReport QualityMeter::finish() {
  close_corner();
  rep_.rms_contour_error_mm = rep_.samples ? std::sqrt(sum_sq_ / static_cast<double>(rep_.samples)) : 0.0;
  rep_.rms_contour_error_printing_mm = n_print_ ? std::sqrt(sum_sq_print_ / static_cast<double>(n_print_)) : 0.0;
  for (std::size_t i = 0; i < moves_.size(); ++i) {
    const MoveMetrics& m = rep_.per_move[i];
    if (m.samples == 0) continue;
    accumulate(rep_.per_layer[moves_[i].layer], m);
    accumulate(rep_.per_feature[moves_[i].feature], m);
  }
  for (auto& [k, g] : rep_.per_layer) finalise(g);
  for (auto& [k, g] : rep_.per_feature) finalise(g);
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < moves_.size(); ++i) {
    if (rep_.per_move[i].samples > 0) idx.push_back(i);
  }
  const std::size_t k = std::min(opt_.worst_count, idx.size());
  std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(k), idx.end(),
                    [&](std::size_t a, std::size_t b) {
                      return rep_.per_move[a].max_contour_error_mm > rep_.per_move[b].max_contour_error_mm;
                    });
  for (std::size_t i = 0; i < k; ++i) {
    const std::size_t mi = idx[i];
    const MoveMetrics& m = rep_.per_move[mi];
    rep_.worst.push_back(WorstPlace{moves_[mi].line, mi, moves_[mi].layer, moves_[mi].feature,
                                    m.worst_t_s, m.worst_x_mm, m.worst_y_mm,
                                    m.max_contour_error_mm});
  }
  std::vector<double> wl;
  for (const CornerResult& c : rep_.corners) {
    if (std::isfinite(c.ringing_wavelength_mm)) wl.push_back(c.ringing_wavelength_mm);
    rep_.ringing_amplitude_mm = std::max(rep_.ringing_amplitude_mm, c.ringing_amplitude_mm);
  }
  if (!wl.empty()) {
    std::nth_element(wl.begin(), wl.begin() + static_cast<std::ptrdiff_t>(wl.size() / 2), wl.end());
    rep_.ringing_wavelength_mm = wl[wl.size() / 2];
  }
  if (rep_.final_residual_vibration_mm == 0.0) rep_.final_residual_vibration_mm = last_vib_;
  return std::move(rep_);
}

}  // namespace amctl::dynamics
