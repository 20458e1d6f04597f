// LPFBF over the plan stream (docs/compensation.md, section 3): the plan is consumed batch by
// batch, the desired path sampled on the FBF grid as its moves arrive, each axis's LpfbfAxis
// emits the command once its windows are solved, and every emitted sample is checked at once
// (the plant, exact for a command linear between samples: e += B dv at each sample, e <- Phi e)
// and written to the CSV (amctl::OutputFile: a regular file appears whole at the end). Held: the window's samples, the
// moves from 64 before the oldest unwritten sample (the contour search) to the newest.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include "amctl/compensation/command_table.hpp"
#include "amctl/compensation/compensate.hpp"
#include "amctl/dynamics/metrics.hpp"
#include "amctl/control/discretize.hpp"
#include "amctl/core/error.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "detail.hpp"

namespace amctl::compensation {
namespace {

/// The plant driven by a command linear between samples, one sample at a time.
class StreamPlant {
 public:
  StreamPlant(const dynamics::AxisModel& m, double h)
      : B_(m.B()), C_(m.C()), Phi_(control::discretize_polynomial(m.A(), m.B(), 1, h).Phi),
        e_(Eigen::VectorXd::Zero(m.A().rows())), h_(h) {}
  /// Nozzle at the sample given the command there and at the next sample.
  double step(double x_k, double x_next) {
    const double v = (x_next - x_k) / h_;
    e_ += B_ * (v - v_prev_);
    v_prev_ = v;
    const double y = x_k + C_.dot(e_);
    tmp_.noalias() = Phi_ * e_;
    e_.swap(tmp_);
    return y;
  }

 private:
  Eigen::VectorXd B_;
  Eigen::RowVectorXd C_;
  Eigen::MatrixXd Phi_;
  Eigen::VectorXd e_, tmp_{e_.size()};
  double h_ = 0.0, v_prev_ = 0.0;
};

struct HeldMove {
  detail::Segment seg;
  double start_s = 0.0, end_s = 0.0;
};

class LpfbfStream final : public plan::Sink {
 public:
  LpfbfStream(const CompensationOptions& o, CommandTable& csv)
      : o_(o), f_(csv),
        plant_x_(o.plant_x, 1.0 / o.sample_rate_hz), plant_y_(o.plant_y, 1.0 / o.sample_rate_hz),
        unc_x_(o.plant_x, 1.0 / o.sample_rate_hz), unc_y_(o.plant_y, 1.0 / o.sample_rate_hz) {}

  void consume(const plan::PlanBatch& batch) override {
    for (const plan::PlannedMove& m : batch.moves)
      if (!m.extrude_only && m.distance_mm > 0.0) on_move(m);
  }

  CompensationResult finish_all(double auto_tail_s) {
    if (!started_) throw Error("compensate: the plan has no XY motion");
    // The grid's end and the end spline, now that the last move is known.
    const double T = lay_.q * lay_.grid.h;
    const double tail = o_.tail_s >= 0.0 ? o_.tail_s : auto_tail_s;
    const int M = static_cast<int>(std::ceil((t_end_ + tail - lay_.grid.t0) / T - 1e-9));
    const std::size_t K = static_cast<std::size_t>(M) * static_cast<std::size_t>(lay_.q) + 1;
    if (M - o_.degree < o_.degree + 1)
      throw Error(fmt::format("--knot-spacing-s {}: the basis does not cover the trajectory; use a "
                              "finer knot spacing", T));
    while (pushed_ < K) push_sample(last_x_, last_y_);
    ax_->finish(K, M, last_x_);
    ay_->finish(K, M, last_y_);
    drain(true);
    r_.motion_time_s = t_end_ - t_begin_;
    r_.lead_in_s = static_cast<double>(lay_.grid.lead_steps) * lay_.grid.h;
    r_.tail_s = lay_.grid.t(K - 1) - t_end_;
    r_.basis_functions = static_cast<std::size_t>(M - o_.degree);
    r_.windows = ax_->windows();
    r_.max_held_samples = std::max(ax_->max_held_samples(), ay_->max_held_samples());
    r_.rms_tracking_error_mm = std::sqrt(sum2_ / static_cast<double>(written_));
    r_.samples = written_;
    r_.status = o_.degree < 2 ? CompensationStatus::unbounded_command_acceleration : CompensationStatus::ok;
    if (o_.degree < 2) {
      r_.peak_command_accel_mm_s2 = std::numeric_limits<double>::infinity();
      r_.message = "degree 1 B-splines have velocity steps at the knots; use --degree 2 or more";
    }
    if (non_finite_) r_.status = CompensationStatus::non_finite_command;
    return r_;
  }

