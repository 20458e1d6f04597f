// Closed-loop SLS build: conservation, mesh-coarsening accuracy, anti-windup behaviour, the
// example configuration and bad input. Reference values are physical balances computed here
// by hand (stated in each test), not copied from the simulator.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/thermal/powder_bed_sim.hpp"

using namespace amctl::thermal;

TEST(SlsBuild, HeatBalanceCloses) {
  SlsBuildConfig c;
  c.layers_added = 60;
  const auto r = simulate_sls_build(c);
  // Heat content = initial + integral of (control + laser) + fresh powder, to round-off.
  EXPECT_LT(std::abs(r.energy_balance_error_j_m2), 1e-3);
  EXPECT_EQ(r.steps, 61 * 56);
}

TEST(SlsBuild, CoarsenedMeshReproducesTheUniformMesh) {
  SlsBuildConfig c;
  c.layers_added = 120;
  c.csv_every = 1;
  SlsBuildConfig u = c;
  u.coarsening.enabled = false;
  const auto rc = simulate_sls_build(c);
  const auto ru = simulate_sls_build(u);
  ASSERT_EQ(rc.trace.size(), ru.trace.size());
  ASSERT_GT(rc.trace.size(), 120u);  // one row per step, many steps per layer
  double max_diff = 0.0;
  for (std::size_t i = 0; i < rc.trace.size(); ++i)
    max_diff = std::max(max_diff, std::abs(rc.trace[i].y_c - ru.trace[i].y_c));
  EXPECT_LT(max_diff, 0.01);  // K
  EXPECT_LT(rc.final_nodes, ru.final_nodes / 3);
}

TEST(SlsBuild, IntegralActionRemovesTheSteadyStateErrorOfASetPointStep) {
  // No layer additions, a 3 K step on a 5 mm bed, 600 s: the whole bed must end at 175 C, so
  // the control energy is rho Cp * 5 mm * 3 K = 29 205 J/m^2 and the error vanishes.
  SlsBuildConfig c;
  c.layers_added = 0;
  c.layer_time_s = 600.0;
  c.laser_flux_w_m2 = 0.0;
  c.setpoint_changes = {{0, 175.0}};
  const auto r = simulate_sls_build(c);
  EXPECT_LT(r.final_abs_error_k, 1e-3);
  EXPECT_NEAR(r.total_effort_j_m2, 1010.0 * 1928.0 * 5e-3 * 3.0, 20.0);  // bed still 1e-3 K short
  EXPECT_LT(r.max_overshoot_k, 0.5);
}

TEST(SlsBuild, EachLayerDeficitIsReplacedByTheController) {
  SlsBuildConfig c;
  c.layers_added = 20;
  c.laser_flux_w_m2 = 0.0;
  const auto r = simulate_sls_build(c);
  // Each fresh layer brings rho Cp l0 (172 - 150) = 4283 J/m^2 of deficit; once the loop is
  // in its periodic regime the heat supplied per layer equals it.
  const double deficit = 1010.0 * 1928.0 * 1e-4 * 22.0;
  EXPECT_NEAR(r.layers.back().effort_j_m2, deficit, 0.05 * deficit);
  EXPECT_EQ(r.unsettled_layers, 0);
  EXPECT_LT(r.final_abs_error_k, 0.5);  // residual overshoot decays by diffusion only
}

TEST(SlsBuild, SetPointChangeIsTracked) {
  SlsBuildConfig c;
  c.layers_added = 40;
  c.laser_flux_w_m2 = 0.0;
  c.setpoint_changes = {{20, 176.0}};
  const auto r = simulate_sls_build(c);
  EXPECT_DOUBLE_EQ(r.layers[25].setpoint_c, 176.0);
  EXPECT_LT(std::abs(r.layers.back().final_error_k), 0.5);
  EXPECT_TRUE(r.layers.back().settled);
}

