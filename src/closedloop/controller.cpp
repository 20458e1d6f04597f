#include "amctl/closedloop/controller.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <deque>
#include <limits>
#include <vector>
#include <numbers>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "amctl/control/discretize.hpp"
#include "amctl/control/state_space.hpp"
#include "amctl/core/error.hpp"

namespace amctl::closedloop {

const char* to_string(ControllerKind k) {
  switch (k) {
    case ControllerKind::open: return "open";
    case ControllerKind::encoder_sequenced: return "encoder-sequenced";
    case ControllerKind::speed_tracking: return "speed-tracking";
    case ControllerKind::pid: return "pid";
    case ControllerKind::feedforward: return "feedforward";
  }
  return "?";
}

ControllerKind controller_from_string(std::string_view name) {
  for (ControllerKind k : all_controllers()) {
    if (name == to_string(k)) return k;
  }
  if (name == "seed003") return ControllerKind::speed_tracking;
  if (name == "best") return ControllerKind::feedforward;
  throw Error(fmt::format("--controller '{}': expected open, encoder-sequenced, speed-tracking, "
                          "pid or feedforward",
                          name));
}

std::optional<std::string> controller_alias_note(std::string_view name) {
  if (name == "seed003") {
    return std::string("--controller seed003 is now 'speed-tracking' (the paper's speed law read "
                       "against the time-based reference); the law as published is "
                       "'encoder-sequenced'. The old name goes in the next release.");
  }
  if (name == "best") {
    return std::string("--controller best is now 'feedforward' (model feed-forward with current "
                       "scaling). The old name goes in the next release.");
  }
  return std::nullopt;
}

std::span<const ControllerKind> all_controllers() {
  static constexpr ControllerKind kAll[] = {ControllerKind::open, ControllerKind::encoder_sequenced,
                                            ControllerKind::speed_tracking, ControllerKind::pid,
                                            ControllerKind::feedforward};
  return kAll;
}

void ControllerParameters::validate() const {
  require_positive("controller.period_s", period_s);
  require_non_negative("controller.alpha_per_s", alpha_per_s);
  require_finite("controller.max_speed_change_mm_s", max_speed_change_mm_s);
  require_positive("controller.max_accel_mm_s2", max_accel_mm_s2);
  require_non_negative("controller.kp", kp);
  require_non_negative("controller.ki_per_s", ki_per_s);
  require_non_negative("controller.kd_s", kd_s);
  require_positive("controller.output_limit_mm", output_limit_mm);
  require_non_negative("controller.derivative_filter_s", derivative_filter_s);
  require_non_negative("controller.ff_kp", ff_kp);
  require_non_negative("controller.ff_ki_per_s", ff_ki_per_s);
  require_non_negative("controller.ff_kd_s", ff_kd_s);
  require_non_negative("controller.latency_s", latency_s);
  require_non_negative("controller.ff_drag_gain_per_s", ff_drag_gain_per_s);
  require_non_negative("controller.ff_load_angle_deg", ff_load_angle_deg);
  require_positive("controller.ff_flip_speed_mm_s", ff_flip_speed_mm_s);
  require_positive("controller.ff_model_mass_scale", ff_model_mass_scale);
  require_positive("controller.ff_model_stiffness_scale", ff_model_stiffness_scale);
}

namespace {

class OpenLoop final : public Controller {
 public:
  double target_mm(const ControlInput& in) override { return in.next_ref_mm; }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::open; }
};

double d_star_mm_s(const ControllerParameters& p, double step_mm) {
  return p.max_speed_change_mm_s > 0.0 ? p.max_speed_change_mm_s
                                       : std::sqrt(2.0 * p.max_accel_mm_s2 * step_mm);
}

// The paper's law (5)-(11) as published: the axis executes its own command sequence h; the
// position-judgement module moves to h + 1 when the encoder reads p = p*(h); between, the speed
// law runs per step event. Reading choices (docs/closedloop.md, section 3): "p = p*(h)" is taken
// as "within half a microstep of p*(h), or past it in the command's direction" (the encoder's
// 0.49 um counts never equal a 12.5 um step grid); v(k) of (9) and (11) is the measured speed
// (encoder distance over the time since the last event); a period with n > 1 steps is n events
// on one reading (D* n); with no step due at the present speed the law is also evaluated once
// per period, so it can start from rest; after the last command the axis holds p* of it with
// v* = 0.
class EncoderSequenced final : public Controller {
 public:
  EncoderSequenced(const ControllerParameters& p, double step_mm, double start_mm)
      : alpha_(p.alpha_per_s), period_(p.period_s), step_mm_(step_mm),
        d_star_(d_star_mm_s(p, step_mm)), from_(start_mm), p_event_(start_mm) {}