  double auto_tail_s = 0.0;

 private:
  void start(const plan::PlannedMove& m) {
    // The layout needs the first move only (the end is settled in finish_all).
    const std::vector<plan::PlannedMove> one{m};
    lay_ = detail::fbf_layout_start(one.front(), o_);
    const double T = lay_.q * lay_.grid.h;
    const auto [nw, no] = detail::lpfbf_window_knots(lay_, o_);
    const detail::Basis basis = detail::make_basis(o_.degree, lay_.q, lay_.grid.h);
    x0_ = last_x_ = m.start_mm[0];
    y0_ = last_y_ = m.start_mm[1];
    ax_.emplace(o_.model_x, basis, nw, no, x0_);
    ay_.emplace(o_.model_y, basis, nw, no, y0_);
    r_.method = "lpfbf";
    r_.sample_rate_hz = o_.sample_rate_hz;
    r_.knot_spacing_s = T;
    r_.degree = o_.degree;
    r_.window_s = nw * T;
    r_.overlap_s = no * T;
    t_begin_ = m.start_time_s;
    f_.begin(false);
    started_ = true;
  }

  void on_move(const plan::PlannedMove& m) {
    if (!started_) start(m);
    // Samples before the move: the tool holds the previous end (or the first start).
    while (lay_.grid.t(pushed_) < m.start_time_s) push_sample(last_x_, last_y_);
    trajectory::Cursor cur(std::span<const plan::PlannedMove>(&m, 1));
    const double end = m.end_time_s();
    while (lay_.grid.t(pushed_) < end) {
      const trajectory::AxisState s = cur.evaluate(lay_.grid.t(pushed_));
      push_sample(s.pos_mm[0], s.pos_mm[1]);
    }
    last_x_ = m.start_mm[0] + m.axes_r[0] * m.distance_mm;
    last_y_ = m.start_mm[1] + m.axes_r[1] * m.distance_mm;
    t_end_ = end;
    HeldMove hm;
    hm.seg = {m.start_mm[0], m.start_mm[1], last_x_, last_y_};
    hm.start_s = m.start_time_s;
    hm.end_s = end;
    moves_.push_back(hm);
    r_.max_held_moves = std::max(r_.max_held_moves, moves_.size());
    drain(false);
  }

  void push_sample(double x, double y) {
    pending_.push_back({lay_.grid.t(pushed_), x, y});
    ax_->push(x);
    ay_->push(y);
    ++pushed_;
  }

