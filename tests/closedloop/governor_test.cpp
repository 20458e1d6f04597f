// The command governor against hand calculations (docs/closedloop.md, section 3.1): the torque
// the plan needs, the margins it leaves, the lead's minimum-time shaping, the feedback's step
// and magnitude limits, the belt-mode check of the acceleration lead, degraded moves; and the
// loop analysis with the rotor's spring softened at a load angle.
#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "amctl/closedloop/controller.hpp"
#include "amctl/closedloop/governor.hpp"

namespace amctl::closedloop {
namespace {

constexpr double kPi = std::numbers::pi;

// 17HS4401 at 1.7 A, 24 V, 40 mm per turn, 16 microsteps; 0.5 kg on a 40 Hz belt.
StepperAxisModel model() { return StepperAxisModel(MotorParameters{}, DriveParameters{}, AxisMechanics{}); }

TEST(CommandGovernor, PlanTorqueIsInertiaFrictionAndRotorByHand) {
  const StepperAxisModel m = model();
  const CommandGovernor g(m, GovernorParameters{}, 1.7);
  // r = 40 mm / 2 pi; F = m a + F_c + c_v v = 0.5 * 3 + 2 + 2 * 0.1 = 3.7 N at 100 mm/s and
  // 3000 mm/s^2; tau = r F + J a / r + b v / r, J = 54 + 1.5 g cm^2.
  const double r = 0.040 / (2 * kPi), j = 55.5e-7;
  const double want = r * 3.7 + j * 3.0 / r + 1e-3 * 0.1 / r;
  EXPECT_NEAR(g.plan_torque_n_m(100.0, 3000.0), want, 1e-12);
  EXPECT_NEAR(g.plan_torque_n_m(-100.0, -3000.0), want, 1e-12);  // magnitudes
}

TEST(CommandGovernor, MarginsOfAMoveByHand) {
  const StepperAxisModel m = model();
  const CommandGovernor g(m, GovernorParameters{}, 1.7);
  const double v = 100.0, a = 3000.0;
  const MoveLimits l = g.limits(v, a);
  ASSERT_TRUE(l.feasible);
  const double r = 0.040 / (2 * kPi), j = 55.5e-7, p = 50.0;
  const double tau = g.plan_torque_n_m(v, a);
  const double po = m.pull_out_torque_at_n_m(v * 1e-3 / r, 1.7);
  EXPECT_NEAR(l.pull_out_n_m, po, 1e-15);
  const double margin = po * std::sin(kPi / 3) - tau;
  // A_c = r M / (2 (J + m r^2)) [m/s^2 -> mm/s^2].
  EXPECT_NEAR(l.correction_accel_mm_s2, 1e3 * r * margin / (2 * (j + 0.5 * r * r)), 1e-9);
  // s_free = (r / p) (d_max - asin(tau / T_po)) / 4 [mm]; the feedback's size is not bounded.
  EXPECT_NEAR(l.free_step_mm, 1e3 * (r / p) * (kPi / 3 - std::asin(tau / po)) / 4, 1e-12);
  EXPECT_TRUE(std::isinf(l.max_feedback_mm));
  const double k = 0.5 * std::pow(2 * kPi * 40, 2);
  // The belt check: the lead m 2a / k ramps in over 2 sqrt(lead / A_c); x = w_b t / 2.
  const double lead = 0.5 * 2 * a / k, t = 2 * std::sqrt(lead / l.correction_accel_mm_s2);
  EXPECT_NEAR(g.belt_phase(2 * a, l.correction_accel_mm_s2), 0.5 * 2 * kPi * 40 * t, 1e-12);
  EXPECT_EQ(l.accel_lead, 0.5 * 2 * kPi * 40 * t <= 0.8);
}

TEST(CommandGovernor, TheBeltLimitIsWhereTheLeadRingsAsMuchAsOpenLoop) {
  // Residual ringing of a lead ramped over t_r against open loop's: |1 - sinc(x) e^{-ix}|,
  // x = w_b t_r / 2; it equals 1 where sinc(x) = 2 cos(x), x = 1.1656 (tan x = 2 x).
  auto residual = [](double x) {
    const double s = std::sin(x) / x;
    return std::hypot(1 - s * std::cos(x), s * std::sin(x));
  };
  EXPECT_NEAR(residual(1.1656), 1.0, 1e-3);
  EXPECT_LT(residual(0.8), 0.75);
  EXPECT_GT(residual(1.2), 1.0);
}

TEST(CommandGovernor, AMoveThePlanAloneSaturatesIsDegraded) {
  const StepperAxisModel m = model();
  const CommandGovernor g(m, GovernorParameters{}, 1.7);
  // 80000 mm/s^2 on 0.5 kg: r m a = 0.255 N m, plus the rotor's J a / r = 0.070 N m, above
  // the 0.24 N m the motor gives at 60 deg.
  const MoveLimits l = g.limits(100.0, 80000.0);
  EXPECT_FALSE(l.feasible);
  EXPECT_EQ(g.reason(l, 100.0), DegradeReason::torque);
  EXPECT_EQ(l.max_feedback_mm, 0.0);
  // Faster than the torque-speed curve allows at d_max: degraded for speed.
  const MoveLimits fast = g.limits(5000.0, 0.0);
  EXPECT_FALSE(fast.feasible);
  EXPECT_EQ(g.reason(fast, 5000.0), DegradeReason::speed);
  // V_c: at that speed T_po sin(60) falls to the cruise torque (or 90 % of the step rate).
  const double vc = g.max_command_speed_mm_s();
  const double r = 0.040 / (2 * kPi);
  const double po = m.pull_out_torque_at_n_m(vc * 1e-3 / r, 1.7) * std::sin(kPi / 3);
  EXPECT_NEAR(po, g.plan_torque_n_m(vc, 0.0), 1e-6);
  EXPECT_LT(vc, 0.9 * 200000 * 0.0125);
}

TEST(CommandLimiter, ShapesAStepOfTheLeadInMinimumTimeWithoutOvershoot) {
  MoveLimits l;
  l.correction_accel_mm_s2 = 1e5;
  l.free_step_mm = 0.0;
  l.max_feedback_mm = 1.0;
  l.max_command_speed_mm_s = 1e9;
  CommandLimiter c;
  c.reset(0.0);
  const double T = 1e-4, lead = 0.4;
  // Bang-bang from rest to rest over e = 0.4 mm at A: t = 2 sqrt(e / A) = 4 ms, 40 periods.
  double prev = 0.0;
  int n = 0;
  for (; n < 200; ++n) {
    const double d = c.next(lead, 0.0, 0.0, l, T).correction_mm;
    EXPECT_LE(d, lead + 1e-12);            // never beyond
    EXPECT_GE(d, prev - 1e-12);            // monotone
    prev = d;
    if (std::abs(d - lead) < 1e-12) break;
  }
  EXPECT_NEAR(n + 1, 40, 2);
  // With a free step the rest within s_free is taken at once.
  l.free_step_mm = 0.5;
  CommandLimiter f;
  f.reset(0.0);
  EXPECT_NEAR(f.next(lead, 0.0, 0.0, l, T).correction_mm, lead, 1e-12);
}

TEST(CommandLimiter, FeedbackStepsAndMagnitudeAreBoundedAndADegradedMoveReturnsToZero) {
  MoveLimits l;
  l.correction_accel_mm_s2 = 1e5;
  l.free_step_mm = 0.01;
  l.max_feedback_mm = 0.05;
  l.max_command_speed_mm_s = 1e9;
  CommandLimiter c;
  c.reset(0.0);
  const double T = 1e-4;
  auto o = c.next(0.0, 1.0, 0.0, l, T);
  EXPECT_NEAR(o.correction_mm, 0.01, 1e-12);  // one step of s_free
  EXPECT_TRUE(o.feedback_limited);
  for (int k = 0; k < 10; ++k) o = c.next(0.0, 1.0, 0.0, l, T);
  EXPECT_NEAR(o.correction_mm, 0.05, 1e-12);  // held at U_max
  // Degraded: back to 0 by at most s_free a period.
  l.feasible = false;
  o = c.next(0.0, 1.0, 0.0, l, T);
  EXPECT_NEAR(o.correction_mm, 0.04, 1e-12);
  for (int k = 0; k < 10; ++k) o = c.next(0.0, 1.0, 0.0, l, T);
  EXPECT_NEAR(o.correction_mm, 0.0, 1e-12);
}

TEST(CommandLimiter, TheCommandNeverRunsFasterThanTheSpeedLimit) {
  MoveLimits l;
  l.correction_accel_mm_s2 = 1e9;
  l.free_step_mm = 10.0;
  l.max_feedback_mm = 10.0;
  l.max_command_speed_mm_s = 300.0;
  CommandLimiter c;
  c.reset(0.0);
  const double T = 1e-4;
  // The plan already moves at 250 mm/s: the correction may add at most 50 mm/s.
  const double d = c.next(0.0, 1.0, 250.0, l, T).correction_mm;
  EXPECT_NEAR(d / T, 50.0, 1e-9);
  // A plan faster than V_c: the correction may slow it, never speed it up.
  CommandLimiter e;
  e.reset(0.0);
  EXPECT_NEAR(e.next(0.0, 1.0, 400.0, l, T).correction_mm, 0.0, 1e-12);
  EXPECT_LT(e.next(0.0, -1.0, 400.0, l, T).correction_mm, 0.0);
}

TEST(LoopStability, AtALoadAngleTheRotorSpringIsSoftenedByItsCosine) {
  // Open loop at load angle d: the plant's continuous eigenvalues with the magnetic spring
  // p Kt I cos d, computed here on their own; radius = exp(max Re(lambda) T).
  const StepperAxisModel m = model();
  ControllerParameters p;
  const double d = 50.0 * kPi / 180.0;
  const double r = m.pulley_radius_m();
  const double mr = m.inertia_kg_m2() / (r * r);
  const double km = 50.0 * m.pull_out_torque_n_m() * std::cos(d) / (r * r);
  const double br = m.motor().rotor_damping_n_m_s_per_rad / (r * r);
  const AxisMechanics& ax = m.axis();
  const double k = ax.belt.stiffness_n_per_m, c = ax.belt.damping_n_s_per_m, ms = ax.belt.mass_kg;
  Eigen::Matrix4d a;
  a << 0, 1, 0, 0, (-km - k) / mr, (-br - c) / mr, k / mr, c / mr, 0, 0, 0, 1, k / ms, c / ms,
      -k / ms, (-c - ax.viscous_friction_n_s_per_m) / ms;
  const Eigen::Vector4cd ev = a.eigenvalues();
  double re = -1e300;
  for (int i = 0; i < 4; ++i) re = std::max(re, ev(i).real());
  EXPECT_NEAR(analyse_loop(ControllerKind::open, p, m, d).spectral_radius, std::exp(re * p.period_s), 1e-9);
}

TEST(LoopStability, TheDefaultGainsHoldFromRestToTheDesignAngle) {
  // The rotor's spring softens as cos d up to the governor's 60 deg: the default gains of every
  // controller keep the linearised loop stable over that range at the run currents of the
  // reversing-strokes scenario and of the presets (1.13 and 1.7 A).
  for (double amp : {1.13, 1.7}) {
    DriveParameters dr;
    dr.current_amplitude_a = amp;
    const StepperAxisModel m(MotorParameters{}, dr, AxisMechanics{});
    ControllerParameters p;
    for (double deg : {0.0, 30.0, 45.0, 60.0}) {
      for (ControllerKind k : all_controllers()) {
        EXPECT_TRUE(analyse_loop(k, p, m, deg * kPi / 180.0).stable) << to_string(k) << " " << deg << " " << amp;
      }
    }
  }
}

}  // namespace
}  // namespace amctl::closedloop