  void push_command(const AxisCommand& c) override {
    const double last = queue_.empty() ? (pushed_ ? last_pushed_ : from_) : queue_.back().target_mm;
    // A command that does not move this axis is no command of its sequence.
    if (std::abs(c.target_mm - last) < 0.5 * step_mm_) return;
    queue_.push_back(c);
    last_pushed_ = c.target_mm;
    pushed_ = true;
  }

  double target_mm(const ControlInput& in) override {
    const double p = in.measured_mm;
    // Position judgement: p = p*(h) -> read the next command.
    while (!queue_.empty() && reached(p, queue_.front().target_mm)) {
      from_ = queue_.front().target_mm;
      queue_.pop_front();
      ++reached_;
    }
    const bool event = in.steps_since_last > 0 || std::abs(v_) * period_ < step_mm_;
    if (event) {
      const double dt = in.t_s - t_event_;
      const double v_meas = (started_ && dt > 0.0) ? (p - p_event_) / dt : 0.0;
      started_ = true;
      p_event_ = p;
      t_event_ = in.t_s;
      double p_star = from_, v_star = 0.0;
      if (!queue_.empty()) {
        p_star = queue_.front().target_mm;
        v_star = std::copysign(queue_.front().speed_mm_s, p_star - from_);
      }
      const double dp = p - p_star;                                  // (5), (6)
      const double vbar = v_star - alpha_ * dp;                      // (7), (8)
      const double d = vbar - v_meas;                                // (9), (10)
      const double d_max = d_star_ * static_cast<double>(std::max<std::uint64_t>(1, in.steps_since_last));
      v_ = std::abs(d) <= d_max ? vbar : v_meas + std::copysign(d_max, d);  // (11)
    }
    return in.command_mm + v_ * period_;
  }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::encoder_sequenced; }
  // Done when the sequence is empty and the encoder reads the last point within a microstep.
  [[nodiscard]] bool finished() const override {
    return queue_.empty() && std::abs(p_event_ - from_) <= step_mm_;
  }
  [[nodiscard]] std::optional<std::pair<double, double>> active_segment() const override {
    if (queue_.empty()) return std::pair{from_, from_};
    return std::pair{from_, queue_.front().target_mm};
  }
  [[nodiscard]] std::uint64_t commands_reached() const override { return reached_; }
  [[nodiscard]] std::uint64_t commands_pending() const override { return queue_.size(); }
  [[nodiscard]] bool sequenced() const override { return true; }

 private:
  [[nodiscard]] bool reached(double p, double target) const {
    const double dir = target - from_;
    if (std::abs(p - target) <= 0.5 * step_mm_) return true;
    return dir > 0.0 ? p >= target : p <= target;
  }
  double alpha_, period_, step_mm_, d_star_;
  std::deque<AxisCommand> queue_;
  double from_;                     // p* of the last command reached (the segment's start)
  double last_pushed_ = 0.0;
  bool pushed_ = false;
  double v_ = 0.0;                  // commanded speed for the next step interval
  double p_event_, t_event_ = 0.0;  // encoder reading and time of the last step event
  bool started_ = false;
  std::uint64_t reached_ = 0;
};

// The speed law (5)-(11) read as a tracking controller: dp against the time-based reference at
// the measured instant, v* the reference's speed, v(k) the law's own commanded speed (which
// (11) updates; where the governor held the command, the speed it applied).
class SpeedTracking final : public Controller {
 public:
  SpeedTracking(const ControllerParameters& p, double step_mm)
      : alpha_(p.alpha_per_s), period_(p.period_s), step_mm_(step_mm), d_star_(d_star_mm_s(p, step_mm)) {}
  double target_mm(const ControlInput& in) override {
    if (in.limited) v_ = in.command_speed_mm_s;
    // A step event, or no step due within the next period at the present speed: evaluate.
    if (in.steps_since_last > 0 || std::abs(v_) * period_ < step_mm_) {
      const double dp = in.measured_mm - in.measured_ref_mm;       // (5), (6)
      const double vbar = in.ref_vel_mm_s - alpha_ * dp;            // (7), (8)
      const double d = vbar - v_;                                   // (9), (10)
      v_ = std::abs(d) <= d_star_ ? vbar : v_ + std::copysign(d_star_, d);  // (11)
    }
    return in.command_mm + v_ * period_;
  }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::speed_tracking; }

 private:
  double alpha_, period_, step_mm_, d_star_, v_ = 0.0;
};