  /// Checks and writes the command samples both axes have emitted (the last one waits for
  /// its successor, which the plant's velocity needs, unless `final`).
  void drain(bool final) {
    std::vector<double> cx = ax_->take_command(), cy = ay_->take_command();
    std::vector<double> axx = ax_->take_accel(), ayy = ay_->take_accel();
    cmd_.insert(cmd_.end(), cx.begin(), cx.end());
    cmdy_.insert(cmdy_.end(), cy.begin(), cy.end());
    for (std::size_t i = 0; i < axx.size(); ++i)
      r_.peak_command_accel_mm_s2 = std::max(r_.peak_command_accel_mm_s2, std::sqrt(axx[i] * axx[i] + ayy[i] * ayy[i]));
    while (cmd_.size() >= 2 || (final && !cmd_.empty())) {
      const bool last = cmd_.size() == 1;
      const double xn = last ? cmd_[0] : cmd_[1], yn = last ? cmdy_[0] : cmdy_[1];
      const auto [t, xd, yd] = pending_.front();
      const double xs = plant_x_.step(cmd_[0], xn), ys = plant_y_.step(cmdy_[0], yn);
      // Uncompensated: the sampled plan itself as the command.
      const double xdn = pending_.size() > 1 ? pending_[1].x : xd, ydn = pending_.size() > 1 ? pending_[1].y : yd;
      const double xu = unc_x_.step(xd, xdn), yu = unc_y_.step(yd, ydn);
      const double e = std::sqrt((xs - xd) * (xs - xd) + (ys - yd) * (ys - yd));
      if (!std::isfinite(e) || !std::isfinite(cmd_[0]) || !std::isfinite(cmdy_[0])) non_finite_ = true;
      r_.max_tracking_error_mm = std::max(r_.max_tracking_error_mm, e);
      sum2_ += e * e;
      // Contour: dynamics::distance_to_segments on the held moves (the definition simulate,
      // compare and the report use: searched along the path within 2 e + 0.05 mm of the move
      // at t). The desired point lies on the current move, so the distance is at most the
      // tracking error: a sample whose tracking error does not exceed the running maximum
      // cannot raise it (exact).
      while (cur_ + 1 < moves_.size() && moves_[cur_ + 1].start_s <= t) ++cur_;
      const double eu = std::sqrt((xu - xd) * (xu - xd) + (yu - yd) * (yu - yd));
      r_.uncompensated_max_tracking_error_mm = std::max(r_.uncompensated_max_tracking_error_mm, eu);
      const auto segment = [this](std::size_t i) {
        const detail::Segment& g = moves_[i].seg;
        return dynamics::PathSegment{g.x0, g.y0, g.x1, g.y1};
      };
      if (e > r_.max_contour_error_mm) {
        r_.max_contour_error_mm = std::max(
            r_.max_contour_error_mm, dynamics::distance_to_segments(segment, moves_.size(), cur_, xs, ys, 2.0 * e + 0.05));
      }
      if (eu > r_.uncompensated_max_contour_error_mm) {
        r_.uncompensated_max_contour_error_mm =
            std::max(r_.uncompensated_max_contour_error_mm,
                     dynamics::distance_to_segments(segment, moves_.size(), cur_, xu, yu, 2.0 * eu + 0.05));
      }
      f_.add(CommandSample{t, cmd_[0], cmdy_[0], xd, yd, xs, ys});
      ++written_;
      cmd_.pop_front();
      cmdy_.pop_front();
      pending_.pop_front();
    }
    // Forget the moves more than 64 behind the current one.
    while (cur_ > 64) {
      moves_.pop_front();
      --cur_;
    }
  }

  struct Pending {
    double t, x, y;
  };
  const CompensationOptions& o_;
  CommandTable& f_;
  detail::FbfLayout lay_;
  std::optional<detail::LpfbfAxis> ax_, ay_;
  StreamPlant plant_x_, plant_y_, unc_x_, unc_y_;
  bool started_ = false, non_finite_ = false;
  double x0_ = 0, y0_ = 0, last_x_ = 0, last_y_ = 0, t_begin_ = 0, t_end_ = 0, sum2_ = 0;
  std::size_t pushed_ = 0, written_ = 0, cur_ = 0;
  std::deque<Pending> pending_;
  std::deque<double> cmd_, cmdy_;
  std::deque<HeldMove> moves_;
  CompensationResult r_;
};

}  // namespace

CompensationResult compensate_file_streaming(const std::string& path, const machine::Machine& machine,
                                             const CompensationOptions& options, const std::string& csv_path) {
  CommandTable csv(csv_path, OutputOptions{"--csv", {path}, {}});
  CompensationResult r = compensate_file_streaming(path, machine, options, csv);
  csv.commit();
  return r;
}

CompensationResult compensate_file_streaming(const plan::GcodeInput& path, const machine::Machine& machine,
                                             const CompensationOptions& options, CommandTable& csv) {
  if (options.method != Method::lpfbf)
    throw Error("compensate_file_streaming: only --method lpfbf streams");
  detail::validate_options(options);
  const auto clock0 = std::chrono::steady_clock::now();
  LpfbfStream sink(options, csv);
  plan::PlanSource source(path, machine);
  std::vector<plan::Sink*> sinks{&sink};
  plan::run_pipeline(source, sinks);
  CompensationResult r = sink.finish_all(detail::auto_tail_s(options));
  r.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock0).count();
  r.real_time_factor = r.compute_time_s > 0.0 ? r.motion_time_s / r.compute_time_s : 0.0;
  detail::judge_machine_accel(r, machine, options);
  return r;
}

}  // namespace amctl::compensation
