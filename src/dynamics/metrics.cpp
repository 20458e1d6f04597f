#include "amctl/dynamics/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "amctl/core/error.hpp"

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
  return distance_to_segments(
      [moves](std::size_t i) {
        const plan::PlannedMove& m = moves[i];
        const double ax = m.start_mm[0], ay = m.start_mm[1];
        return PathSegment{ax, ay, ax + m.axes_r[0] * m.distance_mm, ay + m.axes_r[1] * m.distance_mm};
      },
      moves.size(), center, x, y, radius);
}

QualityMeter::QualityMeter(MetricsOptions options) : opt_(options) { ring_.reserve(1024); }

QualityMeter::QualityMeter(std::span<const plan::PlannedMove> moves, MetricsOptions options)
    : QualityMeter(options) {
  set_window(moves, 0);
}

void QualityMeter::set_window(std::span<const plan::PlannedMove> window, std::size_t base) {
  win_ = window;
  base_ = base;
  if (window.empty()) return;
  if (!have_start_) {
    have_start_ = true;
    first_start_s_ = window.front().start_time_s;
    last_end_s_ = first_start_s_;
  }
  for (const auto& m : window) last_end_s_ = std::max(last_end_s_, m.end_time_s());
}

const plan::PlannedMove& QualityMeter::move(std::size_t g) const {
  AMCTL_CHECK(g >= base_ && g - base_ < win_.size(), "move index outside the metrics window");
  return win_[g - base_];
}

QualityMeter::OpenMove& QualityMeter::open(std::size_t g) {
  if (open_.empty()) open_base_ = std::max(open_base_, g);
  AMCTL_CHECK(g >= open_base_, "per-move record already folded");
  while (open_base_ + open_.size() <= g) {
    const std::size_t i = open_base_ + open_.size();
    OpenMove o;
    if (i >= base_ && i - base_ < win_.size()) {
      const plan::PlannedMove& m = win_[i - base_];
      o.line = m.line;
      o.layer = m.layer;
      o.feature = m.feature;
    }
    open_.push_back(o);
  }
  return open_[g - open_base_];
}

void QualityMeter::finalize_before(std::size_t g) {
  while (!open_.empty() && open_base_ < g) {
    const OpenMove& o = open_.front();
    const std::size_t i = open_base_;
    if (o.m.samples > 0) {
      accumulate(rep_.per_layer[o.layer], o.m);
      accumulate(rep_.per_feature[o.feature], o.m);
      const WorstPlace w{o.line, i, o.layer, o.feature, o.m.worst_t_s, o.m.worst_x_mm,
                         o.m.worst_y_mm, o.m.max_contour_error_mm};
      auto less_bad = [](const WorstPlace& a, const WorstPlace& b) {
        return a.contour_error_mm > b.contour_error_mm;  // min-heap on the error
      };
      if (opt_.worst_count > 0) {
        if (worst_heap_.size() < opt_.worst_count) {
          worst_heap_.push_back(w);
          std::push_heap(worst_heap_.begin(), worst_heap_.end(), less_bad);
        } else if (w.contour_error_mm > worst_heap_.front().contour_error_mm) {
          std::pop_heap(worst_heap_.begin(), worst_heap_.end(), less_bad);
          worst_heap_.back() = w;
          std::push_heap(worst_heap_.begin(), worst_heap_.end(), less_bad);
        }
      }
    }
    if (opt_.keep_per_move) {
      if (rep_.per_move.size() <= i) rep_.per_move.resize(i + 1);
      rep_.per_move[i] = o.m;
    }
    open_.pop_front();
    ++open_base_;
  }
  if (open_.empty()) open_base_ = std::max(open_base_, g);
}

bool QualityMeter::in_range(const SimSample& s) const {
  if (s.t_s < opt_.t_begin_s || s.t_s > opt_.t_end_s) return false;
  const std::int32_t layer = move(s.move_index).layer;
  return layer >= opt_.layer_begin && layer <= opt_.layer_end;
}

