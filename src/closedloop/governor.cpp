#include "amctl/closedloop/governor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::closedloop {

void GovernorParameters::validate() const {
  if (!(max_load_angle_deg > 0.0 && max_load_angle_deg <= 90.0)) {
    throw Error(fmt::format("governor.max_load_angle_deg = {}: expected a design load angle in "
                            "(0, 90] degrees",
                            max_load_angle_deg));
  }
  if (!(step_rate_fraction > 0.0 && step_rate_fraction <= 1.0)) {
    throw Error(fmt::format("governor.step_rate_fraction = {}: expected a fraction in (0, 1]",
                            step_rate_fraction));
  }
  if (!(belt_phase_limit > 0.0 && belt_phase_limit <= 1.166)) {
    throw Error(fmt::format("governor.belt_phase_limit = {}: expected (0, 1.166] (beyond 1.166 "
                            "the acceleration lead rings the belt more than open loop)",
                            belt_phase_limit));
  }
  if (!(rotor_angle_limit_deg > 0.0 && rotor_angle_limit_deg <= 90.0)) {
    throw Error(fmt::format("governor.rotor_angle_limit_deg = {}: expected a load angle in "
                            "(0, 90] degrees",
                            rotor_angle_limit_deg));
  }
  if (!(rotor_hold_s >= 0.0 && rotor_hold_s <= 10.0)) {
    throw Error(fmt::format("governor.rotor_hold_s = {}: expected a time in [0, 10] s", rotor_hold_s));
  }
}

CommandGovernor::CommandGovernor(const StepperAxisModel& model, const GovernorParameters& p,
                                 double current_a)
    : m_(model), p_(p), current_a_(current_a) {
  p_.validate();
  sin_max_ = std::sin(p_.max_load_angle_deg * std::numbers::pi / 180.0);
  const AxisMechanics& ax = m_.axis();
  wb_ = std::sqrt(ax.belt.stiffness_n_per_m / ax.belt.mass_kg);
  v_step_max_ = p_.step_rate_fraction * m_.drive().max_step_rate_hz * m_.step_distance_mm();
  v_cruise_max_ = std::min(v_step_max_, torque_speed_limit_mm_s());
  wr_ = std::sqrt(m_.motor().pole_pairs() * m_.motor().torque_constant_n_m_per_a() * current_a_ /
                  m_.inertia_kg_m2());
}

double CommandGovernor::torque_speed_limit_mm_s() const {
  // The speed at which the pull-out torque (at this current) no longer covers the plan's
  // cruise torque at d_max: bisection on the falling torque-speed curve.
  const double r = m_.pulley_radius_m();
  auto ok = [&](double v_mm_s) {
    return m_.pull_out_torque_at_n_m(v_mm_s * 1e-3 / r, current_a_) * sin_max_ >
           plan_torque_n_m(v_mm_s, 0.0);
  };
  double lo = 0.0, hi = v_step_max_;
  if (ok(hi)) return hi;
  if (!ok(lo)) return 0.0;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (ok(mid) ? lo : hi) = mid;
  }
  return lo;
}

double CommandGovernor::axis_accel_limit_mm_s2(double v_mm_s) const {
  const double r = m_.pulley_radius_m();
  const double spare = m_.pull_out_torque_at_n_m(std::abs(v_mm_s) * 1e-3 / r, current_a_) * sin_max_ -
                       plan_torque_n_m(v_mm_s, 0.0);
  const double j_axis = m_.inertia_kg_m2() + m_.axis().belt.mass_kg * r * r;
  return spare > 0.0 ? 1e3 * r * spare / j_axis : 0.0;
}

double CommandGovernor::max_lead_mm(double v_mm_s, double current_a) const {
  const double r = m_.pulley_radius_m();
  const double po = m_.pull_out_torque_at_n_m(std::abs(v_mm_s) * 1e-3 / r, current_a);
  const double stretch = 1e3 * po * sin_max_ / (r * m_.axis().belt.stiffness_n_per_m);
  const double angle = 1e3 * (r / m_.motor().pole_pairs()) * std::asin(sin_max_);
  return std::max(0.0, stretch + angle + 0.5 * m_.axis().backlash_mm - 0.5 * m_.step_distance_mm());
}

double CommandGovernor::plan_torque_n_m(double v_mm_s, double a_mm_s2) const {
  const AxisMechanics& ax = m_.axis();
  const double r = m_.pulley_radius_m();
  const double v = std::abs(v_mm_s) * 1e-3, a = std::abs(a_mm_s2) * 1e-3;
  const double f = ax.belt.mass_kg * a + ax.coulomb_friction_n + ax.viscous_friction_n_s_per_m * v;
  return r * f + m_.inertia_kg_m2() * a / r + m_.motor().rotor_damping_n_m_s_per_rad * v / r;
}

double CommandGovernor::belt_phase(double accel_change_mm_s2, double correction_accel_mm_s2) const {
  if (correction_accel_mm_s2 <= 0.0) return std::numeric_limits<double>::infinity();
  const AxisMechanics& ax = m_.axis();
  const double lead_mm = ax.belt.mass_kg * std::abs(accel_change_mm_s2) / ax.belt.stiffness_n_per_m;
  const double t_ramp = 2.0 * std::sqrt(lead_mm / correction_accel_mm_s2);
  return 0.5 * wb_ * t_ramp;
}

