#include "amctl/closedloop/controller.hpp"

#include <algorithm>
#include <cmath>
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
    case ControllerKind::seed003: return "seed003";
    case ControllerKind::pid: return "pid";
    case ControllerKind::best: return "best";
  }
  return "?";
}

ControllerKind controller_from_string(std::string_view name) {
  if (name == "open") return ControllerKind::open;
  if (name == "seed003") return ControllerKind::seed003;
  if (name == "pid") return ControllerKind::pid;
  if (name == "best") return ControllerKind::best;
  throw Error(fmt::format("--controller '{}': expected open, seed003, pid or best", name));
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
  require_non_negative("controller.best_kp", best_kp);
  require_non_negative("controller.best_ki_per_s", best_ki_per_s);
  require_non_negative("controller.best_kd_s", best_kd_s);
  require_non_negative("controller.latency_s", latency_s);
  require_non_negative("controller.best_drag_gain_per_s", best_drag_gain_per_s);
  require_non_negative("controller.best_load_angle_deg", best_load_angle_deg);
  require_positive("controller.best_flip_speed_mm_s", best_flip_speed_mm_s);
  require_positive("controller.best_model_mass_scale", best_model_mass_scale);
  require_positive("controller.best_model_stiffness_scale", best_model_stiffness_scale);
}

namespace {

class OpenLoop final : public Controller {
 public:
  double target_mm(const ControlInput& in) override { return in.next_ref_mm; }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::open; }
};

// Seed 003 (5)-(11). v is the law's own speed sequence (the commanded speed); (9) compares
// vbar with it, and (11) moves it by at most D* per step event.
class Seed003 final : public Controller {
 public:
  Seed003(const ControllerParameters& p, double step_mm)
      : alpha_(p.alpha_per_s), period_(p.period_s), step_mm_(step_mm) {
    d_star_ = p.max_speed_change_mm_s > 0.0 ? p.max_speed_change_mm_s
                                            : std::sqrt(2.0 * p.max_accel_mm_s2 * step_mm);
  }
  double target_mm(const ControlInput& in) override {
    // A step event, or no step due within the next period at the present speed: evaluate.
    if (in.steps_since_last > 0 || std::abs(v_) * period_ < step_mm_) {
      const double dp = in.measured_mm - in.measured_ref_mm;       // (5), (6)
      const double vbar = in.ref_vel_mm_s - alpha_ * dp;            // (7), (8)
      const double d = vbar - v_;                                   // (9), (10)
      v_ = std::abs(d) <= d_star_ ? vbar : v_ + std::copysign(d_star_, d);  // (11)
    }
    return in.command_mm + v_ * period_;
  }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::seed003; }

 private:
  double alpha_, period_, step_mm_, d_star_ = 0.0, v_ = 0.0;
};

control::PidController make_pid(double kp, double ki, double kd, double limit_mm) {
  control::PidOptions o;
  o.output_min = -limit_mm;
  o.output_max = limit_mm;
  o.anti_windup = control::AntiWindup::clamp_integral;
  return control::PidController(control::PidGains::parallel(kp, ki, kd), o);
}

class PidLoop final : public Controller {
 public:
  PidLoop(const ControllerParameters& p, const StepperAxisModel& m)
      : pid_(make_pid(p.kp, p.ki_per_s, p.kd_s, p.output_limit_mm)), period_(p.period_s),
        stretch_per_acc_(m.axis().belt.mass_kg / m.axis().belt.stiffness_n_per_m) {}
  double target_mm(const ControlInput& in) override {
    const double u = pid_.update(in.measured_ref_mm, in.measured_mm, period_);
    // Velocity feedforward: the target moves with p_ref; acceleration: belt stretch m a / k
    // (mm/s^2 * kg / (N/m) = mm).
    return in.next_ref_mm + stretch_per_acc_ * in.next_acc_mm_s2 + u;
  }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::pid; }

 private:
  control::PidController pid_;
  double period_, stretch_per_acc_;
};

