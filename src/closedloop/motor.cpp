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
  coulomb_plus_drag_n_ = axis_.coulomb_friction_n + axis_.drag_force_n;
  viscous_plus_drag_ = axis_.viscous_friction_n_s_per_m + axis_.drag_n_s_per_m;
  inv_vs_ = 1.0 / axis_.friction_smoothing_m_s;
  vmax_ = drive_.supply_voltage_v;
  r_ohm_ = motor_.phase_resistance_ohm;
  detent_ = motor_.detent_torque_n_m;
  damping_ = motor_.rotor_damping_n_m_s_per_rad;
  f_ext_ = axis_.external_force_n;
  bump_f_ = axis_.bump_force_n;
  const int cycle = 4 * drive_.microsteps;
  cycle_mask_ = (cycle & (cycle - 1)) == 0 ? cycle - 1 : -1;
  micro_cos_.resize(static_cast<std::size_t>(cycle));
  micro_sin_.resize(static_cast<std::size_t>(cycle));
  for (int n = 0; n < cycle; ++n) {
    micro_cos_[static_cast<std::size_t>(n)] = std::cos(n * rad_per_micro_);
    micro_sin_[static_cast<std::size_t>(n)] = std::sin(n * rad_per_micro_);
  }
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
  sync_angle(s);
  return s;
}

void StepperAxisModel::set_microstep(MotorState& s, std::int64_t n) const {
  s.microstep = n;
  // The electrical angle n 2 pi / (4 microsteps), from the table of one cycle (a power of two
  // for every power-of-two microstepping: a mask, not a division).
  const auto cycle = static_cast<std::int64_t>(micro_cos_.size());
  const auto j = static_cast<std::size_t>(cycle_mask_ >= 0 ? (n & cycle_mask_) : ((n % cycle) + cycle) % cycle);
  const double amp = s.current_a > 0.0 ? s.current_a : drive_.current_amplitude_a;
  s.ref_a = amp * micro_cos_[j];
  s.ref_b = amp * micro_sin_[j];
}

void StepperAxisModel::set_microstep_path(MotorState& s, std::int64_t n0, std::int64_t n1,
                                          double c0, double c1) const {
  const auto cycle = static_cast<std::int64_t>(micro_cos_.size());
  auto idx = [&](std::int64_t n) {
    return static_cast<std::size_t>(cycle_mask_ >= 0 ? (n & cycle_mask_) : ((n % cycle) + cycle) % cycle);
  };
  const std::int64_t dir = n1 > n0 ? 1 : -1;
  const double span = c1 - c0;
  double ra = 0.0, rb = 0.0, prev = 0.0;
  for (std::int64_t m = n0; m != n1; m += dir) {
    // The command crosses (m + dir / 2) s at fraction f of the step.
    const double f = std::clamp(((static_cast<double>(m) + 0.5 * static_cast<double>(dir)) * step_mm_ - c0) / span, prev, 1.0);
    ra += (f - prev) * micro_cos_[idx(m)];
    rb += (f - prev) * micro_sin_[idx(m)];
    prev = f;
  }
  ra += (1.0 - prev) * micro_cos_[idx(n1)];
  rb += (1.0 - prev) * micro_sin_[idx(n1)];
  const double amp = s.current_a > 0.0 ? s.current_a : drive_.current_amplitude_a;
  s.ref_a = amp * ra;
  s.ref_b = amp * rb;
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

SubstepCoefficients StepperAxisModel::substep(double h) const {
  const double L = motor_.phase_inductance_h, R = motor_.phase_resistance_ohm;
  SubstepCoefficients k;
  k.h_s = h;
  // The current loop is linear with constant inputs over the substep: its exact solution.
  // Unsaturated, di/dt = lam (i_inf - i), lam = (Kc + R) / L, i_inf = ref - e / (Kc + R):
  // i1 = E i0 + (1 - E) i_inf, E = exp(-lam h); the mean over the step (for the chopper's
  // voltage) i0 g + (1 - g) i_inf, g = (1 - E) / (lam h). Saturated, L di/dt = +-V - e - R i:
  // i1 = Es i0 + (1 - Es) (+-V - e) / R, Es = exp(-R h / L).
  const double lam = (kc_ + R) / L;
  const double e = std::exp(-lam * h);
  const double g = (1.0 - e) / (lam * h);
  k.ci0 = e;
  k.cref = 1.0 - e;
  k.ce = (1.0 - e) / (kc_ + R);
  k.gi0 = g;
  k.gref = 1.0 - g;
  k.ge = (1.0 - g) / (kc_ + R);
  const double es = std::exp(-R * h / L);
  k.si0 = es;
  k.sv = (1.0 - es) / R;
  k.h_over_j = h / j_;
  k.h_over_m = h * inv_m_;
  return k;
}

void StepperAxisModel::sync_angle(MotorState& s) const {
  const double pth = p_ * s.theta_rad;
  s.sin_e = std::sin(pth);
  s.cos_e = std::cos(pth);
}

void StepperAxisModel::step(MotorState& s, double h) const {
  sync_angle(s);
  integrate(s, substep(h));
}

double StepperAxisModel::load_angle_rad(const MotorState& s) const {
  return static_cast<double>(s.microstep) * rad_per_micro_ - p_ * s.theta_rad;
}

std::int64_t StepperAxisModel::slip_cycles(const MotorState& s) const {
  return static_cast<std::int64_t>(std::floor(load_angle_rad(s) * (0.5 / std::numbers::pi) + 0.5));
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