// A position PID on the encoder: derivative on the error (the setpoint moves with the plan: a
// derivative on the measurement alone would pull back by kd v at every speed v) filtered by
// a first-order low-pass of time constant Tf (the encoder's 0.49 um counts differentiated at
// 10 kHz are noise), output and integral clamped to +-limit, the integral advanced only while
// the governor passed the last command as wanted and the move is not degraded (conditional
// integration). analyse_loop linearises exactly this.
class Pid {
 public:
  Pid(double kp, double ki, double kd, double tf, double period, double limit)
      : kp_(kp), ki_(ki), kd_(kd), a_(period / (tf + period)), limit_(limit) {}
  double update(double setpoint, double y, double T, bool integrate) {
    const double e = setpoint - y;
    if (integrate) integral_ = std::clamp(integral_ + ki_ * T * e, -limit_, limit_);
    if (first_) ef_ = e;
    const double ef = ef_ + a_ * (e - ef_);
    const double deriv = kd_ * (ef - ef_) / T;
    first_ = false;
    ef_ = ef;
    return std::clamp(kp_ * e + integral_ + deriv, -limit_, limit_);
  }
  [[nodiscard]] double integral() const { return integral_; }

 private:
  double kp_, ki_, kd_, a_, limit_, integral_ = 0.0, ef_ = 0.0;
  bool first_ = true;
};

// tanh, exactly +-1 beyond |x| = 20 (where it rounds to +-1 in double precision anyway).
double smooth_sign(double x) { return fast_tanh(x); }

bool integrating(const ControlInput& in) {
  return !in.limited && (in.limits == nullptr || in.limits->feasible);
}
bool accel_lead(const ControlInput& in) { return in.limits == nullptr || in.limits->accel_lead; }

class PidLoop final : public Controller {
 public:
  PidLoop(const ControllerParameters& p, const StepperAxisModel& m)
      : pid_(p.kp, p.ki_per_s, p.kd_s, p.derivative_filter_s, p.period_s, p.output_limit_mm), period_(p.period_s),
        stretch_per_acc_(m.axis().belt.mass_kg / m.axis().belt.stiffness_n_per_m) {}
  double target_mm(const ControlInput& in) override {
    const double u = pid_.update(in.measured_ref_mm, in.measured_mm, period_, integrating(in));
    // Velocity feed-forward: the target moves with p_ref; acceleration: belt stretch m a / k
    // (mm/s^2 * kg / (N/m) = mm), where the governor finds it fits the belt mode.
    lead_ = accel_lead(in) ? stretch_per_acc_ * in.next_acc_mm_s2 : 0.0;
    return in.next_ref_mm + lead_ + u;
  }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::pid; }
  [[nodiscard]] double lead_mm() const override { return lead_; }

 private:
  Pid pid_;
  double period_, stretch_per_acc_, lead_ = 0.0;
};

// The axis as the feed-forward believes it: the true one with its mass and belt stiffness
// scaled (the belt's damping ratio kept).
StepperAxisModel believed_model(const ControllerParameters& p, const StepperAxisModel& m) {
  AxisMechanics ax = m.axis();
  ax.belt.mass_kg *= p.ff_model_mass_scale;
  ax.belt.stiffness_n_per_m *= p.ff_model_stiffness_scale;
  ax.belt.damping_n_s_per_m *= std::sqrt(p.ff_model_mass_scale * p.ff_model_stiffness_scale);
  return StepperAxisModel(m.motor(), m.drive(), ax);
}

