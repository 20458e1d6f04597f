// The closed-loop scenario on a reduced bed (tests/sls3d/small_scenario.toml, a few seconds):
// the schedule, the energy account, the PI law on the trace and the absorbed laser energy,
// each against a hand calculation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "amctl/sls3d/config.hpp"
#include "amctl/sls3d/scan.hpp"
#include "amctl/sls3d/studies.hpp"

namespace amctl::sls3d {
namespace {

TEST(Sls3dScenario, ReducedBedClosesItsEnergyAndFollowsThePiLaw) {
  std::string why;
  if (!engine_available(&why)) GTEST_SKIP() << why;
  const ScenarioConfig c = load_scenario_config(std::string(AMCTL_SOURCE_DIR) + "/tests/sls3d/small_scenario.toml");
  ScenarioOptions o;
  o.keep_rasters = true;
  const ScenarioResult r = run_scenario(c, o);

  ASSERT_EQ(r.snapshots.size(), 3u);
  EXPECT_NEAR(r.snapshots[0].time_s, 0.3, 1e-12);
  EXPECT_NEAR(r.snapshots[2].time_s, 0.9, 1e-12);
  EXPECT_EQ(r.steps, 9);
  ASSERT_EQ(r.layers.size(), 2u);

  // Every step's balance to 1e-6, and the whole run's account closes.
  EXPECT_LT(r.energy_balance_rel_error, 1e-6);
  const EnergyTotals& e = r.energy;
  EXPECT_LT(std::abs(e.closure_j), 1e-6 * (e.laser_j + e.top_flux_j + std::abs(e.spreading_j)));

  // Absorbed laser energy per layer: absorptivity P times the scan's duration, the scan being
  // the ring's area over the hatch at the scan speed (the chords' midpoint rule, 1 % here).
  const double area = std::numbers::pi * (c.part_outer_radius_m * c.part_outer_radius_m -
                                          c.part_inner_radius_m * c.part_inner_radius_m);
  const double per_layer = c.absorptivity * c.laser_power_w * area / c.hatch_m / c.scan_speed_m_s;
  for (const LayerRecord& l : r.layers) EXPECT_NEAR(l.laser_energy_j, per_layer, 0.02 * per_layer);
  EXPECT_NEAR(e.laser_j, 2 * per_layer, 0.02 * 2 * per_layer);

  // The PI on the trace: U_k = U_hold + kp e_k + (kp/Ti) dt sum_{j<k} e_j (no saturation here).
  const double hold = holding_flux_w_m2(c.losses, c.setpoint_c);
  const double sigma = 5.670374419e-8, tk = c.setpoint_c + 273.15, te = c.losses.radiation_env_c + 273.15;
  EXPECT_NEAR(hold, c.losses.emissivity * sigma * (std::pow(tk, 4) - std::pow(te, 4)) +
                        c.losses.convection_w_m2k * (c.setpoint_c - c.losses.gas_temp_c),
              1e-9 * hold);
  double sum = 0;
  for (const TracePoint& p : r.trace) {
    const double err = c.setpoint_c - p.measured_c;
    EXPECT_FALSE(p.saturated);
    EXPECT_NEAR(p.flux_w_m2, hold + c.kp_w_m2k * err + c.kp_w_m2k / c.ti_s * c.dt_s * sum, 1e-9 * hold) << p.t_s;
    sum += err;
  }
  // The fresh powder (150 C) is what the area mean sees first.
  EXPECT_NEAR(r.trace.front().measured_c, c.fresh_powder_temp_c, 1e-6);
  // The maps at the three instants cover the disc.
  for (const Snapshot& s : r.snapshots) EXPECT_EQ(s.map.temp_c.size(), std::size_t(c.map_pixels * c.map_pixels));
  // The snapshot at 0.4 s, the instant the second layer is spread, shows the bed before the
  // spreading (the paper's 15.1 s: the first layer sintered): the ring consolidated and hot,
  // the measured area warmer than the fresh powder that arrives at that instant.
  ASSERT_NEAR(r.layers[1].spread_s, 0.4, 1e-12);
  const Snapshot& before = r.snapshots[1];
  EXPECT_GT(before.measured_c, c.fresh_powder_temp_c + 5.0);
  float state_max = 0;
  for (float v : before.map.state) state_max = std::max(state_max, v);
  EXPECT_GT(state_max, 0.5f);
}

}  // namespace
}  // namespace amctl::sls3d
