// The finite-element plant against independent computations: the slab series (Carslaw &
// Jaeger), a method-of-lines slab under the continuous PI (tests/reference/sls3d/slab_pi.py)
// and the Eagar-Tsai integral evaluated by scipy (tests/reference/sls3d/eagar_tsai.py).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "amctl/core/json.hpp"
#include "amctl/sls3d/studies.hpp"

namespace amctl::sls3d {
namespace {

#define SKIP_WITHOUT_ENGINE()                                              \
  do {                                                                     \
    std::string why;                                                       \
    if (!engine_available(&why)) GTEST_SKIP() << why;                      \
  } while (0)

Json reference(const std::string& name) {
  std::ifstream in(std::string(AMCTL_SOURCE_DIR) + "/tests/reference/sls3d/" + name);
  EXPECT_TRUE(in.good()) << name;
  return Json::parse(in);
}

TEST(Sls3dPlant, SlabFluxMatchesTheSeries) {
  SKIP_WITHOUT_ENGINE();
  SlabFluxOptions o;
  o.thickness_m = 1e-3;
  o.flux_w_m2 = 1000;
  o.times_s = {0.5, 2.0, 10.0};
  const SlabFluxResult r = run_slab_flux(o);
  for (std::size_t i = 0; i < o.times_s.size(); ++i)
    EXPECT_NEAR(r.top_rise_k[i], r.series_top_rise_k[i], 1e-3 * r.series_top_rise_k[i]);
  // The series itself, at one point by hand: t >> L^2/a, T = U t/(rho c L) + U L/k (1/3 - 1/(2 pi^2)...)
  // -> its long-time limit U t/(rho c L) + U L/(3 k).
  const Material m;
  const double t = 200.0, u = 1000.0, l = 1e-3;
  EXPECT_NEAR(slab_flux_top_rise(m, l, u, t), u * t / (m.density_kg_m3 * m.specific_heat_j_kgk * l) + u * l / (3 * m.conductivity_w_mk),
              1e-9);
  EXPECT_LT(r.energy_balance_rel_error, 1e-6);
}

// Observed order in space on the slab (Crank-Nicolson at a step small enough that the time
// error is 1e-3 of the spatial one): Q1 elements with lumped mass converge at order 2.
TEST(Sls3dPlant, SlabFluxConvergesAtOrderTwoInSpace) {
  SKIP_WITHOUT_ENGINE();
  double err[2];
  for (int i = 0; i < 2; ++i) {
    SlabFluxOptions o;
    o.thickness_m = 1e-3;
    o.flux_w_m2 = 1000;
    o.times_s = {2.0};
    o.cells = 8 << i;
    o.max_dt_s = 0.002;
    const SlabFluxResult r = run_slab_flux(o);
    err[i] = std::abs(r.top_rise_k[0] - r.series_top_rise_k[0]);
  }
  EXPECT_NEAR(std::log2(err[0] / err[1]), 2.0, 0.05);
}

// Observed order in time (backward Euler, the scenario's scheme) on the slab, from three step
// sizes halving: the differences between successive levels shrink by 2 (self-convergence, so
// the spatial error of the 64 cells, the same at every step size, drops out).
TEST(Sls3dPlant, SlabFluxConvergesAtOrderOneInTimeWithBackwardEuler) {
  SKIP_WITHOUT_ENGINE();
  double rise[3];
  for (int i = 0; i < 3; ++i) {
    SlabFluxOptions o;
    o.thickness_m = 1e-3;
    o.flux_w_m2 = 1000;
    o.times_s = {2.0};
    o.cells = 64;
    o.max_dt_s = 0.04 / (1 << i);
    o.scheme = Scheme::backward_euler;
    rise[i] = run_slab_flux(o).top_rise_k[0];
  }
  EXPECT_NEAR(std::log2((rise[0] - rise[1]) / (rise[1] - rise[2])), 1.0, 0.05);
  // Backward Euler lags: below the series.
  EXPECT_LT(rise[2], slab_flux_top_rise(Material{}, 1e-3, 1000.0, 2.0));
}

// The PI of the 1D design closing the loop on the slab's top: the element model samples y
// each step and holds U (its error is first order in the step), the reference is the
// continuous loop.
TEST(Sls3dPlant, SlabPiMatchesTheMethodOfLinesLoop) {
  SKIP_WITHOUT_ENGINE();
  const Json ref = reference("slab_pi.json");
  for (const Json& c : ref.at("cases")) {
    SlabPiOptions o;
    o.thickness_m = c.at("thickness_mm").get<double>() * 1e-3;
    if (o.thickness_m > 5e-4 && c.at("kp_w_m2k").get<double>() < 1) continue;  // the slow case: docs only
    o.setpoint_rise_k = c.at("setpoint_rise_k").get<double>();
    o.kp_w_m2k = c.at("kp_w_m2k").get<double>();
    o.ti_s = c.at("ti_s").get<double>();
    o.times_s = c.at("times_s").get<std::vector<double>>();
    if (o.thickness_m > 5e-4) {
      o.cells = 64;
      o.max_dt_s = 0.0025;
    }
    const SlabPiResult r = run_slab_pi(o);
    const auto y = c.at("top_rise_k").get<std::vector<double>>();
    const auto u = c.at("flux_w_m2").get<std::vector<double>>();
    for (std::size_t i = 0; i < y.size(); ++i) {
      EXPECT_NEAR(r.top_rise_k[i], y[i], 1e-3 * std::abs(y[i])) << "L " << o.thickness_m << " t " << o.times_s[i];
      EXPECT_NEAR(r.flux_w_m2[i], u[i], 2e-3 * std::abs(u[i])) << "L " << o.thickness_m << " t " << o.times_s[i];
    }
    EXPECT_LT(r.energy_balance_rel_error, 1e-6);
  }
}

// Quasi-steady field of a moving Gaussian source at Peclet 5 (coarse: 4 cells per radius),
// peak within 2 % of Eagar-Tsai and behind the beam centre.
TEST(Sls3dPlant, MovingSourcePeakMatchesEagarTsai) {
  SKIP_WITHOUT_ENGINE();
  const Json ref = reference("eagar_tsai.json");
  for (const Json& c : ref.at("cases")) {
    if (c.at("peclet").get<double>() != 5) continue;
    MovingSourceOptions o;
    o.power_w = ref.at("power_w").get<double>();
    o.beam_radius_m = ref.at("beam_radius_m").get<double>();
    o.speed_m_s = c.at("speed_m_s").get<double>();
    o.cells_per_radius = 4;
    o.steps_per_radius = 4;
    const Json& p = c.at("probes").at(0);  // one radius behind, on the surface
    o.probes_m.push_back({p.at("xi_w").get<double>() * o.beam_radius_m, 0, 0});
    const MovingSourceResult r = run_moving_source(o);
    const double peak = c.at("peak_rise_k").get<double>();
    EXPECT_NEAR(r.peak_rise_k, peak, 0.02 * peak);
    EXPECT_LT(r.peak_x_m, 0.0);
    EXPECT_NEAR(r.peak_x_m, c.at("peak_xi_m").get<double>(), 0.25 * o.beam_radius_m);
    EXPECT_NEAR(r.probes.at(0).rise_k, p.at("rise_k").get<double>(), 0.03 * p.at("rise_k").get<double>());
    EXPECT_LT(r.energy_balance_rel_error, 1e-6);
  }
}

}  // namespace
}  // namespace amctl::sls3d