MoveLimits CommandGovernor::limits(double peak_speed_mm_s, double accel_mm_s2, double jump_mm_s) const {
  MoveLimits l;
  const double r = m_.pulley_radius_m();
  const double p = m_.motor().pole_pairs();
  const double w = std::abs(peak_speed_mm_s) * 1e-3 / r;
  l.plan_torque_n_m = plan_torque_n_m(peak_speed_mm_s, accel_mm_s2);
  l.pull_out_n_m = m_.pull_out_torque_at_n_m(w, current_a_);
  const double budget = l.pull_out_n_m * sin_max_;
  const double margin = budget - l.plan_torque_n_m;
  l.max_command_speed_mm_s = v_cruise_max_;
  const double j = m_.inertia_kg_m2();
  // The correction's acceleration moves the rotor and, through the belt, the carriage: the
  // whole axis's inertia (J + m r^2, the belt taken as rigid: the conservative bound).
  const double j_axis = j + m_.axis().belt.mass_kg * r * r;
  const double d_plan0 = std::asin(std::min(1.0, l.plan_torque_n_m / std::max(l.pull_out_n_m, 1e-12)));
  const double jump_ok = wr_ * 1e3 * (r / p) * std::max(0.0, std::asin(sin_max_) - d_plan0) / 4.0;
  if (margin > 0.0 && std::abs(peak_speed_mm_s) <= l.max_command_speed_mm_s && jump_mm_s <= jump_ok) {
    l.feasible = true;
    l.correction_accel_mm_s2 = 1e3 * r * margin / (2.0 * j_axis);
    const double d_plan = std::asin(std::min(1.0, l.plan_torque_n_m / l.pull_out_n_m));
    const double d_max = std::asin(sin_max_);
    l.free_step_mm = 1e3 * (r / p) * std::max(0.0, d_max - d_plan) / 4.0;
    // No bound on the feedback's size: it makes up for loads the model does not know (a drag
    // holds the carriage back whatever the command does) and for cycles the rotor slipped (a
    // whole electrical cycle of command lead is no force at all); the current scaling, not a
    // smaller u, answers a load.
    l.max_feedback_mm = std::numeric_limits<double>::infinity();
    // The acceleration lead changes by up to twice the move's acceleration at a junction
    // (a reversal from +a to -a).
    l.accel_lead = belt_phase(2.0 * accel_mm_s2, l.correction_accel_mm_s2) <= p_.belt_phase_limit;
  } else {
    // Degraded: the correction goes back to 0 within the same budgets a feasible move has
    // (what the design angle leaves); with none left it is held where it is (a constant offset
    // asks nothing of the rotor) and the command moves as open loop's does.
    l.feasible = false;
    l.accel_lead = false;
    l.correction_accel_mm_s2 = margin > 0.0 ? 1e3 * r * margin / (2.0 * j_axis) : 0.0;
    l.free_step_mm = margin > 0.0 ? 1e3 * (r / p) * std::max(0.0, std::asin(sin_max_) - d_plan0) / 4.0 : 0.0;
    l.max_feedback_mm = 0.0;
  }
  return l;
}

MoveLimits CommandGovernor::with_measured_load(const MoveLimits& l, double lead_mm,
                                               double current_a) const {
  if (!l.feasible) return l;
  const double r = m_.pulley_radius_m();
  const double tau = r * m_.axis().belt.stiffness_n_per_m * std::abs(lead_mm) * 1e-3;
  // The pull-out at the current commanded now (the move's figure is at the largest current
  // the controller may run; the speed's limit on it stays).
  const double po = std::min(l.pull_out_n_m, m_.motor().torque_constant_n_m_per_a() * current_a);
  if (tau <= l.plan_torque_n_m && po >= l.pull_out_n_m) return l;
  // The steady load is carried whatever the controller does (its lead is what balances it):
  // only what the controller adds on top, the correction's acceleration and steps, shares
  // the margin that is left, down to a tenth of the move's own.
  MoveLimits out = l;
  const double nominal = l.pull_out_n_m * sin_max_ - l.plan_torque_n_m;
  const double margin = std::max(po * sin_max_ - std::max(tau, l.plan_torque_n_m), 0.1 * nominal);
  if (margin >= nominal) return l;
  const double j_axis = m_.inertia_kg_m2() + m_.axis().belt.mass_kg * r * r;
  out.correction_accel_mm_s2 = 1e3 * r * margin / (2.0 * j_axis);
  out.free_step_mm = l.free_step_mm * margin / nominal;
  return out;
}

DegradeReason CommandGovernor::reason(const MoveLimits& l, double peak_speed_mm_s, double jump_mm_s) const {
  if (l.feasible) return DegradeReason::none;
  if (l.pull_out_n_m * sin_max_ > l.plan_torque_n_m &&
      std::abs(peak_speed_mm_s) <= l.max_command_speed_mm_s && jump_mm_s > 0.0) {
    return DegradeReason::jump;
  }
  return std::abs(peak_speed_mm_s) > l.max_command_speed_mm_s ? DegradeReason::speed
                                                               : DegradeReason::torque;
}