void QualityMeter::close_corner() {
  if (!corner_open_) return;
  corner_open_ = false;
  // Local maxima of the deviation across the outgoing wall.
  std::size_t a = 0, b = 0, found = 0;
  for (std::size_t k = 1; k + 1 < ring_.size() && found < 2; ++k) {
    if (ring_[k].dev_mm > ring_[k - 1].dev_mm && ring_[k].dev_mm >= ring_[k + 1].dev_mm) {
      (found == 0 ? a : b) = k;
      ++found;
    }
  }
  if (found == 2) {
    double lo = ring_[a].dev_mm;
    for (std::size_t k = a; k <= b; ++k) lo = std::min(lo, ring_[k].dev_mm);
    const double amp = 0.5 * (ring_[a].dev_mm - lo);
    if (amp > 1e-6) {
      corner_res_.ringing_amplitude_mm = amp;
      corner_res_.ringing_wavelength_mm = ring_[b].sigma_mm - ring_[a].sigma_mm;
      corner_res_.ringing_period_s = ring_[b].t_s - ring_[a].t_s;
    }
  }
  ++rep_.corner_count;
  if (opt_.keep_per_move) {
    rep_.corners.push_back(corner_res_);
  } else {
    // keep the worst_count corners by overshoot; wavelengths into the histogram
    if (std::isfinite(corner_res_.ringing_wavelength_mm)) {
      const auto bin = static_cast<std::size_t>(std::max(0.0, corner_res_.ringing_wavelength_mm) / 0.001);
      if (wavelength_hist_.size() <= bin) wavelength_hist_.resize(std::min<std::size_t>(bin + 1, 1000000));
      ++wavelength_hist_[std::min<std::size_t>(bin, wavelength_hist_.size() - 1)];
    }
    rep_.ringing_amplitude_mm = std::max(rep_.ringing_amplitude_mm, corner_res_.ringing_amplitude_mm);
    auto by_overshoot = [](const CornerResult& a, const CornerResult& b) {
      return a.overshoot_mm > b.overshoot_mm;
    };
    if (rep_.corners.size() < opt_.worst_count) {
      rep_.corners.push_back(corner_res_);
      std::push_heap(rep_.corners.begin(), rep_.corners.end(), by_overshoot);
    } else if (!rep_.corners.empty() && corner_res_.overshoot_mm > rep_.corners.front().overshoot_mm) {
      std::pop_heap(rep_.corners.begin(), rep_.corners.end(), by_overshoot);
      rep_.corners.back() = corner_res_;
      std::push_heap(rep_.corners.begin(), rep_.corners.end(), by_overshoot);
    }
  }
  ring_.clear();
}

void QualityMeter::open_corner_after(std::size_t i, double) {
  const plan::PlannedMove& mi = move(i);
  const Seg si = xy_segment(mi);
  if (si.len <= 1e-9) return;
  const std::size_t end = base_ + win_.size();
  for (std::size_t j = i + 1; j < end && j <= i + 64; ++j) {
    const Seg sj = xy_segment(win_[j - base_]);
    if (sj.len <= 1e-9) continue;
    const double c = ((si.bx - si.ax) * (sj.bx - sj.ax) + (si.by - si.ay) * (sj.by - sj.ay)) /
                     (si.len * sj.len);
    const double ang = std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / std::numbers::pi;
    if (ang <= opt_.corner_angle_deg) return;
    close_corner();
    corner_ = Corner{};
    corner_.angle_deg = ang;
    corner_.p[0] = si.bx;
    corner_.p[1] = si.by;
    corner_.din[0] = (si.bx - si.ax) / si.len;
    corner_.din[1] = (si.by - si.ay) / si.len;
    corner_.dout[0] = (sj.bx - sj.ax) / sj.len;
    corner_.dout[1] = (sj.by - sj.ay) / sj.len;
    corner_res_ = CornerResult{};
    corner_res_.move_index = i;
    corner_res_.line = mi.line;
    corner_res_.angle_deg = ang;
    corner_res_.junction_speed_mm_s = mi.end_v_mm_s;
    corner_open_ = true;
    corner_t0_ = mi.end_time_s();
    return;
  }
}

