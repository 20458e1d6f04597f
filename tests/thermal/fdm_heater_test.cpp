// FDM hotend/bed loops. Reference values are hand calculations stated next to each assertion
// and, for the relay autotune, the describing-function prediction computed here from the
// plant's transfer function by bisection on the phase (a different method from the relay
// simulation).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <complex>
#include <numbers>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/thermal/fdm_heater.hpp"

using namespace amctl::thermal;
using cd = std::complex<double>;

namespace {
// duty -> sensor transfer function of the plant: heater (and core) to block, the sensor's
// first-order lag, the transport delay e^{-s L}.
cd rational_tf(const HeaterPlantParams& p, double w) {
  const cd s(0.0, w);
  const double g = p.core_to_block_w_k, h = p.loss_w_k;
  const cd tb = p.heater_power_w * g /
                ((p.core_capacity_j_k * s + g) * (p.block_capacity_j_k * s + g + h) - g * g);
  return tb / (p.sensor_time_constant_s * s + 1.0);
}
double gain(const HeaterPlantParams& p, double w) { return std::abs(rational_tf(p, w)); }
// Unwrapped phase: the rational part's factors each within (-180, 0], then the delay.
double phase(const HeaterPlantParams& p, double w) {
  const cd s(0.0, w);
  const double g = p.core_to_block_w_k, h = p.loss_w_k;
  const cd den = (p.core_capacity_j_k * s + g) * (p.block_capacity_j_k * s + g + h) - g * g;
  return -std::arg(den) - std::atan(w * p.sensor_time_constant_s) - w * p.sensor_delay_s;
}
}  // namespace

TEST(HeaterPlant, SteadyStateIsPowerOverLossWithFanAndFlow) {
  HeaterPlantParams p = HeaterPlantParams::hotend();
  HeaterPlant plant(p);
  for (int i = 0; i < 20000; ++i) plant.step(0.1, 0.5, 1.0, 10.0);
  // T = 25 + P/2 / (h0 + h_fan + 2.2e-3 * 10): 25 + 19 / (1/20.5 + 1/10.1 - 1/20.5 + 0.022)
  // = 25 + 19 / 0.12101 = 182.01 C for the E3D V6 of Prusa's model.
  const double h = p.loss_w_k + p.fan_extra_loss_w_k + p.filament_j_mm3k * 10.0;
  EXPECT_NEAR(h, 1.0 / 10.1 + 0.022, 1e-12);
  EXPECT_NEAR(plant.sensor_c(), 25.0 + 0.5 * p.heater_power_w / h, 1e-3);
}

TEST(HeaterPlant, InitialHeatingRateIsPowerOverTotalCapacityAfterTheLags) {
  HeaterPlantParams p = HeaterPlantParams::hotend();
  HeaterPlant plant(p);
  for (int i = 0; i < 300; ++i) plant.step(0.1, 1.0, 0.0, 0.0);
  const double b0 = plant.block_c();
  plant.step(1.0, 1.0, 0.0, 0.0);
  // Near ambient the loss is small: dT/dt -> P / C = 38 W / 12.1 J/K = 3.1 K/s less h0 (T-25)/C.
  const double expected = (p.heater_power_w - p.loss_w_k * (b0 - 25.0)) /
                          (p.block_capacity_j_k + p.core_capacity_j_k);
  EXPECT_NEAR(plant.block_c() - b0, expected, 0.02 * expected);
}

TEST(HeaterPlant, TheReadingIsTheSensorNodeOneDelayLater) {
  // The same plant with and without the transport delay: on a 0.1 s grid and a 2.1 s delay the
  // delayed reading at t is the undelayed one at t - 2.1 s exactly (a sample sits there), and
  // the start value (ambient) before.
  HeaterPlantParams p = HeaterPlantParams::hotend();
  ASSERT_EQ(p.sensor_delay_s, 2.1);
  HeaterPlantParams q = p;
  q.sensor_delay_s = 0.0;
  HeaterPlant delayed(p), direct(q);
  std::vector<double> history{direct.sensor_c()};
  for (int i = 1; i <= 300; ++i) {
    const double duty = i < 150 ? 1.0 : 0.2;
    delayed.step(0.1, duty, 0.0, 0.0);
    direct.step(0.1, duty, 0.0, 0.0);
    history.push_back(direct.sensor_c());
    const double want = i < 21 ? 25.0 : history[static_cast<std::size_t>(i - 21)];
    ASSERT_NEAR(delayed.sensor_c(), want, 1e-9) << "step " << i;
  }
}