CommandLimiter::Out CommandLimiter::next(double lead_mm, double feedback_mm,
                                         double ref_speed_mm_s, const MoveLimits& l, double T) {
  Out out;
  const double lead_w = l.feasible ? lead_mm : 0.0;
  double u_w = l.feasible ? std::clamp(feedback_mm, -l.max_feedback_mm, l.max_feedback_mm) : 0.0;
  // The room the command's speed leaves the correction (never forcing a speed the plan does
  // not have).
  const double lo = std::min(-l.max_command_speed_mm_s - ref_speed_mm_s, 0.0);
  const double hi = std::max(l.max_command_speed_mm_s - ref_speed_mm_s, 0.0);
  // Lead: the smooth part follows in minimum time without overshoot under |S''| <= A_c (the
  // rate that can still brake to 0 over the distance left, changed by at most A_c T).
  const double a = l.correction_accel_mm_s2;
  const double e = lead_w - smooth_;
  // The fastest rate from which steps of A T per period still stop within |e|: moving n A T,
  // then (n - 1) A T, ... covers A T^2 n (n + 1) / 2 <= |e|.
  // (For |e| <= A T^2 the bound is at least |e| / T: no square root needed.)
  double want = e / T;
  const double at = a * T;
  if (std::abs(e) > at * T) {
    const double brake = 0.5 * at * (std::sqrt(1.0 + 8.0 * std::abs(e) / (at * T)) - 1.0);
    if (std::abs(want) > brake) want = std::copysign(brake, e);
  } else if (at <= 0.0) {
    want = 0.0;
  }
  rate_ = std::clamp(std::clamp(want, rate_ - at, rate_ + at), lo, hi);
  smooth_ += rate_ * T;
  const double lead = smooth_ + std::clamp(lead_w - smooth_, -l.free_step_mm, l.free_step_mm);
  // Feedback: at most s_free per period (on a degraded move, s_free of the margin left).
  const double step = l.free_step_mm;
  const double u = std::clamp(u_w, u_ - step, u_ + step);
  out.feedback_limited = std::abs(u - feedback_mm) > 1e-9;


  // The command's speed over the period.
  double d = std::clamp(lead + u, lead_ + u_ + lo * T, lead_ + u_ + hi * T);
  if (d != lead + u) out.feedback_limited = true;
  // Split what the speed room cut between the two, the feedback first.
  const double cut = (lead + u) - d;
  u_ = u - cut;
  lead_ = d - u_;
  out.correction_mm = d;
  return out;
}


RotorObserver::RotorObserver(const StepperAxisModel& model, double max_angle_deg, double start_mm)
    : m_(model) {
  now_.q_mm = start_mm;
  const double d = max_angle_deg * std::numbers::pi / 180.0;
  lead_mm_ = std::max(0.0, 1e3 * m_.pulley_radius_m() / m_.motor().pole_pairs() * d -
                               0.5 * m_.step_distance_mm());
}

RotorObserver::Prediction RotorObserver::predict(double c0_mm, double c1_mm, double y_mm,
                                                 double yd_mm_s, double current_a, double T) const {
  // SI inside: q, y [m], speeds [m/s]. Semi-implicit Euler at 4 substeps a period (the rotor's
  // magnetic spring, ~2e3 rad/s, times T / 4 = 25 us is 0.05: far inside the stability limit).
  constexpr int n = 4;
  const double r = m_.pulley_radius_m(), p = m_.motor().pole_pairs();
  const double j = m_.inertia_kg_m2(), b = m_.motor().rotor_damping_n_m_s_per_rad;
  const AxisMechanics& ax = m_.axis();
  const double k = ax.belt.stiffness_n_per_m, cb = ax.belt.damping_n_s_per_m;
  const double hb = 0.5 * ax.backlash_mm * 1e-3;
  double q = now_.q_mm * 1e-3, v = now_.qd_mm_s * 1e-3;
  const double y = y_mm * 1e-3, yd = yd_mm_s * 1e-3;
  // The torque available at the period's speed (the current falls with the back-EMF).
  const double tpo = m_.pull_out_torque_at_n_m(std::abs(v) / r, current_a);
  const double h = T / n;
  for (int i = 0; i < n; ++i) {
    const double c = 1e-3 * (c0_mm + (c1_mm - c0_mm) * (i + 0.5) / n);
    const double s = q - y;
    double f = 0.0;
    if (hb == 0.0) {
      f = k * s + cb * (v - yd);
    } else if (s > hb) {
      f = std::max(0.0, k * (s - hb) + cb * (v - yd));
    } else if (s < -hb) {
      f = std::min(0.0, k * (s + hb) + cb * (v - yd));
    }
    const double tau = tpo * std::sin(p * (c - q) / r) - r * f - b * v / r;
    v += h * r * tau / j;
    q += h * v;
  }
  return {q * 1e3, v * 1e3};
}

}  // namespace amctl::closedloop