class Feedforward final : public Controller {
 public:
  Feedforward(const ControllerParameters& p, const StepperAxisModel& m)
      : pid_(p.ff_kp, p.ff_ki_per_s, p.ff_kd_s, p.derivative_filter_s, p.period_s, p.output_limit_mm), period_(p.period_s),
        drag_gain_(p.ff_drag_gain_per_s), flip_mm_s_(p.ff_flip_speed_mm_s), m_(believed_model(p, m)) {
    const double deg = p.ff_load_angle_deg;
    sin_angle_ = (deg > 0.0 && deg < 90.0) ? std::sin(deg * std::numbers::pi / 180.0) : 0.0;
    if (sin_angle_ > 0.0) inv_kt_sin_ = 1.0 / (m_.motor().torque_constant_n_m_per_a() * sin_angle_);
    current_ = m.drive().current_amplitude_a;
  }

  double target_mm(const ControlInput& in) override {
    const bool integrate = integrating(in);
    const double u = pid_.update(in.measured_ref_mm, in.measured_mm, period_, integrate);
    // Learned drag: the steady force the integral holds, k I, correlated with the direction of
    // motion, moves into the drag estimate, which the feed-forward flips with the direction (the
    // integral then unloads). Driven by the integral rather than the raw error, the estimate is
    // filtered twice and cannot ring with the loop. The drag opposes motion: never negative.
    const double dir = smooth_sign(in.ref_vel_mm_s / flip_mm_s_);
    const double k = m_.axis().belt.stiffness_n_per_m;
    if (integrate) {
      drag_n_ = std::max(0.0, drag_n_ + drag_gain_ * period_ * k * pid_.integral() * 1e-3 * dir);
    }
    // The force the reference needs next period from the model (inertia where the governor
    // lets the acceleration lead in, rail friction) and the learned drag; the integral holds
    // the rest as a lead k I (it is not fed forward again).
    const double acc = accel_lead(in) ? in.next_acc_mm_s2 : 0.0;
    const double r = m_.pulley_radius_m();
    // The model's force and torque change only with the reference's speed and acceleration,
    // the learned drag and the current: recomputed when one of them moved.
    const bool same = acc == acc_ && std::abs(in.next_vel_mm_s - vel_) < 1e-3 &&
                      std::abs(drag_n_ - drag_at_) < 1e-4 && current_ == current_at_;
    if (!same) {
      acc_ = acc;
      vel_ = in.next_vel_mm_s;
      drag_at_ = drag_n_;
      f_ = force_n(in.next_vel_mm_s, acc);
      const double w = in.next_vel_mm_s * 1e-3 / r;
      tau_ = r * f_ + m_.inertia_kg_m2() * acc * 1e-3 / r + m_.motor().rotor_damping_n_m_s_per_rad * w;
      w_ = w;
    }
    const double f = f_, tau = tau_, w = w_;
    if (sin_angle_ > 0.0) {
      // Current sized so that the torque is reached at the design load angle (closed-loop
      // current scaling): the larger of the model's torque and the torque the measured lead
      // implies. The lead of the command over the head (belt stretch plus the rotor's lag) times
      // the belt stiffness over-estimates the belt force by the lag's share, so it errs on the
      // side of more current; it rises as soon as a load holds the head back, before any
      // integral has learned it. Never below the run current, never above the drive's maximum
      // (the motor's rating unless the drive says less).
      const double f_lead = k * (in.command_mm - in.measured_mm) * 1e-3;
      const double tau_need = std::max(std::abs(tau), r * std::abs(f_lead));
      current_ = std::clamp(tau_need * inv_kt_sin_, m_.drive().current_amplitude_a,
                            m_.max_current_a());
    }
    if (!same || current_ != current_at_) {
      current_at_ = current_;
      lead_ = lead_mm(f, tau, w);
    }
    return in.next_ref_mm + lead_ + u;
  }
  [[nodiscard]] double current_request_a() const override { return current_; }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::feedforward; }
  [[nodiscard]] double lead_mm() const override { return lead_; }

 private:
  // Force on the carriage the reference asks for, from the model and the learned drag [N].
  [[nodiscard]] double force_n(double v_mm_s, double a_mm_s2) const {
    const AxisMechanics& ax = m_.axis();
    const double v = v_mm_s * 1e-3;
    return ax.belt.mass_kg * a_mm_s2 * 1e-3 +
           ax.coulomb_friction_n * smooth_sign(v / ax.friction_smoothing_m_s) +
           drag_n_ * smooth_sign(v_mm_s / flip_mm_s_) + ax.viscous_friction_n_s_per_m * v;
  }
  // Where the motor must be ahead of the carriage to produce force f: belt stretch f / k, the
  // backlash's half on the side the belt pulls, and the rotor's load angle asin(tau / T_po) / p
  // at the current it runs.
  [[nodiscard]] double lead_mm(double f, double tau, double w) const {
    const AxisMechanics& ax = m_.axis();
    const double po = std::max(m_.pull_out_torque_at_n_m(w, current_), 1e-9);
    const double d = std::asin(std::clamp(tau / po, -0.95, 0.95));
    const double r = m_.pulley_radius_m();
    return 1e3 * (f / ax.belt.stiffness_n_per_m + r * d / m_.motor().pole_pairs()) +
           (ax.backlash_mm == 0.0 ? 0.0 : 0.5 * ax.backlash_mm * fast_tanh(f / 0.5));
  }
  Pid pid_;
  double period_, drag_gain_, flip_mm_s_, sin_angle_ = 0.0;
  double drag_n_ = 0.0, current_ = 0.0, lead_ = 0.0, inv_kt_sin_ = 0.0;
  // The last model evaluation and what it was made at (NaN: none yet).
  double acc_ = std::numeric_limits<double>::quiet_NaN(), vel_ = 0.0, drag_at_ = 0.0,
         current_at_ = 0.0, f_ = 0.0, tau_ = 0.0, w_ = 0.0;
  StepperAxisModel m_;  // a copy: the caller's model may move
};

}  // namespace

