// The belt dynamics driven by an input-shaped command (shaped_simulation.hpp).
#include "amctl/simulation/shaped_simulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"

namespace amctl::simulation {

namespace dy = amctl::dynamics;

namespace {
constexpr std::size_t kFeedPieces = 64;     // shaped pieces simulated at once
constexpr std::size_t kEmitSamples = 2048;  // samples measured at once (plus the look-ahead)
constexpr std::array<std::array<double, 3>, 2> kIdentityRows{{{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}}};

shaping::AxisShapers axis_shapers(const std::optional<shaping::Shaper>& x, const std::optional<shaping::Shaper>& y) {
  shaping::AxisShapers a;
  a.xyz[0] = x;
  a.xyz[1] = y;
  return a;
}

// Axis a of the shaped piece at tau (Horner).
double piece_value(const shaping::AxisPiece& p, std::size_t a, double tau) {
  double x = 0.0;
  for (int k = shaping::kAxisPieceCoeffs - 1; k >= 0; --k) x = x * tau + p.c[a][static_cast<std::size_t>(k)];
  return x;
}
}  // namespace

ShapedStreamingSimulation::ShapedStreamingSimulation(const dy::AxisModel& m0, const dy::AxisModel& m1,
                                                     const dy::SimulationOptions& so, dy::MetricsOptions mo,
                                                     const std::optional<shaping::Shaper>& shaper_x,
                                                     const std::optional<shaping::Shaper>& shaper_y,
                                                     RowSink rows, std::size_t window_moves)
    : metrics_opt_(mo), sim_opt_(so), model_0_(m0), model_1_(m1), shaped_(axis_shapers(shaper_x, shaper_y)),
      meter_(mo), rows_(std::move(rows)), window_(std::max<std::size_t>(window_moves, 80)) {
  dy::require_above_nyquist(so.sample_rate_hz, {&m0, &m1});
  h_ = 1.0 / so.sample_rate_hz;
  dy::SimulationOptions plain = so;
  plain.extra_settle_s = 0.0;
  settle_s_ = dy::settle_time_s(plain, m0, m1);
  require_finite("settle_s", settle_s_);
  min_delay_s_ = shaped_.min_delay_s();
  max_delay_s_ = shaped_.max_delay_s();
  // The grid starts at a whole number of steps at or before the earliest moment the shaped
  // command moves (t0 + min_delay).
  k_start_ = static_cast<long long>(std::floor(min_delay_s_ / h_ + 1e-9));
  k_start_ = std::min<long long>(k_start_, 0);
  lookahead_ = max_delay_s_ > 0.0 ? static_cast<std::size_t>(std::ceil(max_delay_s_ / h_ - 1e-9)) : 0;
  rows_map_ = so.motor_space ? so.motor_rows : kIdentityRows;
  det_ = rows_map_[0][0] * rows_map_[1][1] - rows_map_[0][1] * rows_map_[1][0];
  if (rows_map_ != kIdentityRows && !(std::abs(det_) > 0.0)) {
    throw Error("the two motors of the motor-space simulation do not determine X and Y");
  }
  buf_.reserve(3 * window_ + 1);
  offsets_.reserve(3 * window_ + 1);
}

ShapedStreamingSimulation::~ShapedStreamingSimulation() = default;

dy::SimulationStats ShapedStreamingSimulation::stats() const {
  dy::SimulationStats s;
  s.samples = emitted_;
  s.start_time_s = t0_ + static_cast<double>(k_start_) * h_;
  s.end_time_s = last_t_;
  s.motion_end_time_s = motion_end_s_;
  if (engine_) {
    s.axis_state_updates = engine_->state_updates();
    s.split_steps = engine_->pieces();
  }
  return s;
}

void ShapedStreamingSimulation::on_sample(const dy::PlantSample& s) {
  Pending p;
  p.t_s = s.t_s;
  // The shaped toolhead at t: on the piece being simulated, or at rest where the stream
  // started (before its first piece) or ended.
  double xyz[3];
  for (std::size_t a = 0; a < 3; ++a) {
    if (piece_ != nullptr) {
      xyz[a] = piece_value(*piece_, a, std::max(0.0, s.t_s - piece_->t0_s));
    } else if (have_last_piece_) {
      xyz[a] = piece_value(last_piece_, a, last_piece_.duration_s);
    } else {
      xyz[a] = pieces_.empty() ? 0.0 : pieces_.front().c[a][0];
    }
  }
  p.cmd_mm = {xyz[0], xyz[1]};
  // The nozzle: the command plus the motors' deflections mapped back to X, Y (the inverse of
  // the rows' X, Y part; identity without motor space).
  const double d0 = s.sim_mm[0] - s.cmd_mm[0], d1 = s.sim_mm[1] - s.cmd_mm[1];
  if (rows_map_ == kIdentityRows) {
    p.sim_mm = {xyz[0] + d0, xyz[1] + d1};
  } else {
    const auto& r0 = rows_map_[0];
    const auto& r1 = rows_map_[1];
    p.sim_mm = {xyz[0] + (r1[1] * d0 - r0[1] * d1) / det_, xyz[1] + (r0[0] * d1 - r1[0] * d0) / det_};
  }
  p.vib_mm = engine_->plant().vibration_mm(engine_->input_terms(), engine_->input());
  pending_.push_back(p);
}

void ShapedStreamingSimulation::feed(bool final) {
  if (!engine_) {
    if (pieces_.empty()) return;
    engine_.emplace(model_0_, model_1_, sim_opt_.sample_rate_hz, t0_, k_start_);
  }
  const auto sink = [this](const dy::PlantSample& s) { on_sample(s); };
  const auto& r0 = rows_map_[0];
  const auto& r1 = rows_map_[1];
  for (const shaping::AxisPiece& ap : pieces_) {
    dy::CommandPiece cp;
    cp.t0_s = ap.t0_s;
    cp.duration_s = ap.duration_s;
    for (std::size_t k = 0; k < static_cast<std::size_t>(dy::kCommandPieceCoeffs); ++k) {
      const double x = ap.c[0][k], y = ap.c[1][k], z = ap.c[2][k];
      cp.c[0][k] = r0[2] != 0.0 ? r0[0] * x + r0[1] * y + r0[2] * z : r0[0] * x + r0[1] * y;
      cp.c[1][k] = r1[2] != 0.0 ? r1[0] * x + r1[1] * y + r1[2] * z : r1[0] * x + r1[1] * y;
    }
    for (std::size_t k = static_cast<std::size_t>(dy::kCommandPieceCoeffs); k < shaping::kAxisPieceCoeffs; ++k) {
      AMCTL_CHECK(ap.c[0][k] == 0.0 && ap.c[1][k] == 0.0 && ap.c[2][k] == 0.0,
                  "a shaped XY piece above the plant engine's degree");
    }
    piece_ = &ap;
    engine_->push(cp, sink);
    last_piece_ = ap;
    have_last_piece_ = true;
  }
  piece_ = nullptr;
  pieces_.clear();
  if (final) {
    // Through motion end + the longest delay (the shaped command's end) + the settle time.
    const double t_first = t0_ + static_cast<double>(k_start_) * h_;
    const double t_final = motion_end_s_ + max_delay_s_ + settle_s_ + h_;
    const auto last_k = static_cast<std::size_t>(std::ceil((t_final - t_first) / h_ - 1e-9));
    engine_->rest_until(last_k, sink);
  }
}

void ShapedStreamingSimulation::emit(bool flush) {
  if (buf_.empty()) return;
  meter_.set_window(buf_, base_);
  trajectory::Cursor plan_cursor(buf_);
  std::array<double, plan::kMaxPieceDegree + 1> d{};
  while (!pending_.empty()) {
    std::size_t vib_at = lookahead_;
    if (vib_at >= pending_.size()) {
      if (!flush) break;
      vib_at = pending_.size() - 1;
    }
    const Pending& p = pending_.front();
    dy::SimSample s;
    s.t_s = p.t_s;
    const trajectory::Cursor::Location& loc = plan_cursor.locate(s.t_s);
    trajectory::Cursor::path_derivatives(loc, s.t_s, d);
    const plan::PlannedMove& mv = buf_[loc.move_index];
    for (std::size_t a = 0; a < 3; ++a) s.cmd_mm[a] = mv.start_mm[a] + mv.axes_r[a] * d[0];
    s.cmd_vel_mm_s = {mv.axes_r[0] * d[1], mv.axes_r[1] * d[1]};
    // The stream's coordinates back to the plan's (an XY jump of G92 is absorbed there).
    const std::array<double, 2>& off = offsets_[loc.move_index];
    const std::array<double, 2> cmd_s{p.cmd_mm[0] - off[0], p.cmd_mm[1] - off[1]};
    s.sim_mm = {p.sim_mm[0] - off[0], p.sim_mm[1] - off[1]};
    s.vibration_mm = pending_[vib_at].vib_mm;
    s.move_index = base_ + loc.move_index;
    s.line = mv.line;
    s.holding = loc.holding;
    // Residual vibration of every move that has ended by t: the vibration read L samples
    // later, once the shaped command has left the move (QualityMeter::on_move_end, called
    // before the sample as the Simulator does).
    next_end_ = std::max(next_end_, base_);
    while (next_end_ < base_ + buf_.size() && s.t_s >= buf_[next_end_ - base_].end_time_s() - 1e-12) {
      meter_.on_move_end(next_end_++, s.t_s, s.vibration_mm);
    }
    const double e = meter_.add(s);
    if (rows_) rows_(s, e);
    // The shaped command against the plan (the same measuring range as the nozzle: e is NaN
    // outside it), searched along the path as the meter does.
    if (!std::isnan(e)) {
      const double lx = cmd_s[0] - s.cmd_mm[0], ly = cmd_s[1] - s.cmd_mm[1];
      const double dc = dy::distance_to_path(buf_, loc.move_index, cmd_s[0], cmd_s[1],
                                             2.0 * std::sqrt(lx * lx + ly * ly) + 0.05);
      smoothing_.max_mm = std::max(smoothing_.max_mm, dc);
      sum_sq_smoothing_ += dc * dc;
      ++smoothing_.samples;
      while (!corner_times_.empty() && corner_times_.front() + max_delay_s_ + h_ < s.t_s) {
        corner_times_.pop_front();
      }
      if (!corner_times_.empty() && corner_times_.front() + min_delay_s_ - h_ <= s.t_s) {
        smoothing_.max_at_corners_mm = std::max(smoothing_.max_at_corners_mm, dc);
      }
    }
    last_t_ = s.t_s;
    ++emitted_;
    pending_.pop_front();
    ++front_k_;
  }
}

void ShapedStreamingSimulation::push(const plan::PlannedMove& m) {
  if (!started_) {
    started_ = true;
    t0_ = m.start_time_s;
    motion_end_s_ = t0_;
  }
  motion_end_s_ = std::max(motion_end_s_, m.end_time_s());
  // Corner junctions of the plan (XY direction turning by more than the corner angle).
  const double len = std::hypot(m.axes_r[0], m.axes_r[1]) * m.distance_mm;
  if (len > 1e-9) {
    const double dir[2] = {m.axes_r[0] * m.distance_mm / len, m.axes_r[1] * m.distance_mm / len};
    if (have_dir_) {
      const double c = std::clamp(dir[0] * last_dir_[0] + dir[1] * last_dir_[1], -1.0, 1.0);
      if (std::acos(c) * 180.0 / std::numbers::pi > metrics_opt_.corner_angle_deg) {
        corner_times_.push_back(m.start_time_s);
      }
    }
    have_dir_ = true;
    last_dir_[0] = dir[0];
    last_dir_[1] = dir[1];
  }
  shaped_.push(m, pieces_);
  buf_.push_back(m);
  offsets_.push_back({shaped_.offset_mm()[0], shaped_.offset_mm()[1]});
  max_buffer_ = std::max(max_buffer_, buf_.size());
  if (buf_.size() < 3 * window_) {
    // Simulate as the pieces come and measure every few thousand samples, so that the samples
    // held do not grow with the time the window's moves take.
    if (pieces_.size() >= kFeedPieces) feed(false);
    if (pending_.size() >= kEmitSamples + lookahead_) emit(false);
    return;
  }
  feed(false);
  emit(false);
  // Keep the moves of the pending samples (and what the shaped command still looks back at),
  // and 64 moves before them for the contour search.
  const double oldest = pending_.empty() ? (buf_.back().start_time_s + min_delay_s_) : pending_.front().t_s;
  const double keep_from = oldest - max_delay_s_ - 4.0 * h_;
  std::size_t by_time = 0;
  while (by_time < buf_.size() && buf_[by_time].end_time_s() < keep_from) ++by_time;
  const std::size_t drop = std::min(buf_.size() - 2 * window_, by_time > 64 ? by_time - 64 : 0);
  if (drop == 0) {
    if (buf_.size() > 64 * window_) {
      throw Error(fmt::format("shaped simulation: more than {} moves within one shaper duration "
                              "({} s)", 64 * window_, max_delay_s_ - min_delay_s_));
    }
    return;
  }
  buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(drop));
  offsets_.erase(offsets_.begin(), offsets_.begin() + static_cast<std::ptrdiff_t>(drop));
  base_ += drop;
}

dy::QualityReport ShapedStreamingSimulation::finish() {
  if (started_) {
    shaped_.finish(pieces_);
    feed(true);
    emit(true);
  }
  smoothing_.rms_mm =
      smoothing_.samples ? std::sqrt(sum_sq_smoothing_ / static_cast<double>(smoothing_.samples)) : 0.0;
  return meter_.finish();
}

}  // namespace amctl::simulation