namespace amctl::closedloop {
namespace {

// The lead cap (docs/closedloop.md, section 3.1): the command's lead over a carriage held still
// settles the rotor where Kt I sin(d) = r k (r th - y) and (r / p) d + (r th - y) = c - y.
// The settled angle, solved for here by bisection, stays at or below the design angle when
// c - y is the cap, and the cap is the closed form by hand.
TEST(CommandGovernor, TheLeadCapHoldsTheRotorAtOrBelowTheDesignAngle) {
  MotorParameters mp;
  mp.detent_torque_n_m = 0.0;
  AxisMechanics ax;
  const double k = ax.belt.stiffness_n_per_m;
  ax.belt.mass_kg = 1e7;  // the carriage held still
  ax.belt.damping_n_s_per_m = 0.0;
  ax.coulomb_friction_n = ax.viscous_friction_n_s_per_m = 0.0;
  const StepperAxisModel m(mp, DriveParameters{}, ax);
  const CommandGovernor g(m, GovernorParameters{}, 1.7);
  const double r = 0.040 / (2 * kPi), p = 50.0, s = 0.040 / 3200 * 1e3;
  const double kt_i = 0.40 / std::numbers::sqrt2;  // Kt I at 1.7 A (at rest V / R > I)
  const double cap = 1e3 * kt_i * std::sin(kPi / 3) / (r * k) + 1e3 * (r / p) * kPi / 3 - 0.5 * s;
  EXPECT_NEAR(g.max_lead_mm(0.0, 1.7), cap, 1e-12);
  // The largest whole microstep within the cap, reached a microstep per millisecond (as the
  // governor's step limits bring a lead in) and held until the rotor settles.
  const auto n = static_cast<std::int64_t>(std::floor(cap / s + 0.5));
  MotorState st = m.rest_state(0.0);
  for (std::int64_t j = 1; j <= n; ++j) {
    m.set_microstep(st, j);
    for (int i = 0; i < 50; ++i) m.step(st, 20e-6);
  }
  for (int i = 0; i < 40000; ++i) m.step(st, 20e-6);  // 0.8 s: the rotor's ringing dies out
  const double c_mm = static_cast<double>(n) * s;
  double lo = 0.0, hi = kPi / 2;
  for (int i = 0; i < 80; ++i) {
    const double d = 0.5 * (lo + hi);
    const double lead = 1e3 * (r / p) * d + 1e3 * kt_i * std::sin(d) / (r * k);
    (lead < c_mm ? lo : hi) = d;
  }
  EXPECT_NEAR(m.load_angle_rad(st), lo, 2e-3);
  EXPECT_LE(m.load_angle_rad(st), kPi / 3 + 2e-3);
  EXPECT_GT(m.load_angle_rad(st), kPi / 3 - 0.05);  // the cap is not needlessly tight
}

}  // namespace
}  // namespace amctl::closedloop

