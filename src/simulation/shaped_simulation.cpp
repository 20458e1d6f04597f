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

std::vector<CommandTap> command_taps(const std::optional<shaping::Shaper>& x,
                                     const std::optional<shaping::Shaper>& y, bool motor_space) {
  if (motor_space) {
    const bool same = x.has_value() == y.has_value() &&
                      (!x || (x->amplitudes == y->amplitudes && x->times_s == y->times_s));
    if (!same) return split_command_taps(x, y);
  }
  std::vector<CommandTap> taps;
  auto tap_at = [&](double d) -> CommandTap& {
    for (CommandTap& t : taps) {
      if (t.delay_s == d) return t;
    }
    taps.push_back(CommandTap{d, {0.0, 0.0}});
    return taps.back();
  };
  const std::optional<shaping::Shaper>* axes[2] = {&x, &y};
  for (std::size_t a = 0; a < 2; ++a) {
    if (!axes[a]->has_value()) {
      tap_at(0.0).weight[a] += 1.0;
      continue;
    }
    const shaping::AppliedPulses p = shaping::applied_pulses(**axes[a]);
    for (std::size_t i = 0; i < p.weights.size(); ++i) tap_at(p.delays_s[i]).weight[a] += p.weights[i];
  }
  std::sort(taps.begin(), taps.end(),
            [](const CommandTap& a, const CommandTap& b) { return a.delay_s < b.delay_s; });
  return taps;
}

std::vector<CommandTap> split_command_taps(const std::optional<shaping::Shaper>& x,
                                           const std::optional<shaping::Shaper>& y) {
  std::vector<CommandTap> taps;
  const std::optional<shaping::Shaper>* axes[2] = {&x, &y};
  for (int a = 0; a < 2; ++a) {
    std::vector<CommandTap> part;
    auto add = [&](double d, double w) {
      for (CommandTap& t : part) {
        if (t.delay_s == d) {
          t.weight[0] += w;
          t.weight[1] += w;
          return;
        }
      }
      part.push_back(CommandTap{d, {w, w}, a});
    };
    if (!axes[a]->has_value()) {
      add(0.0, 1.0);
    } else {
      const shaping::AppliedPulses p = shaping::applied_pulses(**axes[a]);
      for (std::size_t i = 0; i < p.weights.size(); ++i) add(p.delays_s[i], p.weights[i]);
    }
    std::sort(part.begin(), part.end(),
              [](const CommandTap& l, const CommandTap& r) { return l.delay_s < r.delay_s; });
    taps.insert(taps.end(), part.begin(), part.end());
  }
  return taps;
}

namespace {
/// The move with only its cartesian `axis` part: the other axis' start and direction set to 0
/// (Z and E kept: the simulated axes are X and Y, or the motors made of them).
plan::PlannedMove plan_part(plan::PlannedMove m, int axis) {
  const std::size_t other = axis == 0 ? 1 : 0;
  m.start_mm[other] = 0.0;
  m.axes_r[other] = 0.0;
  return m;
}
}  // namespace

// ------------------------------------------------------------------------------ streaming
struct ShapedStreamingSimulation::Tap {
  Tap(const CommandTap& t, const dy::AxisModel& m0, const dy::AxisModel& m1,
      const dy::SimulationOptions& o)
      : tap(t), sim(m0, m1, o) {}
  CommandTap tap;
  dy::Simulator sim;
  std::size_t next_k = 0;  // combined index of this simulator's next sample
};

struct ShapedStreamingSimulation::Pending {
  std::array<double, 2> sim_mm{};    // shaped nozzle
  std::array<double, 2> cmd_mm{};    // shaped command
  std::array<double, 2> vib_mm{};    // free vibration of the shaped nozzle per axis
  std::size_t count = 0;             // simulators that contributed
};

namespace {
constexpr double kChunkS = 0.25;  // lockstep chunk: bounds the samples held per simulator
}

