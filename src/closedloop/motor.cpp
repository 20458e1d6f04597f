#include "amctl/closedloop/motor.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "amctl/core/error.hpp"

namespace amctl::closedloop {
namespace {

void positive(const char* prefix, const char* field, double v) {
  require_positive(std::string(prefix) + "." + field, v);
}
void non_negative(const char* prefix, const char* field, double v) {
  require_non_negative(std::string(prefix) + "." + field, v);
}

}  // namespace

double MotorParameters::torque_constant_n_m_per_a() const {
  return holding_torque_n_m / (std::numbers::sqrt2 * rated_current_a);
}

void MotorParameters::validate(const char* prefix) const {
  positive(prefix, "holding_torque_n_m", holding_torque_n_m);
  positive(prefix, "rated_current_a", rated_current_a);
  positive(prefix, "phase_resistance_ohm", phase_resistance_ohm);
  positive(prefix, "phase_inductance_h", phase_inductance_h);
  positive(prefix, "rotor_inertia_kg_m2", rotor_inertia_kg_m2);
  non_negative(prefix, "detent_torque_n_m", detent_torque_n_m);
  non_negative(prefix, "rotor_damping_n_m_s_per_rad", rotor_damping_n_m_s_per_rad);
  if (full_steps_per_rotation <= 0 || full_steps_per_rotation % 4 != 0) {
    throw Error(std::string(prefix) + ".full_steps_per_rotation = " +
                std::to_string(full_steps_per_rotation) +
                ": expected a positive multiple of 4 (a two-phase hybrid stepper)");
  }
}

void DriveParameters::validate(const char* prefix) const {
  positive(prefix, "supply_voltage_v", supply_voltage_v);
  positive(prefix, "current_amplitude_a", current_amplitude_a);
  positive(prefix, "current_loop_bandwidth_hz", current_loop_bandwidth_hz);
  positive(prefix, "max_step_rate_hz", max_step_rate_hz);
  non_negative(prefix, "max_current_a", max_current_a);
  if (microsteps <= 0) {
    throw Error(std::string(prefix) + ".microsteps = " + std::to_string(microsteps) +
                ": expected a positive number of microsteps per full step");
  }
}

void AxisMechanics::validate(const char* prefix) const {
  positive(prefix, "rotation_distance_mm", rotation_distance_mm);
  non_negative(prefix, "pulley_inertia_kg_m2", pulley_inertia_kg_m2);
  positive(prefix, "belt.mass_kg", belt.mass_kg);
  positive(prefix, "belt.stiffness_n_per_m", belt.stiffness_n_per_m);
  non_negative(prefix, "belt.damping_n_s_per_m", belt.damping_n_s_per_m);
  non_negative(prefix, "coulomb_friction_n", coulomb_friction_n);
  non_negative(prefix, "viscous_friction_n_s_per_m", viscous_friction_n_s_per_m);
  non_negative(prefix, "drag_force_n", drag_force_n);
  non_negative(prefix, "drag_n_s_per_m", drag_n_s_per_m);
  require_finite(std::string(prefix) + ".external_force_n", external_force_n);
  positive(prefix, "friction_smoothing_m_s", friction_smoothing_m_s);
  non_negative(prefix, "end_load_n_per_mm", end_load_n_per_mm);
  require_finite(std::string(prefix) + ".end_load_start_mm", end_load_start_mm);
  non_negative(prefix, "bump_force_n", bump_force_n);
  require_finite(std::string(prefix) + ".bump_position_mm", bump_position_mm);
  non_negative(prefix, "bump_half_width_mm", bump_half_width_mm);
  non_negative(prefix, "backlash_mm", backlash_mm);
}

double AxisMechanics::pulley_radius_m() const {
  return rotation_distance_mm * 1e-3 / (2.0 * std::numbers::pi);
}

StepperAxisModel::StepperAxisModel(const MotorParameters& motor, const DriveParameters& drive,
                                   const AxisMechanics& axis)
    : motor_(motor), drive_(drive), axis_(axis) {
  motor_.validate();
  drive_.validate();
  axis_.validate();
  p_ = motor_.pole_pairs();
  kt_ = motor_.torque_constant_n_m_per_a();
  r_ = axis_.pulley_radius_m();
  j_ = motor_.rotor_inertia_kg_m2 + axis_.pulley_inertia_kg_m2;
  kc_ = 2.0 * std::numbers::pi * drive_.current_loop_bandwidth_hz * motor_.phase_inductance_h;
  step_mm_ = axis_.rotation_distance_mm /
             (static_cast<double>(motor_.full_steps_per_rotation) * drive_.microsteps);
  rad_per_micro_ = 2.0 * std::numbers::pi / (4.0 * drive_.microsteps);
  inv_m_ = 1.0 / axis_.belt.mass_kg;
  k_ = axis_.belt.stiffness_n_per_m;
  c_ = axis_.belt.damping_n_s_per_m;
  half_backlash_ = 0.5 * axis_.backlash_mm * 1e-3;
  end_k_ = axis_.end_load_n_per_mm * 1e3;
  end_x_ = axis_.end_load_start_mm * 1e-3;
  bump_lo_ = (axis_.bump_position_mm - axis_.bump_half_width_mm) * 1e-3;
  bump_hi_ = (axis_.bump_position_mm + axis_.bump_half_width_mm) * 1e-3;
}

double StepperAxisModel::magnetic_stiffness_n_m_per_rad() const {
  return p_ * (pull_out_torque_n_m() + 4.0 * motor_.detent_torque_n_m);
}

MotorState StepperAxisModel::rest_state(double x_mm) const {
  MotorState s;
  const auto n = static_cast<std::int64_t>(std::llround(x_mm / step_mm_));
  s.x_m = x_mm * 1e-3;
  s.theta_rad = s.x_m / r_;
  // Rest exactly on the commanded microstep: the rotor sits at phi / p (load angle 0).
  set_microstep(s, n);
  s.theta_rad = static_cast<double>(n) * rad_per_micro_ / p_;
  s.x_m = s.theta_rad * r_;
  set_current(s, drive_.current_amplitude_a);
  s.i_a = s.ref_a;
  s.i_b = s.ref_b;
  return s;
}

void StepperAxisModel::set_microstep(MotorState& s, std::int64_t n) const {
  s.microstep = n;
  const double phi = static_cast<double>(n) * rad_per_micro_;
  const double amp = s.current_a > 0.0 ? s.current_a : drive_.current_amplitude_a;
  s.ref_a = amp * std::cos(phi);
  s.ref_b = amp * std::sin(phi);
}

double StepperAxisModel::max_current_a() const {
  return drive_.max_current_a > 0.0 ? drive_.max_current_a : motor_.rated_current_a;
}

void StepperAxisModel::set_current(MotorState& s, double amplitude_a) const {
  const double c = std::clamp(amplitude_a, 1e-6, std::max(max_current_a(), drive_.current_amplitude_a));
  if (s.current_a > 0.0) {
    // Same electrical angle, new amplitude: scale the reference (no sine to recompute).
    const double k = c / s.current_a;
    s.ref_a *= k;
    s.ref_b *= k;
    s.current_a = c;
  } else {
    s.current_a = c;
    set_microstep(s, s.microstep);
  }
}

void StepperAxisModel::step(MotorState& s, double h) const {
  const double pth = p_ * s.theta_rad;
  const double sn = std::sin(pth), cs = std::cos(pth);
  const double L = motor_.phase_inductance_h, R = motor_.phase_resistance_ohm;
  const double vmax = drive_.supply_voltage_v;
  // Back-EMF as a voltage drop e (L di/dt = v - R i - e), taken at the start of the step.
  const double e_a = -kt_ * s.omega_rad_s * sn;
  const double e_b = kt_ * s.omega_rad_s * cs;
  // The chopper applies v = Kc (i_ref - i) + R i_ref (it holds the current at standstill
  // exactly, as a hysteresis chopper does). Backward Euler of L di/dt = v - R i - e; if v
  // exceeds the supply, the chopper saturates: L di/dt = +-V - R i - e, again backward Euler.
  auto phase = [&](double i0, double ref, double e) {
    double i1 = (L * i0 + h * ((kc_ + R) * ref - e)) / (L + h * (kc_ + R));
    const double v = kc_ * (ref - i1) + R * ref;
    if (v > vmax || v < -vmax) {
      const double vs = v > 0 ? vmax : -vmax;
      i1 = (L * i0 + h * (vs - e)) / (L + h * R);
    }
    return i1;
  };
  s.i_a = phase(s.i_a, s.ref_a, e_a);
  s.i_b = phase(s.i_b, s.ref_b, e_b);
  // sin(4 p th) from sin, cos of p th (double angle twice).
  const double s2 = 2.0 * sn * cs, c2 = cs * cs - sn * sn;
  const double s4 = 2.0 * s2 * c2;
  const double tm = kt_ * (-s.i_a * sn + s.i_b * cs) - motor_.detent_torque_n_m * s4;
  s.torque_n_m = tm;
  const double stretch = r_ * s.theta_rad - s.x_m;
  const double stretch_rate = r_ * s.omega_rad_s - s.v_m_s;
  double f_belt = 0.0;
  if (half_backlash_ == 0.0) {
    f_belt = k_ * stretch + c_ * stretch_rate;
  } else if (stretch > half_backlash_) {  // engaged pulling +x: a contact pushes, never pulls
    f_belt = std::max(0.0, k_ * (stretch - half_backlash_) + c_ * stretch_rate);
  } else if (stretch < -half_backlash_) {
    f_belt = std::min(0.0, k_ * (stretch + half_backlash_) + c_ * stretch_rate);
  }
  const double t_rotor = tm - motor_.rotor_damping_n_m_s_per_rad * s.omega_rad_s - r_ * f_belt;
  const double sgn = std::tanh(s.v_m_s / axis_.friction_smoothing_m_s);
  const double f_cart = f_belt - (axis_.coulomb_friction_n + axis_.drag_force_n) * sgn -
                        (axis_.viscous_friction_n_s_per_m + axis_.drag_n_s_per_m) * s.v_m_s +
                        axis_.external_force_n +
                        end_k_ * std::max(0.0, end_x_ - s.x_m) -
                        ((s.x_m >= bump_lo_ && s.x_m <= bump_hi_) ? axis_.bump_force_n * sgn : 0.0);
  // Semi-implicit Euler: velocities first, positions with the new velocities.
  s.omega_rad_s += h * t_rotor / j_;
  s.v_m_s += h * f_cart * inv_m_;
  s.theta_rad += h * s.omega_rad_s;
  s.x_m += h * s.v_m_s;
}

double StepperAxisModel::load_angle_rad(const MotorState& s) const {
  return static_cast<double>(s.microstep) * rad_per_micro_ - p_ * s.theta_rad;
}

std::int64_t StepperAxisModel::slip_cycles(const MotorState& s) const {
  return static_cast<std::int64_t>(std::llround(load_angle_rad(s) / (2.0 * std::numbers::pi)));
}

double StepperAxisModel::pull_out_torque_at_n_m(double omega) const {
  return pull_out_torque_at_n_m(omega, drive_.current_amplitude_a);
}

double StepperAxisModel::pull_out_torque_at_n_m(double omega, double current_a) const {
  const double we = p_ * std::abs(omega);
  const double z = std::hypot(motor_.phase_resistance_ohm, we * motor_.phase_inductance_h);
  const double headroom = drive_.supply_voltage_v - kt_ * std::abs(omega);
  const double i = std::clamp(headroom / z, 0.0, current_a);
  return kt_ * i;
}

}  // namespace amctl::closedloop