TEST(RelayAutotune, UltimateGainAndPeriodMatchTheDescribingFunction) {
  HeaterPlantParams p = HeaterPlantParams::hotend();
  // Phase crossover of the plant by bisection: arg G(j w) = -180 deg (the phase falls
  // monotonically: poles and the delay).
  double lo = 1e-3, hi = 10.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = std::sqrt(lo * hi);
    if (phase(p, mid) > -std::numbers::pi) lo = mid; else hi = mid;
  }
  const double w180 = lo;
  const double ku_df = 1.0 / gain(p, w180);
  const double tu_df = 2.0 * std::numbers::pi / w180;
  AutotuneOptions o;
  o.target_c = 210.0;
  o.lockout_s = 0.5;  // short lockout so the relay period is set by the plant
  o.cycles = 8;
  const auto r = relay_autotune(HeaterPlant(p), o);
  ASSERT_TRUE(r.ok) << r.message;
  std::printf("relay: Ku %.4f (DF %.4f)  Tu %.3f s (DF %.3f s)  bias %.4f\n", r.ku, ku_df, r.tu_s,
              tu_df, r.bias);
  // The describing function is a first-harmonic approximation: agreement within ~20 %.
  EXPECT_NEAR(r.ku, ku_df, 0.2 * ku_df) << "Ku DF " << ku_df;
  EXPECT_NEAR(r.tu_s, tu_df, 0.2 * tu_df) << "Tu DF " << tu_df;
  // Bias converges to the duty that holds 210 C: h0 185 / P = 185 / 20.5 / 38 = 0.2375.
  EXPECT_NEAR(r.bias, p.loss_w_k * 185.0 / p.heater_power_w, 0.03);
}

TEST(RelayAutotune, RulesGiveTheTextbookRatios) {
  const auto c = tuning_rule(TuningRule::classic_zn, 2.0, 10.0);
  EXPECT_DOUBLE_EQ(c.kp(), 1.2);
  EXPECT_DOUBLE_EQ(c.ki_per_s(), 0.24);   // 2 kp / Tu
  EXPECT_DOUBLE_EQ(c.kd_s(), 1.5);    // kp Tu / 8
  const auto n = tuning_rule(TuningRule::no_overshoot, 2.0, 10.0);
  EXPECT_DOUBLE_EQ(n.kp(), 0.4);
  EXPECT_DOUBLE_EQ(n.ki_per_s(), 0.08);
  EXPECT_NEAR(n.kd_s(), 4.0 / 3.0, 1e-15);
  EXPECT_THROW((void)tuning_rule(TuningRule::classic_zn, 0.0, 1.0), amctl::Error);
}

TEST(MpcIdentification, RecoversTheModelOfAPlantWithTheSameStructure) {
  HeaterPlantParams p = HeaterPlantParams::hotend();
  p.core_capacity_j_k = 0.0;  // exactly the block + sensor model: no core, no delay
  p.sensor_delay_s = 0.0;
  IdentifyOptions io;
  io.filament_j_mm3k = p.filament_j_mm3k;
  const auto id = identify_mpc_model(HeaterPlant(p), io);
  std::printf("identified: asym %.2f C  C %.3f J/K  R %.4f 1/s  A %.5f W/K  F %.5f W/K\n",
              id.asymptotic_temp_c, id.model.block_capacity_j_k, id.model.sensor_responsiveness_1_s,
              id.model.loss_w_k, id.model.loss_w_k + id.model.fan_extra_loss_w_k);
  const double rise = p.heater_power_w / p.loss_w_k;  // 38 W x 20.5 K/W = 779 K
  EXPECT_NEAR(id.asymptotic_temp_c, 25.0 + rise, 0.02 * rise);
  EXPECT_NEAR(id.model.block_capacity_j_k, p.block_capacity_j_k, 0.03 * p.block_capacity_j_k);
  EXPECT_NEAR(id.model.sensor_responsiveness_1_s, 1.0 / p.sensor_time_constant_s,
              0.05 / p.sensor_time_constant_s);
  EXPECT_NEAR(id.model.loss_w_k, p.loss_w_k, 0.01 * p.loss_w_k);
  // The full-fan loss comes from the mean holding power over a minute after a minute's settling
  // of the 120 s block: 1.7 % high on the E3D V6's fan step (0.049 -> 0.099 W/K).
  const double full_fan = p.loss_w_k + p.fan_extra_loss_w_k;
  EXPECT_NEAR(id.model.loss_w_k + id.model.fan_extra_loss_w_k, full_fan, 0.02 * full_fan);
}