double QualityMeter::add(const SimSample& s) {
  if (win_.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t g = s.move_index;
  finalize_before(g);
  next_end_ = std::max(next_end_, base_);
  if (!in_range(s)) return std::numeric_limits<double>::quiet_NaN();
  ++rep_.samples;
  const double lx = s.sim_mm[0] - s.cmd_mm[0], ly = s.sim_mm[1] - s.cmd_mm[1];
  const double lag = std::sqrt(lx * lx + ly * ly);
  const double d = distance_to_path(win_, g - base_, s.sim_mm[0], s.sim_mm[1], 2.0 * lag + 0.05);
  MoveMetrics& mm = open(g).m;
  if (d >= mm.max_contour_error_mm || mm.samples == 0) {
    mm.max_contour_error_mm = std::max(mm.max_contour_error_mm, d);
    mm.worst_t_s = s.t_s;
    mm.worst_x_mm = s.sim_mm[0];
    mm.worst_y_mm = s.sim_mm[1];
  }
  mm.sum_sq_contour_error_mm2 += d * d;
  ++mm.samples;
  rep_.max_contour_error_mm = std::max(rep_.max_contour_error_mm, d);
  sum_sq_ += d * d;
  if (!s.holding && move(g).is_extruding()) {
    rep_.max_contour_error_printing_mm = std::max(rep_.max_contour_error_printing_mm, d);
    sum_sq_print_ += d * d;
    ++n_print_;
  }
  const double vib = std::hypot(s.vibration_mm[0], s.vibration_mm[1]);
  last_vib_ = vib;

  // Moves that ended by now: residual vibration (unless fed exactly), corners they end in.
  const std::size_t end = base_ + win_.size();
  while (next_end_ < end && s.t_s >= win_[next_end_ - base_].end_time_s() - 1e-12) {
    const std::size_t i = next_end_++;
    if (!exact_ends_ && i >= open_base_) {
      open(i).m.residual_vibration_mm = vib;
      rep_.max_residual_vibration_mm = std::max(rep_.max_residual_vibration_mm, vib);
      rep_.final_residual_vibration_mm = vib;
    }
    open_corner_after(i, vib);
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
  if (i < base_ || i - base_ >= win_.size() || t_s < opt_.t_begin_s || t_s > opt_.t_end_s) return;
  const std::int32_t layer = win_[i - base_].layer;
  if (layer < opt_.layer_begin || layer > opt_.layer_end || i < open_base_) return;
  exact_ends_ = true;
  const double vib = std::hypot(v[0], v[1]);
  open(i).m.residual_vibration_mm = vib;
  rep_.max_residual_vibration_mm = std::max(rep_.max_residual_vibration_mm, vib);
  rep_.final_residual_vibration_mm = vib;
}

QualityReport QualityMeter::finish() {
  close_corner();
  finalize_before(std::numeric_limits<std::size_t>::max());
  rep_.motion_time_s = have_start_ ? last_end_s_ - first_start_s_ : 0.0;
  rep_.rms_contour_error_mm = rep_.samples ? std::sqrt(sum_sq_ / static_cast<double>(rep_.samples)) : 0.0;
  rep_.rms_contour_error_printing_mm = n_print_ ? std::sqrt(sum_sq_print_ / static_cast<double>(n_print_)) : 0.0;
  for (auto& [k, g] : rep_.per_layer) finalise(g);
  for (auto& [k, g] : rep_.per_feature) finalise(g);
  rep_.worst = worst_heap_;
  std::sort(rep_.worst.begin(), rep_.worst.end(), [](const WorstPlace& a, const WorstPlace& b) {
    return a.contour_error_mm > b.contour_error_mm;
  });
  std::vector<double> wl;
  for (const CornerResult& c : rep_.corners) {
    if (std::isfinite(c.ringing_wavelength_mm)) wl.push_back(c.ringing_wavelength_mm);
    rep_.ringing_amplitude_mm = std::max(rep_.ringing_amplitude_mm, c.ringing_amplitude_mm);
  }
  if (!opt_.keep_per_move) {
    std::sort(rep_.corners.begin(), rep_.corners.end(), [](const CornerResult& a, const CornerResult& b) {
      return a.overshoot_mm > b.overshoot_mm;
    });
    std::uint64_t total = 0, acc = 0;
    for (auto c : wavelength_hist_) total += c;
    for (std::size_t b = 0; b < wavelength_hist_.size() && total > 0; ++b) {
      acc += wavelength_hist_[b];
      if (2 * acc > total) {
        rep_.ringing_wavelength_mm = (static_cast<double>(b) + 0.5) * 0.001;
        break;
      }
    }
  } else if (!wl.empty()) {
    std::nth_element(wl.begin(), wl.begin() + static_cast<std::ptrdiff_t>(wl.size() / 2), wl.end());
    rep_.ringing_wavelength_mm = wl[wl.size() / 2];
  }
  if (!exact_ends_ && rep_.final_residual_vibration_mm == 0.0) rep_.final_residual_vibration_mm = last_vib_;
  return std::move(rep_);
}

// ---------------------------------------------------------------------------------------
StreamingSimulation::StreamingSimulation(const AxisModel& m0, const AxisModel& m1,
                                         const SimulationOptions& so, MetricsOptions mo,
                                         RowSink rows, std::size_t window_moves)
    : sim_(m0, m1, so), meter_(mo), rows_(std::move(rows)), window_(std::max<std::size_t>(window_moves, 80)) {
  buf_.reserve(3 * window_ + 1);
}

void StreamingSimulation::run(double t_stop, bool final) {
  meter_.set_window(buf_, base_);
  sim_.advance(
      buf_, base_, t_stop, final,
      [&](const SimSample& s) {
        const double e = meter_.add(s);
        if (rows_) rows_(s, e);
      },
      [&](std::size_t i, double t, const std::array<double, 2>& v) { meter_.on_move_end(i, t, v); });
}

void StreamingSimulation::push(const plan::PlannedMove& m) {
  buf_.push_back(m);
  max_buffer_ = std::max(max_buffer_, buf_.size());
  if (buf_.size() < 3 * window_) return;
  run(buf_[buf_.size() - window_].start_time_s, false);
  const std::size_t drop = buf_.size() - 2 * window_;
  buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(drop));
  base_ += drop;
}

QualityReport StreamingSimulation::finish() {
  run(std::numeric_limits<double>::infinity(), true);
  return meter_.finish();
}

}  // namespace amctl::dynamics
