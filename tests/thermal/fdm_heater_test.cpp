// FDM hotend/bed loops. Reference values are hand calculations stated next to each assertion
// and, for the relay autotune, the describing-function prediction computed here from the
// plant's transfer function by bisection on the phase (a different method from the relay
// simulation).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <complex>
#include <numbers>

#include "amctl/core/error.hpp"
#include "amctl/thermal/fdm_heater.hpp"

using namespace amctl::thermal;
using cd = std::complex<double>;

namespace {
// duty -> sensor transfer function of the three-node plant.
cd plant_tf(const HeaterPlantParams& p, double w) {
  const cd s(0.0, w);
  const double g = p.core_to_block_w_k, h = p.loss_w_k;
  const cd tb = p.heater_power_w * g /
                ((p.core_capacity_j_k * s + g) * (p.block_capacity_j_k * s + g + h) - g * g);
  return tb / (p.sensor_time_constant_s * s + 1.0);
}
}  // namespace

TEST(HeaterPlant, SteadyStateIsPowerOverLossWithFanAndFlow) {
  HeaterPlantParams p = HeaterPlantParams::hotend();
  HeaterPlant plant(p);
  for (int i = 0; i < 20000; ++i) plant.step(0.1, 0.5, 1.0, 10.0);
  // T = 25 + 20 W / (0.068 + 0.029 + 2.2e-3 * 10) = 25 + 20/0.119 = 193.07 C
  EXPECT_NEAR(plant.sensor_c(), 25.0 + 20.0 / 0.119, 1e-3);
}

TEST(HeaterPlant, InitialHeatingRateIsPowerOverTotalCapacityAfterTheLags) {
  HeaterPlantParams p = HeaterPlantParams::hotend();
  HeaterPlant plant(p);
  for (int i = 0; i < 300; ++i) plant.step(0.1, 1.0, 0.0, 0.0);
  const double b0 = plant.block_c();
  plant.step(1.0, 1.0, 0.0, 0.0);
  // Near ambient the loss is small: dT/dt -> 40 W / 18.2 J/K = 2.2 K/s less 0.068*(T-25)/C.
  const double expected = (40.0 - 0.068 * (b0 - 25.0)) / (16.7 + 1.5);
  EXPECT_NEAR(plant.block_c() - b0, expected, 0.02 * expected);
}

TEST(RelayAutotune, UltimateGainAndPeriodMatchTheDescribingFunction) {
  HeaterPlantParams p = HeaterPlantParams::hotend();
  // Phase crossover of the plant by bisection: arg G(j w) = -180 deg.
  double lo = 1e-3, hi = 10.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = std::sqrt(lo * hi);
    const double ph = std::arg(plant_tf(p, mid));
    // arg wraps from -pi to +pi past -180 deg; the three-pole phase goes 0 -> -270 deg.
    if (ph < 0.0) lo = mid; else hi = mid;
  }
  const double w180 = lo;
  const double ku_df = 1.0 / std::abs(plant_tf(p, w180));
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
  // Bias converges to the duty that holds 210 C: 0.068 * 185 / 40 = 0.3145.
  EXPECT_NEAR(r.bias, 0.068 * 185.0 / 40.0, 0.03);
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
  p.core_capacity_j_k = 0.0;  // exactly the block + sensor model
  IdentifyOptions io;
  io.filament_j_mm3k = p.filament_j_mm3k;
  const auto id = identify_mpc_model(HeaterPlant(p), io);
  std::printf("identified: asym %.2f C  C %.3f J/K  R %.4f 1/s  A %.5f W/K  F %.5f W/K\n",
              id.asymptotic_temp_c, id.model.block_capacity_j_k, id.model.sensor_responsiveness_1_s,
              id.model.loss_w_k, id.model.loss_w_k + id.model.fan_extra_loss_w_k);
  EXPECT_NEAR(id.asymptotic_temp_c, 25.0 + 40.0 / 0.068, 0.02 * 588.2);
  EXPECT_NEAR(id.model.block_capacity_j_k, 16.7, 0.03 * 16.7);
  EXPECT_NEAR(id.model.sensor_responsiveness_1_s, 0.22, 0.05 * 0.22);
  EXPECT_NEAR(id.model.loss_w_k, 0.068, 0.01 * 0.068);
  EXPECT_NEAR(id.model.loss_w_k + id.model.fan_extra_loss_w_k, 0.097, 0.01 * 0.097);
}

TEST(MpcController, HoldsTheTargetWithoutSteadyStateError) {
  const HeaterPlantParams p = HeaterPlantParams::hotend();
  const auto id = identify_mpc_model(HeaterPlant(p), IdentifyOptions{});
  MpcController mpc(id.model, MpcOptions{}, 25.0);
  HeaterPlant plant(p);
  for (int i = 0; i < 4000; ++i) {
    const double y = plant.measured_c();
    plant.step(0.1, mpc.update(210.0, y, 0.0, 5.0, 0.1), 0.0, 5.0);
  }
  EXPECT_NEAR(plant.sensor_c(), 210.0, 0.05);
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
  // Both reach the target within 2 minutes (40 W into 18 J/K over 185 K needs ~85 s at least).
  EXPECT_LT(rp.heat_up_time_s, 120.0);
  EXPECT_LT(rm.heat_up_time_s, 120.0);
  EXPECT_GT(rm.heat_up_time_s, 18.2 * 184.0 / 40.0);
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
