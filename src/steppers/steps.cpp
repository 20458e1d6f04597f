// The step generator: every motor's steps over each planned move, with Klipper's half-step
// convention (docs/steppers.md sections 1-2). Linear motors (a row over X, Y, Z, E) get the
// closed-form path of section 2; non-linear ones (a kinematics::MotorCurve) are stepped on the
// intervals where their curve is monotone (section 2b).
#include "amctl/steppers/steps.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "step_solver.hpp"

namespace amctl::steppers {

using detail::horner;
using plan::PathPiece;
using plan::PlannedMove;

StepGenerator::StepGenerator(std::vector<kinematics::Motor> motors)
    : motors_(std::move(motors)),
      state_(motors_.size()),
      stats_(motors_.size()),
      scratch_(motors_.size()) {
  for (const kinematics::Motor& m : motors_) {
    AMCTL_CHECK(m.step_distance.value > 0.0, "step distance must be positive");
  }
}

void StepGenerator::add_move(const PlannedMove& move, std::vector<Step>& out) {
  piece_count_ = trajectory::move_pieces(move, pieces_);
  std::size_t active = 0, last_active = 0;
  for (std::uint32_t c = 0; c < motors_.size(); ++c) {
    scratch_[c].clear();
    if (motors_[c].linear()) linear_move(c, move, scratch_[c]);
    else curve_move(c, move, scratch_[c]);
    if (!scratch_[c].empty()) {
      ++active;
      last_active = c;
    }
  }
  if (active == 0) return;
  if (active == 1) {
    out.insert(out.end(), scratch_[last_active].begin(), scratch_[last_active].end());
    return;
  }
  // k-way merge by time (ties: motor order); few motors, so a linear scan of the heads.
  std::array<std::size_t, 16> head_small{};
  std::vector<std::size_t> head_big;
  std::size_t* head = head_small.data();
  if (motors_.size() > head_small.size()) {
    head_big.assign(motors_.size(), 0);
    head = head_big.data();
  }
  std::size_t total = 0;
  for (const auto& s : scratch_) total += s.size();
  out.reserve(out.size() + total);
  for (std::size_t k = 0; k < total; ++k) {
    std::size_t best = motors_.size();
    double best_t = 0.0;
    for (std::size_t c = 0; c < motors_.size(); ++c) {
      if (head[c] < scratch_[c].size()) {
        const double t = scratch_[c][head[c]].time_s;
        if (best == motors_.size() || t < best_t) {
          best = c;
          best_t = t;
        }
      }
    }
    out.push_back(scratch_[best][head[best]++]);
  }
}

void StepGenerator::record_step(std::uint32_t c, double t, int dir, std::vector<Step>& out) {
  State& st = state_[c];
  StepperStats& stats = stats_[c];
  st.n += dir;
  const double interval = t - st.last_step_s;
  if (interval < stats.min_interval_s) {
    stats.min_interval_s = interval;
    stats.peak_time_s = t;
  }
  st.last_step_s = t;
  out.push_back(Step{t, c, dir});
  ++stats.steps;
  if (dir > 0) ++stats.steps_positive;
  else ++stats.steps_negative;
  stats.position_steps = st.n;
}

void StepGenerator::linear_move(std::uint32_t c, const PlannedMove& move, std::vector<Step>& out) {
  const kinematics::Motor& motor = motors_[c];
  State& st = state_[c];
  const auto& r = motor.row;
  const double start = r[0] * move.start_mm[0] + r[1] * move.start_mm[1] +
                       r[2] * move.start_mm[2] + r[3] * move.start_mm[3];
  const double k = r[0] * move.axes_r[0] + r[1] * move.axes_r[1] + r[2] * move.axes_r[2] +
                   r[3] * move.axes_r[3];
  if (!st.started) {
    st.started = true;
    st.origin_mm = start;
    st.last_end_mm = start;
  }
  double base = start + st.offset_mm;
  // A jump between moves (G92, homing): the motor did not move, so the position stays
  // continuous and the offset takes the jump. Round-off between moves is left alone.
  if (std::abs(base - st.last_end_mm) > 1e-9 * (1.0 + std::abs(st.last_end_mm))) {
    st.offset_mm += st.last_end_mm - base;
    base = st.last_end_mm;
  }
  if (piece_count_ == 0 || k == 0.0) return;
  double dummy = 0.0;
  const double s_end = detail::end_distance(pieces_, piece_count_);
  const double end = base + k * s_end;
  st.last_end_mm = end;
  const double step = motor.step_distance.value;
  const double u_end = (end - st.origin_mm) / step;
  const int dir = k > 0.0 ? 1 : -1;
  // Klipper takes a step when the motor is within kLevelToleranceMm of its half-step level
  // (itersolve.c), so a move that ends that close short of a level steps at its end.
  const double reach = kLevelToleranceMm / step;
  std::int64_t n_end = st.n;
  if (dir > 0) {
    n_end = std::max<std::int64_t>(st.n,
                                   static_cast<std::int64_t>(std::floor(u_end + reach + 0.5)));
  } else {
    n_end = std::min<std::int64_t>(st.n,
                                   static_cast<std::int64_t>(std::ceil(u_end - reach - 0.5)));
  }
  if (n_end == st.n) return;
  // The hot loop of every linear motor, kept with its state in locals (the piece walk of
  // PieceCursor and the bookkeeping of record_step, written out: through them this loop ran
  // 16 % slower on BM_StepsBoxbossCoreXY).
  StepperStats& stats = stats_[c];
  std::size_t pi = 0;
  double piece_t0 = move.start_time_s;
  double piece_end_s = horner(pieces_[0], pieces_[0].duration_s, dummy);
  double lo = 0.0;
  const double inv_k = 1.0 / k;
  const std::int64_t count = dir > 0 ? n_end - st.n : st.n - n_end;
  for (std::int64_t i = 0; i < count; ++i) {
    // The half-step level between n and n + dir.
    const double level = static_cast<double>(st.n) + 0.5 * dir;
    const double s_target = (st.origin_mm + level * step - base) * inv_k;
    while (pi + 1 < piece_count_ && s_target > piece_end_s) {
      piece_t0 += pieces_[pi].duration_s;
      ++pi;
      piece_end_s = horner(pieces_[pi], pieces_[pi].duration_s, dummy);
      lo = 0.0;
    }
    lo = solve_crossing_s(pieces_[pi], s_target, lo);
    const double t = piece_t0 + lo;
    st.n += dir;
    const double interval = t - st.last_step_s;
    if (interval < stats.min_interval_s) {
      stats.min_interval_s = interval;
      stats.peak_time_s = t;
    }
    st.last_step_s = t;
    out.push_back(Step{t, c, dir});
  }
  stats.steps += static_cast<std::uint64_t>(count);
  if (dir > 0) stats.steps_positive += static_cast<std::uint64_t>(count);
  else stats.steps_negative += static_cast<std::uint64_t>(count);
  stats.position_steps = st.n;
}

void StepGenerator::curve_move(std::uint32_t c, const PlannedMove& move, std::vector<Step>& out) {
  const kinematics::Motor& motor = motors_[c];
  const kinematics::MotorCurve& curve = *motor.curve;
  State& st = state_[c];
  const kinematics::Vec3 p0{move.start_mm[0], move.start_mm[1], move.start_mm[2]};
  const kinematics::Vec3 u{move.axes_r[0], move.axes_r[1], move.axes_r[2]};
  auto reach_error = [&](double s) {
    const kinematics::Vec3 p{p0[0] + u[0] * s, p0[1] + u[1] * s, p0[2] + u[2] * s};
    return Error(fmt::format("line {}: {}", move.line, curve.out_of_reach(p, motor.name)));
  };
  auto q = [&](double s) {
    const double v = curve.along(p0, u, s);
    if (!std::isfinite(v)) throw reach_error(s);
    return v;
  };
  const double offset = st.continue_at(q(0.0));
  if (piece_count_ == 0 || !curve.moves_along(u)) return;
  const double s_end = detail::end_distance(pieces_, piece_count_);
  auto slope = [&](double s) { return curve.slope_along(p0, u, s, s_end); };
  st.last_end_mm = q(s_end) + offset;
  bounds_.assign(1, 0.0);
  curve.turning_points(p0, u, s_end, bounds_);
  bounds_.push_back(s_end);
  detail::PieceCursor cursor(pieces_, piece_count_, move.start_time_s);
  detail::step_monotone_intervals(st, std::span<const double>(bounds_), q, slope, offset,
                                  motor.step_distance.value, s_end, cursor,
                                  [&](double t, int dir) { record_step(c, t, dir, out); });
}

StepSink::StepSink(std::vector<kinematics::Motor> motors, Callback on_steps)
    : gen_(std::move(motors)), on_steps_(std::move(on_steps)) {}

void StepSink::consume(const plan::PlanBatch& batch) {
  for (const PlannedMove& m : batch.moves) {
    buf_.clear();
    gen_.add_move(m, buf_);
    if (!buf_.empty() && on_steps_) on_steps_(buf_);
  }
}

}  // namespace amctl::steppers