TEST(MpcController, HoldsTheTargetWithoutSteadyStateError) {
  const HeaterPlantParams p = HeaterPlantParams::hotend();
  const auto id = identify_mpc_model(HeaterPlant(p), IdentifyOptions{});
  MpcController mpc(id.model, MpcOptions{}, 25.0);
  HeaterPlant plant(p);
  double sum = 0.0;  // the mean over the last 100 s: the ambient-estimate limit cycle averages out
  for (int i = 0; i < 4000; ++i) {
    const double y = plant.measured_c();
    plant.step(0.1, mpc.update(210.0, y, 0.0, 5.0, 0.1), 0.0, 5.0);
    if (i >= 3000) sum += plant.sensor_c();
  }
  EXPECT_NEAR(sum / 1000.0, 210.0, 0.05);
}

TEST(HeaterComparison, MpcRejectsFanAndFlowBetterThanTheAutotunedPid) {
  const HeaterPlantParams p = HeaterPlantParams::hotend();
  const auto at = relay_autotune(HeaterPlant(p), AutotuneOptions{});
  ASSERT_TRUE(at.ok);
  const auto id = identify_mpc_model(HeaterPlant(p), IdentifyOptions{});
  HeaterScenario sc;
  amctl::control::PidController pid(at.gains, heater_pid_options());
  MpcController mpc(id.model, MpcOptions{}, p.ambient_c);
  const auto rp = run_heater_scenario(p, sc,
      [&](double t, double y, double, double, double dt) { return pid.update(t, y, dt); }, "pid");
  const auto rm = run_heater_scenario(p, sc,
      [&](double t, double y, double f, double q, double dt) { return mpc.update(t, y, f, q, dt); },
      "mpc");
  EXPECT_LT(rm.flow_ripple_k, 0.5 * rp.flow_ripple_k);
  EXPECT_LT(rm.fan_max_dev_k, rp.fan_max_dev_k);
  EXPECT_LT(rm.overshoot_k, rp.overshoot_k);
  // Both reach the target within 2 minutes (38 W into 12.1 J/K over 184 K needs 59 s at least).
  EXPECT_LT(rp.heat_up_time_s, 120.0);
  EXPECT_LT(rm.heat_up_time_s, 120.0);
  EXPECT_GT(rm.heat_up_time_s, (p.block_capacity_j_k + p.core_capacity_j_k) * 184.0 / p.heater_power_w);
}

TEST(PidController, AntiWindupCutsTheOvershootOfALongSaturatedHeatUp) {
  const HeaterPlantParams p = HeaterPlantParams::hotend();
  const auto g = amctl::control::PidGains::parallel(0.05, 0.01, 0.1);
  auto overshoot = [&](amctl::control::AntiWindup aw, bool plain) {
    amctl::control::PidOptions o = heater_pid_options();
    o.anti_windup = aw;
    o.full_output_band = 0.0;  // PID from cold: the integrator sees the whole rise
    amctl::control::PidController pid(g, o);
    HeaterPlant plant(p);
    double mx = 0.0;
    double integral = 0.0;  // a plain, unprotected PI-D for reference
    for (int i = 0; i < 4000; ++i) {
      const double y = plant.measured_c();
      double u;
      if (plain) {
        integral += g.ki_per_s() * (200.0 - y) * 0.1;
        u = std::clamp(g.kp() * (200.0 - y) + integral, 0.0, 1.0);
      } else {
        u = pid.update(200.0, y, 0.1);
      }
      plant.step(0.1, u, 0.0, 0.0);
      mx = std::max(mx, plant.sensor_c());
    }
    return mx - 200.0;
  };
  const double none = overshoot(amctl::control::AntiWindup::conditional_integration, true);
  EXPECT_GT(none, 20.0);
  EXPECT_LT(overshoot(amctl::control::AntiWindup::conditional_integration, false), 0.3 * none);
  EXPECT_LT(overshoot(amctl::control::AntiWindup::back_calculation, false), 0.3 * none);
}

TEST(HeaterPlant, RejectsNonPositiveConstantsNamingThem) {
  HeaterPlantParams p;
  p.block_capacity_j_k = 0.0;
  try {
    HeaterPlant plant(p);
    FAIL();
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("block_capacity_j_k"), std::string::npos);
  }
  p = HeaterPlantParams{};
  p.heater_power_w = -40;
  EXPECT_THROW(HeaterPlant{p}, amctl::Error);
  EXPECT_THROW((void)amctl::control::PidGains::parallel(-1, 0, 0), amctl::Error);
}