LoopAnalysis analyse_loop(ControllerKind kind, const ControllerParameters& p,
                          const StepperAxisModel& model, double load_angle_rad) {
  p.validate();
  const double r = model.pulley_radius_m();
  const double mr = model.inertia_kg_m2() / (r * r);
  // The magnetic spring at load angle d: d/d(p th) of Kt I sin(d), p Kt I cos d (the detent's
  // 4-per-cycle ripple, +-4 p T_det, averages out along a move and is left out there); at rest
  // p (Kt I + 4 T_det), the rotor sitting in a detent.
  const double km = (load_angle_rad == 0.0
                         ? model.magnetic_stiffness_n_m_per_rad()
                         : model.motor().pole_pairs() * model.pull_out_torque_n_m() * std::cos(load_angle_rad)) /
                    (r * r);
  const double br = model.motor().rotor_damping_n_m_s_per_rad / (r * r);
  const AxisMechanics& ax = model.axis();
  const double k = ax.belt.stiffness_n_per_m, c = ax.belt.damping_n_s_per_m, m = ax.belt.mass_kg;
  const double cv = ax.viscous_friction_n_s_per_m;
  // z = [q, q', x, x'] (rotor as belt travel r theta, carriage), input s (motor command).
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(4, 4);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(4);
  a(0, 1) = 1.0;
  a(1, 0) = (-km - k) / mr;
  a(1, 1) = (-br - c) / mr;
  a(1, 2) = k / mr;
  a(1, 3) = c / mr;
  b(1) = km / mr;
  a(2, 3) = 1.0;
  a(3, 0) = k / m;
  a(3, 1) = c / m;
  a(3, 2) = -k / m;
  a(3, 3) = (-c - cv) / m;
  Eigen::RowVectorXd cx = Eigen::RowVectorXd::Zero(4);
  cx(2) = 1.0;
  const control::Discretization dz =
      control::discretize_zoh(control::StateSpace::siso(a, b, cx), p.period_s);
  const int d = static_cast<int>(std::lround(p.latency_s / p.period_s));
  // X = [z(4), s, x_{k-1} .. x_{k-d}, I, e_f] (e_f: the PID's filtered error)
  const int is = 4, id0 = 5, ii = 5 + d, iy = 6 + d, n = 7 + d;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
  Eigen::RowVectorXd ym = Eigen::RowVectorXd::Zero(n);  // the measurement used at k
  if (d == 0) ym(2) = 1.0; else ym(id0 + d - 1) = 1.0;
  M.block(0, 0, 4, 4) = dz.Phi;
  M.block(0, is, 4, 1) = dz.Gamma0;
  if (d > 0) {
    M(id0, 2) = 1.0;
    for (int j = 1; j < d; ++j) M(id0 + j, id0 + j - 1) = 1.0;
  }
  double kp = 0.0, ki = 0.0, kd = 0.0;
  switch (kind) {
    case ControllerKind::open:
      break;  // s' = 0 (the reference, zero in the linearisation)
    case ControllerKind::speed_tracking:
    case ControllerKind::encoder_sequenced:
      M(is, is) = 1.0;
      M.row(is) -= p.alpha_per_s * p.period_s * ym;
      break;
    case ControllerKind::pid:
      kp = p.kp, ki = p.ki_per_s, kd = p.kd_s;
      break;
    case ControllerKind::feedforward:
      kp = p.ff_kp, ki = p.ff_ki_per_s, kd = p.ff_kd_s;
      break;
  }
  if (kind == ControllerKind::pid || kind == ControllerKind::feedforward) {
    // e = -y; I' = I + ki T e; the filtered error e_f' = (1 - a) e_f + a e, a = T / (Tf + T);
    // s' = kp e + I' + kd (e_f' - e_f) / T = (kp + ki T) e + I + (kd a / T) (e - e_f).
    const double T = p.period_s, a = T / (p.derivative_filter_s + T);
    M.row(is) = -(kp + ki * T + kd * a / T) * ym;
    M(is, ii) += 1.0;
    M(is, iy) -= kd * a / T;
    M.row(ii) = -ki * T * ym;
    if (ki > 0.0) M(ii, ii) += 1.0;  // without integral action the state is unused
    M.row(iy) = -a * ym;
    M(iy, iy) += 1.0 - a;
  }
  Eigen::EigenSolver<Eigen::MatrixXd> es(M, false);
  LoopAnalysis out;
  out.states = n;
  const double arg_min = 2.0 * std::numbers::pi * 5.0 * p.period_s;
  if (!M.allFinite() || es.info() != Eigen::Success) {
    // No eigenvalues to trust (a gain overflowing the loop matrix): not a stable loop.
    out.spectral_radius = out.oscillatory_radius = std::numeric_limits<double>::infinity();
    return out;
  }
  for (int i = 0; i < n; ++i) {
    const std::complex<double> l = es.eigenvalues()(i);
    // A NaN (an overflowing gain, 1e308) is no radius below 1.
    const double m = std::isfinite(std::abs(l)) ? std::abs(l) : std::numeric_limits<double>::infinity();
    out.spectral_radius = std::max(out.spectral_radius, m);
    if (std::abs(std::arg(l)) > arg_min) out.oscillatory_radius = std::max(out.oscillatory_radius, std::abs(l));
  }
  out.stable = std::isfinite(out.spectral_radius) && out.spectral_radius < 1.0;
  return out;
}