ShapedStreamingSimulation::ShapedStreamingSimulation(const dy::AxisModel& m0, const dy::AxisModel& m1,
                                                     const dy::SimulationOptions& so,
                                                     dy::MetricsOptions mo, std::vector<CommandTap> taps,
                                                     RowSink rows, std::size_t window_moves)
    : metrics_opt_(mo), meter_(mo), rows_(std::move(rows)),
      window_(std::max<std::size_t>(window_moves, 80)) {
  AMCTL_CHECK(!taps.empty(), "a shaped simulation needs at least one tap");
  dy::require_above_nyquist(so.sample_rate_hz, {&m0, &m1});
  h_ = 1.0 / so.sample_rate_hz;
  min_delay_s_ = std::numeric_limits<double>::infinity();
  max_delay_s_ = -std::numeric_limits<double>::infinity();
  for (const CommandTap& t : taps) {
    min_delay_s_ = std::min(min_delay_s_, t.delay_s);
    max_delay_s_ = std::max(max_delay_s_, t.delay_s);
  }
  // The combined grid starts at a whole number of steps at or before the earliest moment the
  // shaped command moves (t0 + min_delay), so every simulator starts at or before t0 (at rest).
  k_start_ = static_cast<long long>(std::floor(min_delay_s_ / h_ + 1e-9));
  k_start_ = std::min<long long>(k_start_, 0);
  lookahead_ = max_delay_s_ > 0.0 ? static_cast<std::size_t>(std::ceil(max_delay_s_ / h_ - 1e-9)) : 0;
  for (const CommandTap& t : taps) {
    AMCTL_CHECK(t.plan_axis >= -1 && t.plan_axis <= 1, "a tap's plan_axis is -1, 0 or 1");
    if (t.plan_axis >= 0) split_ = true;
    dy::SimulationOptions o = so;
    o.vibration_per_sample = false;
    o.modal_state_per_sample = true;
    o.grid_offset_s = std::min(0.0, static_cast<double>(k_start_) * h_ - t.delay_s);
    o.extra_settle_s = max_delay_s_ - t.delay_s + h_;
    taps_.push_back(std::make_unique<Tap>(t, m0, m1, o));
  }
  mode_axes_ = taps_.front()->sim.mode_axes();
  buf_.reserve(3 * window_ + 1);
  if (split_) {
    for (auto& b : part_buf_) b.reserve(3 * window_ + 1);
  }
}

ShapedStreamingSimulation::~ShapedStreamingSimulation() = default;

std::size_t ShapedStreamingSimulation::simulators() const { return taps_.size(); }

dy::SimulationStats ShapedStreamingSimulation::stats() const {
  dy::SimulationStats s;
  s.samples = emitted_;
  s.start_time_s = t0_ + static_cast<double>(k_start_) * h_;
  s.end_time_s = last_t_;
  s.motion_end_time_s = motion_end_s_;
  for (const auto& t : taps_) {
    s.axis_state_updates += t->sim.stats().axis_state_updates;
    s.split_steps += t->sim.stats().split_steps;
  }
  return s;
}

void ShapedStreamingSimulation::contribute(std::size_t i, const dy::SimSample& s,
                                           std::span<const double> modal) {
  Tap& tap = *taps_[i];
  const std::size_t k = tap.next_k++;
  AMCTL_CHECK(k >= front_k_, "shaped sample already emitted");
  const std::size_t idx = k - front_k_;
  const std::size_t nm = modal.size();
  while (pending_.size() <= idx) {
    pending_.emplace_back();
    pending_modal_.insert(pending_modal_.end(), nm, 0.0);
  }
  Pending& p = pending_[idx];
  const auto& w = tap.tap.weight;
  for (std::size_t a = 0; a < 2; ++a) {
    p.sim_mm[a] += w[a] * s.sim_mm[a];
    p.cmd_mm[a] += w[a] * s.cmd_mm[a];
  }
  const std::size_t off = idx * nm;
  for (std::size_t r = 0; r < nm; ++r) {
    pending_modal_[off + r] += w[static_cast<std::size_t>(mode_axes_[r / 2])] * modal[r];
  }
  if (++p.count == taps_.size()) {
    double v2[2] = {0.0, 0.0};
    for (std::size_t r = 0; r < nm; ++r) {
      const double m = pending_modal_[off + r];
      v2[mode_axes_[r / 2]] += m * m;
    }
    p.vib_mm = {std::sqrt(v2[0]), std::sqrt(v2[1])};
  }
}

