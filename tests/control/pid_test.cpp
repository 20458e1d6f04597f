// The PI/PID law, its anti-windup rules and its transfer function, each against values
// worked out by hand in the comments.
#include "amctl/control/pid.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl::control {
namespace {

using cd = std::complex<double>;

TEST(PidGains, StandardAndParallelFormsConvertBothWays) {
  const PidGains s = PidGains::standard(2.0, 0.5, 0.25);
  EXPECT_EQ(s.form(), PidGains::Form::standard);
  EXPECT_DOUBLE_EQ(s.ki_per_s(), 4.0);  // kp / Ti
  EXPECT_DOUBLE_EQ(s.kd_s(), 0.5);      // kp Td
  EXPECT_EQ(s.integral_time_s(), 0.5);  // as given, not recomputed
  const PidGains p = PidGains::parallel(2.0, 4.0, 0.5);
  EXPECT_DOUBLE_EQ(p.integral_time_s(), 0.5);
  EXPECT_DOUBLE_EQ(p.derivative_time_s(), 0.25);
  EXPECT_EQ(p.ki_per_s(), 4.0);
  const PidGains p_only = PidGains::standard(3.0, std::numeric_limits<double>::infinity());
  EXPECT_EQ(p_only.ki_per_s(), 0.0);
  EXPECT_TRUE(std::isinf(PidGains::parallel(3.0, 0.0).integral_time_s()));
}

TEST(PidGains, RejectsNegativeAndNonFiniteGains) {
  EXPECT_THROW((void)PidGains::parallel(-1.0, 0.0), Error);
  EXPECT_THROW((void)PidGains::parallel(1.0, std::nan("")), Error);
  EXPECT_THROW((void)PidGains::parallel(1.0, 0.0, -0.1), Error);
  EXPECT_THROW((void)PidGains::standard(1.0, 0.0), Error);
  EXPECT_THROW((void)PidGains::standard(1.0, -2.0), Error);
  EXPECT_THROW((void)PidGains::standard(1.0, std::nan("")), Error);
  EXPECT_THROW((void)PidGains::standard(std::numeric_limits<double>::infinity(), 1.0), Error);
}

TEST(PidGains, TransferFunctionMatchesHandValues) {
  // Standard PI kp = 2, Ti = 0.5 at s = 4j: 2 (1 + 1/(2j)) = 2 - 1j.
  const cd c = PidGains::standard(2.0, 0.5).transfer(cd(0.0, 4.0));
  EXPECT_NEAR(c.real(), 2.0, 1e-15);
  EXPECT_NEAR(c.imag(), -1.0, 1e-15);
  // Parallel kp = 1, ki = 2, kd = 0.5, filter Tf = 0.1 at s = 10j:
  // 1 + 2/(10j) + 0.5 (10j)/(1 + 1j) = 1 - 0.2j + (5 + 5j)/2 = 3.5 + 2.3j.
  const cd d = PidGains::parallel(1.0, 2.0, 0.5).transfer(cd(0.0, 10.0), 0.1);
  EXPECT_NEAR(d.real(), 3.5, 1e-14);
  EXPECT_NEAR(d.imag(), 2.3, 1e-14);
}

TEST(PidController, UnsaturatedPiFollowsTheLawStepByStep) {
  // kp = 2, ki = 0.5 /s, r = 1, y = 0.25, T = 0.1 s: e = 0.75, each step adds
  // ki e T = 0.0375 to I after the output kp e + I is formed.
  PidController pi(PidGains::parallel(2.0, 0.5), PidOptions{});
  const double expected[] = {1.5, 1.5375, 1.575, 1.6125};
  for (double u : expected) EXPECT_NEAR(pi.update(1.0, 0.25, 0.1), u, 1e-15);
  EXPECT_NEAR(pi.integral(), 4 * 0.0375, 1e-15);
  pi.reset();
  EXPECT_EQ(pi.integral(), 0.0);
  EXPECT_NEAR(pi.update(1.0, 0.25, 0.1), 1.5, 1e-15);
}

// A plant pinned at y = 0 (a heater at full power that cannot move yet): r = 2, kp = 1,
// ki = 1 /s, T = 0.5 s, output in [0, 1]. e = 2, ki e T = 1 per step, u_unsat = 2 + I.
std::vector<double> integrals_while_saturated(AntiWindup aw) {
  PidOptions o;
  o.output_min = 0.0;
  o.output_max = 1.0;
  o.anti_windup = aw;
  o.tracking_time_s = 1.0;
  PidController pi(PidGains::parallel(1.0, 1.0), o);
  std::vector<double> out;
  for (int i = 0; i < 4; ++i) {
    const PidStep s = pi.step(2.0, 0.0, 0.5);
    EXPECT_EQ(s.output, 1.0);
    EXPECT_TRUE(s.saturated);
    out.push_back(pi.integral());
  }
  // Then the plant overshoots to y = 2.5 (e = -0.5): the wound-up integrators keep the
  // output at the top, the protected ones let it fall.
  out.push_back(pi.update(2.0, 2.5, 0.5));
  return out;
}

TEST(PidController, AntiWindupRulesOnASaturatingPlantMatchTheHandCalculation) {
  // none: I = 1, 2, 3, 4; then u = kp e + I = -0.5 + 4 -> still 1.
  EXPECT_EQ(integrals_while_saturated(AntiWindup::none), (std::vector<double>{1, 2, 3, 4, 1}));
  // clamp_integral: I = min(I + 1, 1) = 1 each step; then -0.5 + 1 = 0.5.
  EXPECT_EQ(integrals_while_saturated(AntiWindup::clamp_integral),
            (std::vector<double>{1, 1, 1, 1, 0.5}));
  // conditional_integration: saturated high with e > 0, so I stays 0; then -0.5 -> 0.
  EXPECT_EQ(integrals_while_saturated(AntiWindup::conditional_integration),
            (std::vector<double>{0, 0, 0, 0, 0}));
  // back_calculation, Tt = 1 s: I += 1 + (1 - (2 + I)) 0.5 = 0.5 + I/2:
  // 0.5, 0.75, 0.875, 0.9375 (towards I = 1, where ki e = (u_unsat - u)/Tt); then
  // -0.5 + 0.9375 = 0.4375.
  EXPECT_EQ(integrals_while_saturated(AntiWindup::back_calculation),
            (std::vector<double>{0.5, 0.75, 0.875, 0.9375, 0.4375}));
}

TEST(PidController, ConditionalIntegrationFreezesOnlyWhileTheErrorDrivesIntoTheLimit) {
  PidOptions o;
  o.output_min = 0.0;
  o.output_max = 1.0;
  o.anti_windup = AntiWindup::conditional_integration;
  // kp = 10, ki = 1 /s, T = 1 s.
  PidController pi(PidGains::parallel(10.0, 1.0), o);
  (void)pi.step(0.0, 1.0, 1.0);  // e = -1: u_unsat = -10 below 0 and e < 0: I frozen at 0
  EXPECT_EQ(pi.integral(), 0.0);
  EXPECT_EQ(pi.step(0.0, -0.5, 1.0).output, 1.0);  // e = 0.5: u_unsat = 5 above 1, e > 0
  EXPECT_EQ(pi.integral(), 0.0);
  (void)pi.step(0.0, -0.05, 1.0);  // e = 0.05: u = 0.5 inside the limits: I += 0.05
  EXPECT_NEAR(pi.integral(), 0.05, 1e-15);
  // kp = 0, ki = 1 /s: wind I to -1 while unsaturated (u_unsat = I = 0 at the first step),
  // freeze while e < 0 keeps u_unsat = -1 below the limit, then integrate as soon as e > 0
  // drives the output back out of saturation: I = -1 + 0.5.
  PidController i_only(PidGains::parallel(0.0, 1.0), o);
  (void)i_only.step(0.0, 1.0, 1.0);
  EXPECT_EQ(i_only.integral(), -1.0);
  (void)i_only.step(0.0, 1.0, 1.0);
  EXPECT_EQ(i_only.integral(), -1.0);
  (void)i_only.step(0.0, -0.5, 1.0);
  EXPECT_EQ(i_only.integral(), -0.5);
}

TEST(PidController, DerivativeActsOnTheFilteredMeasurementOnly) {
  // kp = ki = 0, kd = 1 s: u = -dy/dt. A set-point jump gives no kick; a measurement ramp of
  // 1 per second gives -1 once the (unfiltered, Tf = 0) difference sees it.
  PidController d(PidGains::parallel(0.0, 0.0, 1.0), PidOptions{});
  EXPECT_EQ(d.update(0.0, 0.0, 0.1), 0.0);
  EXPECT_EQ(d.update(100.0, 0.0, 0.1), 0.0);
  EXPECT_NEAR(d.update(100.0, 0.1, 0.1), -1.0, 1e-12);
  // With Tf = T the filter moves half way each period: y_f = 0.05, dy_f/dt = -0.5 for u.
  PidOptions o;
  o.derivative_filter_s = 0.1;
  PidController f(PidGains::parallel(0.0, 0.0, 1.0), o);
  (void)f.update(0.0, 0.0, 0.1);
  EXPECT_NEAR(f.update(0.0, 0.1, 0.1), -0.5, 1e-12);
}

TEST(PidController, FullOutputBandSwitchesToTheLimitAndResetsTheIntegral) {
  PidOptions o;
  o.output_min = 0.0;
  o.output_max = 1.0;
  o.full_output_band = 10.0;
  PidController pi(PidGains::parallel(0.01, 0.1), o);
  (void)pi.step(100.0, 95.0, 1.0);  // e = 5 inside the band: I = 0.5
  EXPECT_NEAR(pi.integral(), 0.5, 1e-15);
  const PidStep cold = pi.step(100.0, 80.0, 1.0);  // e = 20: full on, I reset
  EXPECT_EQ(cold.output, 1.0);
  EXPECT_FALSE(cold.saturated);
  EXPECT_EQ(pi.integral(), 0.0);
  EXPECT_EQ(pi.update(100.0, 115.0, 1.0), 0.0);  // e = -15: full off
}

TEST(PidController, RejectsBadOptionsAndPeriods) {
  const PidGains g = PidGains::parallel(1.0, 1.0);
  PidOptions o;
  o.output_min = 1.0;
  o.output_max = 1.0;
  EXPECT_THROW(PidController(g, o), Error);
  o = PidOptions{};
  o.anti_windup = AntiWindup::back_calculation;
  o.tracking_time_s = 0.0;
  EXPECT_THROW(PidController(g, o), Error);
  o = PidOptions{};
  o.derivative_filter_s = -1.0;
  EXPECT_THROW(PidController(g, o), Error);
  PidController pi(g, PidOptions{});
  EXPECT_THROW((void)pi.update(1.0, 0.0, 0.0), Error);
  EXPECT_THROW((void)pi.update(1.0, 0.0, std::nan("")), Error);
  EXPECT_THROW((void)pi.update(1.0, std::nan(""), 0.1), Error);
  EXPECT_THROW((void)pi.update(std::numeric_limits<double>::infinity(), 0.0, 0.1), Error);
}

TEST(AntiWindup, NamesRoundTrip) {
  for (AntiWindup a : {AntiWindup::none, AntiWindup::clamp_integral,
                       AntiWindup::conditional_integration, AntiWindup::back_calculation})
    EXPECT_EQ(anti_windup_from_string(to_string(a)), a);
  EXPECT_FALSE(anti_windup_from_string("clamp").has_value());
}

}  // namespace
}  // namespace amctl::control