TEST(SlsBuild, AntiWindupLimitsOvershootAfterALongSaturation) {
  // A 30 K set-point jump with a weak heater saturates for many layers; a plain integrator
  // winds up and overshoots, both anti-windup schemes do not.
  SlsBuildConfig c;
  c.layers_added = 30;
  c.laser_flux_w_m2 = 0.0;
  c.flux_max_w_m2 = 900.0;
  c.setpoint_changes = {{1, 190.0}};
  double overshoot[3];
  int i = 0;
  for (auto aw : {amctl::control::AntiWindup::none, amctl::control::AntiWindup::back_calculation,
                  amctl::control::AntiWindup::conditional_integration}) {
    c.anti_windup = aw;
    overshoot[i++] = simulate_sls_build(c).max_overshoot_k;
  }
  EXPECT_GT(overshoot[0], 3.0 * std::max(overshoot[1], overshoot[2]) + 0.5);
}

TEST(SlsBuild, LaserDisturbanceRaisesTheBedAndSaturatesTheHeaterAtZero) {
  SlsBuildConfig c;
  c.layers_added = 20;
  const auto r = simulate_sls_build(c);
  EXPECT_GT(r.max_overshoot_k, 0.3);
  EXPECT_GT(r.saturated_fraction, 0.05);
}

TEST(SlsBuild, ExampleConfigLoadsAndRuns) {
  const auto c = load_sls_config(std::string(AMCTL_SOURCE_DIR) + "/configs/sls_pa12.toml");
  EXPECT_EQ(c.layers_added, 200);
  EXPECT_EQ(c.anti_windup, amctl::control::AntiWindup::conditional_integration);
  ASSERT_EQ(c.setpoint_changes.size(), 1u);
  auto small = c;
  small.layers_added = 5;
  const auto r = simulate_sls_build(small);
  // 14 s / 0.25 s = 56 steps per interval; the start-up interval and five additions.
  EXPECT_EQ(r.layers.size(), 6u);
  EXPECT_EQ(r.steps, 6 * 56);
  EXPECT_EQ(r.trace.size(), std::size_t(6 * 56 / 4));  // csv_every = 4
  EXPECT_EQ(r.layers.back().layer, 55);
  EXPECT_LT(std::abs(r.energy_balance_error_j_m2), 1e-3);
}

TEST(SlsBuild, BadInputNamesTheParameter) {
  auto expect_msg = [](SlsBuildConfig c, const std::string& needle) {
    try {
      c.validate();
      FAIL() << "no error for " << needle;
    } catch (const amctl::Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  SlsBuildConfig c;
  c.ti_s = 0.0;
  expect_msg(c, "ti_s");
  c = {};
  c.flux_min_w_m2 = 100;
  c.flux_max_w_m2 = 50;
  expect_msg(c, "reversed");
  c = {};
  c.layer_thickness_m = -1;
  expect_msg(c, "layer_thickness");
  c = {};
  c.dt_s = 0;
  expect_msg(c, "dt_s");
  c = {};
  c.material.specific_heat_j_kgk = 0;
  expect_msg(c, "Cp");
}

TEST(SlsBuild, ConfigErrorsCarryFileLineAndColumn) {
  const std::string path = std::string(AMCTL_BINARY_DIR) + "/bad_sls.toml";
  {
    std::ofstream f(path);
    f << "[controller]\nkp_w_m2k = 100\nkd = 3\n";
  }
  try {
    (void)load_sls_config(path);
    FAIL();
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad_sls.toml:3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("kd"), std::string::npos);
  }
}

TEST(SlsBuild, IntegerKeysRefuseFloatsInsteadOfConvertingThem) {
  // Found by fuzz_sls_config (UBSan): `cells_per_layer = 1e308` went through toml++'s
  // float-to-integer cast, undefined for a value beyond int64. An integer key now needs an
  // integer, and the error names its place.
  const std::string path = std::string(AMCTL_BINARY_DIR) + "/float_sls.toml";
  for (const char* v : {"1e308", "2.0", "99999999999"}) {
    {
      std::ofstream f(path);
      f << "[numerics]\ncells_per_layer = " << v << "\n";
    }
    try {
      (void)load_sls_config(path);
      ADD_FAILURE() << v << " was accepted";
    } catch (const amctl::Error& e) {
      EXPECT_NE(std::string(e.what()).find("float_sls.toml:2:19:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("cells_per_layer"), std::string::npos) << e.what();
    }
  }
}
