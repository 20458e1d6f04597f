#include "amctl/dynamics/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/dynamics/propagator.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::dynamics {

namespace {

double auto_settle_s(const AxisModel& a, const AxisModel& b) {
  double slowest = std::numeric_limits<double>::infinity();
  bool any = false;
  for (const AxisModel* m : {&a, &b}) {
    for (const Mode& mode : m->modes()) {
      any = true;
      slowest = std::min(slowest, mode.damping_ratio * 2.0 * std::numbers::pi *
                                      mode.natural_frequency_hz);
    }
  }
  if (!any) return 0.0;
  if (slowest <= 0.0) return 1.0;
  return std::clamp(5.0 / slowest, 0.05, 1.0);
}

}  // namespace

Simulator::Simulator(const AxisModel& m0, const AxisModel& m1, const SimulationOptions& opt)
    : opt_(opt), plant_((require_above_nyquist(opt.sample_rate_hz, {&m0, &m1}), m0), m1, 1.0 / opt.sample_rate_hz) {
  h_ = 1.0 / opt.sample_rate_hz;
  settle_ = opt.settle_s >= 0.0 ? opt.settle_s : auto_settle_s(m0, m1);
  require_finite("settle_s", settle_);
  require_finite("grid_offset_s", opt.grid_offset_s);
  require_finite("extra_settle_s", opt.extra_settle_s);
  if (opt.grid_offset_s > 0.0) throw Error("grid_offset_s must be <= 0");
  if (opt.extra_settle_s < 0.0) throw Error("extra_settle_s must be >= 0");
  if (opt.extra_settle_s > 0.0) settle_ += opt.extra_settle_s;
  if (opt.modal_state_per_sample) modal_state_.assign(2 * plant_.modes(), 0.0);
}

Simulator::~Simulator() = default;

std::vector<int> Simulator::mode_axes() const { return plant_.mode_axes(); }

