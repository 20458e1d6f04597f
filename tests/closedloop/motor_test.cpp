// The stepper physics against closed forms: the rotor's small-signal frequency on its
// magnetic spring, the static load angle asin(T / (Kt I)), slipping beyond pull-out, and the
// pull-out torque at speed.
#include <cmath>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "amctl/closedloop/motor.hpp"
#include "amctl/core/error.hpp"

namespace amctl::closedloop {
namespace {

// Rotor alone: belt almost slack, no damping, no detent, a current loop fast enough that the
// phase currents stay at their reference.
StepperAxisModel free_rotor(double detent_n_m = 0.0) {
  MotorParameters m;
  m.detent_torque_n_m = detent_n_m;
  m.rotor_damping_n_m_s_per_rad = 0.0;
  DriveParameters d;
  d.current_loop_bandwidth_hz = 1e6;
  d.supply_voltage_v = 1e4;
  AxisMechanics a;
  a.belt = {1.0, 1e-6, 0.0};
  a.coulomb_friction_n = 0.0;
  a.viscous_friction_n_s_per_m = 0.0;
  return StepperAxisModel(m, d, a);
}

double measured_period_s(const StepperAxisModel& model, double h) {
  MotorState s = model.rest_state(0.0);
  const double th0 = 0.002 / model.motor().pole_pairs();  // 0.002 rad electrical
  s.theta_rad = th0;
  double prev = s.theta_rad, first = -1.0, last = -1.0;
  int crossings = 0;
  for (int k = 1; k * h < 0.05; ++k) {
    model.step(s, h);
    if (prev < 0.0 && s.theta_rad >= 0.0) {
      const double t = (k - 1 + prev / (prev - s.theta_rad)) * h;  // linear interpolation
      if (first < 0) first = t;
      last = t;
      ++crossings;
    }
    prev = s.theta_rad;
  }
  return (last - first) / (crossings - 1);
}

TEST(StepperPhysics, RotorRingsAtSqrtOfMagneticStiffnessOverInertia) {
  const StepperAxisModel model = free_rotor();
  // 17HS4401: Kt = 0.40 N m / (sqrt 2 * 1.7 A), I = 1.7 A, p = 50, J = 54 + 1.5 g cm^2.
  const double k = 50.0 * 0.40 / std::numbers::sqrt2;
  const double j = 54e-7 + 1.5e-7;
  const double period = 2.0 * std::numbers::pi / std::sqrt(k / j);
  EXPECT_NEAR(measured_period_s(model, 1e-6), period, 2e-3 * period);
  // The simulator's default substep (20 us) keeps the frequency within 0.5 %.
  EXPECT_NEAR(measured_period_s(model, 20e-6), period, 5e-3 * period);
}

TEST(StepperPhysics, DetentTorqueStiffensTheSpringByFourTimesItsAmplitude) {
  const StepperAxisModel model = free_rotor(0.022);
  const double k = 50.0 * (0.40 / std::numbers::sqrt2 + 4.0 * 0.022);
  EXPECT_NEAR(model.magnetic_stiffness_n_m_per_rad(), k, 1e-12);
  const double period = 2.0 * std::numbers::pi / std::sqrt(k / (54e-7 + 1.5e-7));
  EXPECT_NEAR(measured_period_s(model, 1e-6), period, 2e-3 * period);
}

AxisMechanics loaded_axis(double force_n) {
  AxisMechanics a;
  a.coulomb_friction_n = 0.0;
  a.viscous_friction_n_s_per_m = 200.0;  // settles quickly
  a.external_force_n = force_n;
  return a;
}

MotorParameters damped_motor() {
  MotorParameters m;
  m.detent_torque_n_m = 0.0;
  m.rotor_damping_n_m_s_per_rad = 0.02;
  return m;
}

TEST(StepperPhysics, StaticLoadAngleIsArcsineOfTorqueOverPullOut) {
  const double f = 20.0;  // N pushing the carriage towards +x
  const StepperAxisModel model(damped_motor(), DriveParameters{}, loaded_axis(f));
  MotorState s = model.rest_state(0.0);
  for (int k = 0; k < 25000; ++k) model.step(s, 20e-6);  // 0.5 s
  // Torque balance: Kt I sin(d) = -r F (the load drives the rotor forward: d < 0).
  const double r = 0.040 / (2.0 * std::numbers::pi);
  const double kt_i = 0.40 / std::numbers::sqrt2;
  EXPECT_NEAR(model.load_angle_rad(s), std::asin(-r * f / kt_i), 1e-4);
  EXPECT_EQ(model.slip_cycles(s), 0);
}

TEST(StepperPhysics, ALoadBeyondPullOutSlipsWholeElectricalCycles) {
  const double r = 0.040 / (2.0 * std::numbers::pi);
  const double pull_out_force = 0.40 / std::numbers::sqrt2 / r;  // 44.4 N
  const StepperAxisModel model(damped_motor(), DriveParameters{}, loaded_axis(1.2 * pull_out_force));
  MotorState s = model.rest_state(0.0);
  for (int k = 0; k < 5000; ++k) model.step(s, 20e-6);
  EXPECT_LT(model.slip_cycles(s), 0);  // rotor ran ahead of the command by whole cycles
  const StepperAxisModel ok(damped_motor(), DriveParameters{}, loaded_axis(0.9 * pull_out_force));
  MotorState t = ok.rest_state(0.0);
  for (int k = 0; k < 5000; ++k) ok.step(t, 20e-6);
  EXPECT_EQ(ok.slip_cycles(t), 0);
}

TEST(StepperPhysics, BacklashShiftsTheHeldCarriageByHalfTheLostMotion) {
  // A steady force F on the carriage: the belt holds it at stretch -(F/k) beyond the edge of
  // the deadband, so the carriage sits F/k + B/2 ahead of the pulley; the rotor's torque is the
  // same with or without backlash, so the two positions differ by exactly B/2.
  const double f = 20.0, b_mm = 0.3;
  AxisMechanics with = loaded_axis(f);
  with.backlash_mm = b_mm;
  const StepperAxisModel tight(damped_motor(), DriveParameters{}, loaded_axis(f));
  const StepperAxisModel loose(damped_motor(), DriveParameters{}, with);
  MotorState a = tight.rest_state(0.0), b = loose.rest_state(0.0);
  for (int k = 0; k < 25000; ++k) {
    tight.step(a, 20e-6);
    loose.step(b, 20e-6);
  }
  EXPECT_NEAR(StepperAxisModel::position_mm(b) - StepperAxisModel::position_mm(a), b_mm / 2, 1e-6);
  EXPECT_NEAR(loose.load_angle_rad(b), tight.load_angle_rad(a), 1e-9);
  // Stretch of the engaged belt: F / k beyond the deadband's edge.
  const double k = with.belt.stiffness_n_per_m;
  const double stretch_mm = (b.theta_rad * loose.pulley_radius_m() - b.x_m) * 1e3;
  EXPECT_NEAR(stretch_mm, -(f / k * 1e3 + b_mm / 2), 1e-6);
}

TEST(StepperPhysics, InsideTheDeadbandTheBeltCarriesNoForce) {
  AxisMechanics a;
  a.backlash_mm = 0.4;
  a.coulomb_friction_n = 0.0;
  a.viscous_friction_n_s_per_m = 0.0;
  const StepperAxisModel model(damped_motor(), DriveParameters{}, a);
  MotorState s = model.rest_state(0.0);
  s.x_m += 0.15e-3;  // within +-0.2 mm of the pulley: no contact
  const double x0 = s.x_m;
  for (int k = 0; k < 1000; ++k) model.step(s, 20e-6);
  EXPECT_EQ(s.x_m, x0);
  EXPECT_EQ(s.v_m_s, 0.0);
}

TEST(StepperPhysics, ABoostedCurrentHoldsTheLoadAtTheSmallerAngle) {
  // set_current raises the phase current reference: the static load angle becomes
  // asin(r F / (Kt I)) at the new I; and it is clamped to the drive's maximum.
  const double f = 30.0, r = 0.040 / (2.0 * std::numbers::pi);
  DriveParameters d;
  d.current_amplitude_a = 1.0;
  d.max_current_a = 1.5;
  const StepperAxisModel model(damped_motor(), d, loaded_axis(f));
  MotorState s = model.rest_state(0.0);
  model.set_current(s, 2.0);
  EXPECT_DOUBLE_EQ(s.current_a, 1.5);
  for (int k = 0; k < 25000; ++k) model.step(s, 20e-6);
  const double kt = 0.40 / (std::numbers::sqrt2 * 1.7);
  EXPECT_NEAR(model.load_angle_rad(s), std::asin(-r * f / (kt * 1.5)), 1e-4);
}

TEST(StepperPhysics, PullOutTorqueFallsWithSpeed) {
  const StepperAxisModel model(MotorParameters{}, DriveParameters{}, AxisMechanics{});
  const double kt = 0.40 / (std::numbers::sqrt2 * 1.7);
  EXPECT_NEAR(model.pull_out_torque_at_n_m(0.0), kt * 1.7, 1e-12);
  // 100 rad/s: |R + j p w L| = |1.5 + 14j| ohm, headroom 24 V - Kt w.
  const double i = (24.0 - kt * 100.0) / std::hypot(1.5, 14.0);
  EXPECT_NEAR(model.pull_out_torque_at_n_m(100.0), kt * i, 1e-12);
  EXPECT_LT(model.pull_out_torque_at_n_m(100.0), model.pull_out_torque_at_n_m(20.0));
}

TEST(StepperPhysics, BadParametersAreNamed) {
  DriveParameters d;
  d.microsteps = 0;
  try {
    StepperAxisModel(MotorParameters{}, d, AxisMechanics{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("drive.microsteps"), std::string::npos) << e.what();
  }
  AxisMechanics a;
  a.rotation_distance_mm = -40.0;
  try {
    StepperAxisModel(MotorParameters{}, DriveParameters{}, a);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("axis.rotation_distance_mm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amctl::closedloop