void ShapedStreamingSimulation::emit(trajectory::Cursor& plan_cursor, bool flush) {
  const std::size_t nm = 2 * mode_axes_.size();
  const std::size_t ntaps = taps_.size();
  std::size_t complete = 0;
  while (complete < pending_.size() && pending_[complete].count == ntaps) ++complete;
  std::array<double, plan::kMaxPieceDegree + 1> d{};
  while (!pending_.empty() && pending_.front().count == ntaps) {
    std::size_t vib_at = lookahead_;
    if (vib_at >= complete) {
      if (!flush) break;
      vib_at = complete - 1;
    }
    const Pending& p = pending_.front();
    dy::SimSample s;
    s.t_s = t0_ + static_cast<double>(k_start_ + static_cast<long long>(front_k_)) * h_;
    const trajectory::Cursor::Location& loc = plan_cursor.locate(s.t_s);
    trajectory::Cursor::path_derivatives(loc, s.t_s, d);
    const plan::PlannedMove& mv = buf_[loc.move_index];
    for (std::size_t a = 0; a < 3; ++a) s.cmd_mm[a] = mv.start_mm[a] + mv.axes_r[a] * d[0];
    s.cmd_vel_mm_s = {mv.axes_r[0] * d[1], mv.axes_r[1] * d[1]};
    s.sim_mm = p.sim_mm;
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
      const double lx = p.cmd_mm[0] - s.cmd_mm[0], ly = p.cmd_mm[1] - s.cmd_mm[1];
      const double dc = dy::distance_to_path(buf_, loc.move_index, p.cmd_mm[0], p.cmd_mm[1],
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
    pending_modal_.erase(pending_modal_.begin(), pending_modal_.begin() + static_cast<std::ptrdiff_t>(nm));
    ++front_k_;
    --complete;
  }
}

void ShapedStreamingSimulation::run(double t_stop, bool final) {
  if (buf_.empty()) return;
  meter_.set_window(buf_, base_);
  trajectory::Cursor plan_cursor(buf_);
  auto advance_all = [&](double tc, bool fin) {
    for (std::size_t i = 0; i < taps_.size(); ++i) {
      Tap& tap = *taps_[i];
      const std::vector<plan::PlannedMove>& moves =
          tap.tap.plan_axis < 0 ? buf_ : part_buf_[static_cast<std::size_t>(tap.tap.plan_axis)];
      tap.sim.advance(moves, base_, tc - tap.tap.delay_s, fin,
                      [&, i](const dy::SimSample& s) { contribute(i, s, taps_[i]->sim.modal_state()); });
    }
    emit(plan_cursor, fin);
  };
  const double limit = final ? motion_end_s_ + max_delay_s_ : t_stop;
  double tc = t_done_;
  while (tc < limit) {
    tc = std::min(tc + kChunkS, limit);
    advance_all(tc, false);
  }
  t_done_ = std::max(t_done_, tc);
  if (final) advance_all(std::numeric_limits<double>::infinity(), true);
}

void ShapedStreamingSimulation::push(const plan::PlannedMove& m) {
  if (!started_) {
    started_ = true;
    t0_ = m.start_time_s;
    t_done_ = t0_ + static_cast<double>(k_start_) * h_;
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
  buf_.push_back(m);
  if (split_) {
    part_buf_[0].push_back(plan_part(m, 0));
    part_buf_[1].push_back(plan_part(m, 1));
  }
  max_buffer_ = std::max(max_buffer_, buf_.size());
  if (buf_.size() < 3 * window_) return;
  // Every simulator needs the plan up to its own time t - d_i + one step: stop where the
  // most look-ahead still lies before the last known move's start.
  const double t_stop = std::min(buf_[buf_.size() - window_].start_time_s,
                                 buf_.back().start_time_s + min_delay_s_ - 2.0 * h_);
  if (t_stop > t_done_) run(t_stop, false);
  // Keep what the simulators still look back at (t - max_delay), the pending samples, and
  // 64 moves before them for the contour search.
  const double oldest_pending = t0_ + static_cast<double>(k_start_ + static_cast<long long>(front_k_)) * h_;
  const double keep_from = std::min(oldest_pending, t_done_) - max_delay_s_ - 4.0 * h_;
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
  if (split_) {
    for (auto& b : part_buf_) b.erase(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(drop));
  }
  base_ += drop;
}

dy::QualityReport ShapedStreamingSimulation::finish() {
  run(std::numeric_limits<double>::infinity(), true);
  smoothing_.rms_mm =
      smoothing_.samples ? std::sqrt(sum_sq_smoothing_ / static_cast<double>(smoothing_.samples)) : 0.0;
  return meter_.finish();
}

}  // namespace amctl::simulation