// The axis as best believes it: the true one with its mass and belt stiffness scaled (the
// belt's damping ratio kept).
StepperAxisModel believed_model(const ControllerParameters& p, const StepperAxisModel& m) {
  AxisMechanics ax = m.axis();
  ax.belt.mass_kg *= p.best_model_mass_scale;
  ax.belt.stiffness_n_per_m *= p.best_model_stiffness_scale;
  ax.belt.damping_n_s_per_m *= std::sqrt(p.best_model_mass_scale * p.best_model_stiffness_scale);
  return StepperAxisModel(m.motor(), m.drive(), ax);
}

class Best final : public Controller {
 public:
  Best(const ControllerParameters& p, const StepperAxisModel& m)
      : pid_(make_pid(p.best_kp, p.best_ki_per_s, p.best_kd_s, p.output_limit_mm)),
        period_(p.period_s), drag_gain_(p.best_drag_gain_per_s),
        flip_mm_s_(p.best_flip_speed_mm_s), m_(believed_model(p, m)) {
    const double deg = p.best_load_angle_deg;
    sin_angle_ = (deg > 0.0 && deg < 90.0) ? std::sin(deg * std::numbers::pi / 180.0) : 0.0;
    current_ = m.drive().current_amplitude_a;
  }

  double target_mm(const ControlInput& in) override {
    const double u = pid_.update(in.measured_ref_mm, in.measured_mm, period_);
    // Learned drag: the steady force the integral holds, k I, correlated with the direction of
    // motion, moves into the drag estimate, which the feedforward flips with the direction (the
    // integral then unloads). Driven by the integral rather than the raw error, the estimate is
    // filtered twice and cannot ring with the loop. The drag opposes motion: never negative.
    const double dir = std::tanh(in.ref_vel_mm_s / flip_mm_s_);
    const double k = m_.axis().belt.stiffness_n_per_m;
    drag_n_ = std::max(0.0, drag_n_ + drag_gain_ * period_ * k * pid_.integral() * 1e-3 * dir);
    // The force the reference needs next period from the model (inertia, rail friction) and
    // the learned drag; the integral holds the rest as a lead k I (it is not fed forward again).
    const double f = force_n(in.next_vel_mm_s, in.next_acc_mm_s2);
    const double r = m_.pulley_radius_m();
    const double w = in.next_vel_mm_s * 1e-3 / r;
    const double tau = r * f + m_.inertia_kg_m2() * in.next_acc_mm_s2 * 1e-3 / r +
                       m_.motor().rotor_damping_n_m_s_per_rad * w;
    if (sin_angle_ > 0.0) {
      // Current sized so that the torque is reached at the design load angle (closed-loop
      // current scaling): the larger of the model's torque and the torque the measured lead
      // implies. The lead of the command over the head (belt stretch plus the rotor's lag) times
      // the belt stiffness over-estimates the belt force by the lag's share, so it errs on the
      // side of more current; it rises as soon as a load holds the head back, before any
      // integral has learned it. Never below the run current, never above the drive's maximum.
      const double kt = m_.motor().torque_constant_n_m_per_a();
      const double f_lead = k * (in.command_mm - in.measured_mm) * 1e-3;
      const double tau_need = std::max(std::abs(tau), r * std::abs(f_lead));
      current_ = std::clamp(tau_need / (kt * sin_angle_), m_.drive().current_amplitude_a,
                            m_.max_current_a());
    }
    return in.next_ref_mm + lead_mm(f, tau, w) + u;
  }
  [[nodiscard]] double current_request_a() const override { return current_; }
  [[nodiscard]] ControllerKind kind() const override { return ControllerKind::best; }

 private:
  // Force on the carriage the reference asks for, from the model and the learned drag [N].
  [[nodiscard]] double force_n(double v_mm_s, double a_mm_s2) const {
    const AxisMechanics& ax = m_.axis();
    const double v = v_mm_s * 1e-3;
    return ax.belt.mass_kg * a_mm_s2 * 1e-3 +
           ax.coulomb_friction_n * std::tanh(v / ax.friction_smoothing_m_s) +
           drag_n_ * std::tanh(v_mm_s / flip_mm_s_) + ax.viscous_friction_n_s_per_m * v;
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
           0.5 * ax.backlash_mm * std::tanh(f / 0.5);
  }
  control::PidController pid_;
  double period_, drag_gain_, flip_mm_s_, sin_angle_ = 0.0;
  double drag_n_ = 0.0, current_ = 0.0;
  StepperAxisModel m_;  // a copy: the caller's model may move
};

}  // namespace