namespace amctl::closedloop {
namespace {

// The rotor observer (section 3.2) against closed forms: with the carriage held and the
// command held, the rotor settles where the motor's torque balances the belt,
//   Kt I sin(p (c - q) / r) = r k (q - y)          (at rest T_po = Kt I),
// solved here by bisection; and about that balance the rotor rings on the motor's and the
// belt's springs in parallel, w^2 = (p Kt I / r + r k) r / J.
TEST(RotorObserver, SettlesAtTheStaticBalanceOfMotorAndBelt) {
  const StepperAxisModel m(MotorParameters{}, DriveParameters{}, AxisMechanics{});
  RotorObserver obs(m, 70.0, 0.0);
  const double c = 0.1, y = 0.0, i_a = 1.7, T = 1e-4;  // 45 deg of command lead at q = 0
  for (int k = 0; k < 20000; ++k) obs.commit(obs.predict(c, c, y, 0.0, i_a, T));
  const double r = m.pulley_radius_m(), p = m.motor().pole_pairs();
  const double kt = m.motor().torque_constant_n_m_per_a(), kb = m.axis().belt.stiffness_n_per_m;
  double lo = 0.0, hi = c * 1e-3;  // q in metres between the carriage and the command
  for (int k = 0; k < 200; ++k) {
    const double q = 0.5 * (lo + hi);
    const double f = kt * i_a * std::sin(p * (c * 1e-3 - q) / r) - r * kb * (q - y);
    (f > 0.0 ? lo : hi) = q;
  }
  EXPECT_NEAR(obs.state().q_mm, 0.5 * (lo + hi) * 1e3, 1e-6);
  EXPECT_NEAR(obs.state().qd_mm_s, 0.0, 1e-6);
  // The largest lead over the rotor: (r / p) 70 deg less half a microstep.
  EXPECT_NEAR(obs.max_lead_mm(), 1e3 * r / p * 70.0 * kPi / 180.0 - 0.5 * m.step_distance_mm(), 1e-12);
}

TEST(RotorObserver, RingsAtTheRotorsFrequencyOnMotorAndBeltSprings) {
  // Small signal about the balance at c = y = 0: J q'' / r = -(p Kt I / r + r k) q, so
  // w = sqrt((p Kt I / r + r k) r / J). A 1 um step of the command, carriage held; the
  // observer's rotor crosses its new balance every half period.
  const StepperAxisModel m(MotorParameters{}, DriveParameters{}, AxisMechanics{});
  RotorObserver obs(m, 70.0, 0.0);
  const double r = m.pulley_radius_m(), p = m.motor().pole_pairs(), j = m.inertia_kg_m2();
  const double kt = m.motor().torque_constant_n_m_per_a(), kb = m.axis().belt.stiffness_n_per_m;
  const double w = std::sqrt((p * kt * 1.7 / r + r * kb) * r / j);
  const double c = 1e-3, q_eq = c * (p * kt * 1.7 / r) / (p * kt * 1.7 / r + r * kb);
  const double T = 1e-5;  // fine periods for timing the crossings
  double t = 0.0, prev = obs.state().q_mm - q_eq;
  std::vector<double> crossings;
  while (crossings.size() < 5 && t < 0.1) {
    obs.commit(obs.predict(c, c, 0.0, 0.0, 1.7, T));
    t += T;
    const double e = obs.state().q_mm - q_eq;
    if ((e > 0.0) != (prev > 0.0)) crossings.push_back(t - T * e / (e - prev));
    prev = e;
  }
  ASSERT_EQ(crossings.size(), 5u);
  const double period = 0.5 * (crossings[4] - crossings[0]);
  // Damped by the rotor's b and the belt's damping (ratio ~0.1 here): the damped period is
  // longer by 1 / sqrt(1 - zeta^2), under 1 %.
  EXPECT_NEAR(period, 2.0 * kPi / w, 0.01 * 2.0 * kPi / w);
}

}  // namespace
}  // namespace amctl::closedloop