void Simulator::advance(std::span<const plan::PlannedMove> moves, std::size_t base,
                        double t_stop, bool final, const SampleSink& sink,
                        const MoveEndSink& move_end) {
  if (moves.empty()) return;
  const SimulationOptions& opt = opt_;
  const double h = h_;
  ModalPlant& plant = plant_;
  SimulationStats& stats = stats_;
  if (!started_) {
    started_ = true;
    motion_end_ = moves.front().start_time_s;
    t0_ = opt.grid_offset_s < 0.0 ? motion_end_ + opt.grid_offset_s : motion_end_;
    stats.start_time_s = t0_;
  }
  for (const auto& m : moves) motion_end_ = std::max(motion_end_, m.end_time_s());
  const double t0 = t0_;
  const double t_final = motion_end_ + settle_;
  const auto n_steps = static_cast<std::size_t>(std::ceil((t_final - t0) / h - 1e-9));
  stats.motion_end_time_s = motion_end_;

  static constexpr std::array<std::array<double, 3>, 2> kIdentity{{{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}}};
  const auto& rows = opt.motor_space ? opt.motor_rows : kIdentity;
  const auto& row0 = rows[0];
  const auto& row1 = rows[1];
  const bool identity = rows == kIdentity;
  // A motor's share of the tool's z (CoreXZ); the term is left out where it is 0.
  auto motor = [](const std::array<double, 3>& row, const auto& v) {
    const double xy = row[0] * v[0] + row[1] * v[1];
    return row[2] != 0.0 ? xy + row[2] * v[2] : xy;
  };
  // The tool's x, y for motor positions a, b at height z: the inverse of the rows' x, y part.
  const double det = row0[0] * row1[1] - row0[1] * row1[0];
  if (!identity && !(std::abs(det) > 0.0)) {
    throw Error("the two motors of the motor-space simulation do not determine X and Y");
  }
  auto tool_xy = [&](double a, double b, double z) -> std::array<double, 2> {
    if (identity) return {a, b};
    if (row0[2] != 0.0) a -= row0[2] * z;
    if (row1[2] != 0.0) b -= row1[2] * z;
    return {(row1[1] * a - row0[1] * b) / det, (row0[0] * b - row1[0] * a) / det};
  };
  trajectory::Cursor cursor(moves);
  std::array<double, plan::kMaxPieceDegree + 1> d{};
  double u[2][kMaxInputTerms] = {};

  // Fills u (input derivatives per axis) for the location just found; returns the terms.
  auto input_terms = [&](const trajectory::Cursor::Location& loc, double t) -> int {
    trajectory::Cursor::path_derivatives(loc, t, d);
    const plan::PlannedMove& mv = moves[loc.move_index];
    const double g0 = motor(row0, mv.axes_r);
    const double g1 = motor(row1, mv.axes_r);
    const int terms = loc.holding ? 0 : std::max(0, loc.piece->degree - 1);
    for (int j = 0; j < kMaxInputTerms; ++j) {
      const double dj = j < terms ? d[static_cast<std::size_t>(j + 2)] : 0.0;
      u[0][j] = g0 * dj;
      u[1][j] = g1 * dj;
    }
    return terms;
  };

  // Commanded velocity of the two simulated axes at t on the piece of `l`.
  auto axis_velocity = [&](const trajectory::Cursor::Location& l, double t, double (&v)[2]) {
    const double sv = l.holding ? 0.0 : trajectory::evaluate_piece(*l.piece, t - l.piece_t0_s).v_mm_s;
    const plan::PlannedMove& mv = moves[l.move_index];
    v[0] = sv * motor(row0, mv.axes_r);
    v[1] = sv * motor(row1, mv.axes_r);
  };

  double (&v_left)[2] = v_left_;
  bool& have_left = have_left_;
  // Free-vibration amplitude per axis for the current state and input u (terms used).
  auto vibration = [&](int terms) { return plant.vibration_mm(terms, u); };
  // Reports every move that has ended by the location `l` at time t.
  std::size_t& next_end = next_end_;
  auto report_ends = [&](const trajectory::Cursor::Location& l, double t, int terms) {
    if (!move_end) return;
    const std::size_t done =
        base + (l.holding && t >= moves[l.move_index].start_time_s ? l.move_index + 1 : l.move_index);
    if (next_end >= done) return;
    const auto vib = vibration(terms);
    while (next_end < done) move_end(next_end++, t, vib);
  };
  for (std::size_t& k = k_;; ++k) {
    const double t = t0 + static_cast<double>(k) * h;
    if (!final && t >= t_stop) break;
    if (final && k > n_steps) break;
    const trajectory::Cursor::Location loc = cursor.locate(t);
    const int terms = input_terms(loc, t);
    const plan::PlannedMove& mv = moves[loc.move_index];
    if (have_left) {  // the last step ended exactly on a piece boundary
      double vr[2];
      axis_velocity(loc, t, vr);
      plant.velocity_jump(vr[0] - v_left[0], vr[1] - v_left[1]);
      have_left = false;
      report_ends(loc, t, terms);
    }

    // ---- output sample at t
    SimSample s;
    s.t_s = t;
    s.move_index = base + loc.move_index;
    s.line = mv.line;
    s.holding = loc.holding;
    for (int i = 0; i < 3; ++i) s.cmd_mm[static_cast<std::size_t>(i)] = mv.start_mm[static_cast<std::size_t>(i)] + mv.axes_r[static_cast<std::size_t>(i)] * d[0];
    s.cmd_vel_mm_s = {mv.axes_r[0] * d[1], mv.axes_r[1] * d[1]};
    const std::array<double, 2> err = plant.deflection_mm();
    const double c0 = motor(row0, s.cmd_mm);
    const double c1 = motor(row1, s.cmd_mm);
    const auto xy = tool_xy(c0 + err[0], c1 + err[1], s.cmd_mm[2]);
    s.sim_mm = {xy[0], xy[1]};
    if (opt.vibration_per_sample) s.vibration_mm = vibration(terms);
    if (opt.modal_state_per_sample) plant.modal_state(terms, u, modal_state_);
    sink(s);
    ++stats.samples;
    if (final && k >= n_steps) {
      report_ends(loc, t, terms);
      stats.end_time_s = t;
      ++k;
      break;
    }

    // ---- advance to t + h
    const double t_next = t0 + static_cast<double>(k + 1) * h;
    const double tol = 1e-12 * std::max(1.0, std::abs(t_next));
    if (plant.empty()) continue;
    if (loc.piece_end_s >= t_next - tol) {
      plant.step(terms, u);
      stats.axis_state_updates += plant.modes();
      if (loc.piece_end_s <= t_next + tol) {
        axis_velocity(loc, t_next, v_left);
        have_left = true;
      }
      continue;
    }
    ++stats.split_steps;
    double tc = t;
    const trajectory::Cursor::Location* lp = &loc;
    int tm = terms;
    for (int guard = 0; tc < t_next - tol && guard < 64; ++guard) {
      const double end = std::min(lp->piece_end_s, t_next);
      if (end >= t_next - tol && lp->piece_end_s <= t_next + tol) {
        axis_velocity(*lp, t_next, v_left);
        have_left = true;
      }
      const double dt = end - tc;
      if (dt > 0.0) {
        plant.advance(dt, tm, u);
        stats.axis_state_updates += plant.modes();
      }
      tc = end;
      if (tc >= t_next - tol) break;
      // Left limit of the commanded axis velocities at the boundary, before the cursor
      // moves on (it may reload its pieces).
      double vl[2];
      axis_velocity(*lp, tc, vl);
      const trajectory::Cursor::Location& nl = cursor.locate(tc);
      tm = input_terms(nl, tc);
      lp = &nl;
      double vr[2];
      axis_velocity(nl, tc, vr);
      plant.velocity_jump(vr[0] - vl[0], vr[1] - vl[1]);
      report_ends(nl, tc, tm);
    }
  }
}

double settle_time_s(const SimulationOptions& opt, const AxisModel& m0, const AxisModel& m1) {
  double settle = opt.settle_s >= 0.0 ? opt.settle_s : auto_settle_s(m0, m1);
  if (opt.extra_settle_s > 0.0) settle += opt.extra_settle_s;
  return settle;
}

SimulationStats simulate(std::span<const plan::PlannedMove> moves, const AxisModel& m0,
                         const AxisModel& m1, const SimulationOptions& opt,
                         const SampleSink& sink, const MoveEndSink& move_end) {
  Simulator sim(m0, m1, opt);
  sim.advance(moves, 0, std::numeric_limits<double>::infinity(), true, sink, move_end);
  return sim.stats();
}

}  // namespace amctl::dynamics