ControllerParameters fit_default_gains(ControllerKind kind, const ControllerParameters& p,
                                      const StepperAxisModel& model, double design_load_angle_rad,
                                      double& scale) {
  // Robust stability over the plant's uncertainty, not a fixed large margin: the loop with
  // every gain times kGainMargin (1.5, 3.5 dB: what the linearisation leaves out, the current
  // lagging its reference, the microstep quantisation, the detent's ripple) must be stable
  // for every plant of the uncertainty set: the rotor's spring at rest and at the design
  // angle, the carriage mass and the belt stiffness each at (1 -+ kModelUncertainty) of their
  // nominal values (corners and centre). A loop that leaves the set's edge would still ring up
  // the belt mode; a slip beyond it is the lead cap's to prevent (section 3.1), which earlier
  // needed a fixed margin of 3 (the Voron V0 box at 420 mm/s lost 28 full steps at margin 2).
  // Multiplying kp, ki and kd together scales the controller's whole transfer function.
  std::vector<StepperAxisModel> plants;
  for (double fm : {1.0, 1.0 - kModelUncertainty, 1.0 + kModelUncertainty}) {
    for (double fk : {1.0, 1.0 - kModelUncertainty, 1.0 + kModelUncertainty}) {
      if ((fm == 1.0) != (fk == 1.0)) continue;  // the centre and the four corners
      AxisMechanics ax = model.axis();
      ax.belt.mass_kg *= fm;
      ax.belt.stiffness_n_per_m *= fk;
      plants.emplace_back(model.motor(), model.drive(), ax);
    }
  }
  auto ok = [&](const ControllerParameters& g) {
    ControllerParameters g2 = g;
    g2.kp *= kGainMargin;
    g2.ki_per_s *= kGainMargin;
    g2.kd_s *= kGainMargin;
    g2.ff_kp *= kGainMargin;
    g2.ff_ki_per_s *= kGainMargin;
    g2.ff_kd_s *= kGainMargin;
    g2.alpha_per_s *= kGainMargin;
    for (const StepperAxisModel& plant : plants) {
      for (double angle : {0.0, design_load_angle_rad}) {
        if (analyse_loop(kind, g2, plant, angle).spectral_radius >= 0.9995) return false;
        // Never ringing longer than open loop: at the gains themselves the loop's oscillatory
        // modes (the belt's, the rotor's) die away at least as fast as open loop's do.
        if (analyse_loop(kind, g2, plant, angle).oscillatory_radius >
            analyse_loop(ControllerKind::open, g, plant, angle).oscillatory_radius + 1e-12) {
          return false;
        }
      }
    }
    return true;
  };
  ControllerParameters g = p;
  scale = 1.0;
  for (int i = 0; i < 40; ++i) {
    g.kp = p.kp * scale;
    g.ki_per_s = p.ki_per_s * scale;
    g.ff_kp = p.ff_kp * scale;
    g.ff_ki_per_s = p.ff_ki_per_s * scale;
    g.alpha_per_s = p.alpha_per_s * scale;
    if (ok(g)) return g;
    scale *= 0.9;
  }
  scale = 0.0;
  return p;
}