LoopAnalysis analyse_loop(ControllerKind kind, const ControllerParameters& p,
                          const StepperAxisModel& model) {
  p.validate();
  const double r = model.pulley_radius_m();
  const double mr = model.inertia_kg_m2() / (r * r);
  const double km = model.magnetic_stiffness_n_m_per_rad() / (r * r);
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
  // X = [z(4), s, x_{k-1} .. x_{k-d}, I, y_prev]
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
  M.row(iy) = ym;
  double kp = 0.0, ki = 0.0, kd = 0.0;
  switch (kind) {
    case ControllerKind::open:
      break;  // s' = 0 (the reference, zero in the linearisation)
    case ControllerKind::seed003:
      M(is, is) = 1.0;
      M.row(is) -= p.alpha_per_s * p.period_s * ym;
      break;
    case ControllerKind::pid:
      kp = p.kp, ki = p.ki_per_s, kd = p.kd_s;
      break;
    case ControllerKind::best:
      kp = p.best_kp, ki = p.best_ki_per_s, kd = p.best_kd_s;
      break;
  }
  if (kind == ControllerKind::pid || kind == ControllerKind::best) {
    // s' = kp e + I - kd (y - y_prev) / T,  I' = I + ki T e,  e = -y.
    M.row(is) = -kp * ym - (kd / p.period_s) * ym;
    M(is, ii) += 1.0;
    M(is, iy) += kd / p.period_s;
    M.row(ii) = -ki * p.period_s * ym;
    if (ki > 0.0) M(ii, ii) += 1.0;  // without integral action the state is unused
  }
  Eigen::EigenSolver<Eigen::MatrixXd> es(M, false);
  LoopAnalysis out;
  out.states = n;
  for (int i = 0; i < n; ++i) out.spectral_radius = std::max(out.spectral_radius, std::abs(es.eigenvalues()(i)));
  out.stable = std::isfinite(out.spectral_radius) && out.spectral_radius < 1.0;
  return out;
}

void require_stable_loop(ControllerKind kind, const ControllerParameters& p,
                         const StepperAxisModel& model, const std::string& axis_name) {
  const LoopAnalysis a = analyse_loop(kind, p, model);
  if (a.stable) return;
  std::string gains;
  switch (kind) {
    case ControllerKind::open: gains = "(no feedback)"; break;
    case ControllerKind::seed003: gains = fmt::format("alpha_per_s = {}", p.alpha_per_s); break;
    case ControllerKind::pid:
      gains = fmt::format("kp = {}, ki_per_s = {}, kd_s = {}", p.kp, p.ki_per_s, p.kd_s);
      break;
    case ControllerKind::best:
      gains = fmt::format("best_kp = {}, best_ki_per_s = {}, best_kd_s = {}", p.best_kp,
                          p.best_ki_per_s, p.best_kd_s);
      break;
  }
  throw Error(fmt::format(
      "controller {} on axis {}: gains {} make the loop unstable (spectral radius {:.4f} >= 1 "
      "of the linearised loop at period {} s, latency {} s); lower the gains",
      to_string(kind), axis_name, gains, a.spectral_radius, p.period_s, p.latency_s));
}

std::unique_ptr<Controller> make_controller(ControllerKind kind, const ControllerParameters& p,
                                            const StepperAxisModel& model) {
  p.validate();
  switch (kind) {
    case ControllerKind::open: return std::make_unique<OpenLoop>();
    case ControllerKind::seed003: return std::make_unique<Seed003>(p, model.step_distance_mm());
    case ControllerKind::pid: return std::make_unique<PidLoop>(p, model);
    case ControllerKind::best: return std::make_unique<Best>(p, model);
  }
  AMCTL_CHECK(false, "unknown controller kind");
  return nullptr;
}

}  // namespace amctl::closedloop