void require_stable_loop(ControllerKind kind, const ControllerParameters& p,
                         const StepperAxisModel& model, const std::string& axis_name,
                         double design_load_angle_rad) {
  // At rest and at the design load angle, where the rotor's spring is softest (the loop's
  // gain through it lowest, its phase worst); the governor keeps the rotor within.
  double angle = 0.0;
  LoopAnalysis a = analyse_loop(kind, p, model, 0.0);
  if (a.stable && design_load_angle_rad > 0.0) {
    a = analyse_loop(kind, p, model, design_load_angle_rad);
    angle = design_load_angle_rad;
  }
  if (a.stable) return;
  std::string gains;
  switch (kind) {
    case ControllerKind::open: gains = "(no feedback)"; break;
    case ControllerKind::speed_tracking:
    case ControllerKind::encoder_sequenced:
      gains = fmt::format("alpha_per_s = {}", p.alpha_per_s);
      break;
    case ControllerKind::pid:
      gains = fmt::format("kp = {}, ki_per_s = {}, kd_s = {}", p.kp, p.ki_per_s, p.kd_s);
      break;
    case ControllerKind::feedforward:
      gains = fmt::format("kp = {}, ki_per_s = {}, kd_s = {}", p.ff_kp, p.ff_ki_per_s, p.ff_kd_s);
      break;
  }
  throw Error(fmt::format(
      "controller {} on axis {}: gains {} make the loop unstable (spectral radius {:.4f} >= 1 "
      "of the linearised loop at load angle {:.0f} deg, period {} s, latency {} s, run current "
      "{:.2f} A); lower the gains",
      to_string(kind), axis_name, gains, a.spectral_radius, angle * 180.0 / std::numbers::pi,
      p.period_s, p.latency_s, model.drive().current_amplitude_a));
}

std::unique_ptr<Controller> make_controller(ControllerKind kind, const ControllerParameters& p,
                                            const StepperAxisModel& model, double start_mm) {
  p.validate();
  switch (kind) {
    case ControllerKind::open: return std::make_unique<OpenLoop>();
    case ControllerKind::encoder_sequenced:
      return std::make_unique<EncoderSequenced>(p, model.step_distance_mm(), start_mm);
    case ControllerKind::speed_tracking:
      return std::make_unique<SpeedTracking>(p, model.step_distance_mm());
    case ControllerKind::pid: return std::make_unique<PidLoop>(p, model);
    case ControllerKind::feedforward: return std::make_unique<Feedforward>(p, model);
  }
  AMCTL_CHECK(false, "unknown controller kind");
  return nullptr;
}

}  // namespace amctl::closedloop
