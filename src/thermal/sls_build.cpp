#include <algorithm>
#include <cmath>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/thermal/powder_bed_sim.hpp"

namespace amctl::thermal {

void SlsBuildConfig::validate() const {
  material.validate();
  require_positive("layer_thickness_m (l0)", layer_thickness_m);
  if (initial_layers < 1)
    throw Error("initial_layers must be >= 1, got " + std::to_string(initial_layers));
  if (layers_added < 0)
    throw Error("layers_added must be >= 0, got " + std::to_string(layers_added));
  // Sizes checked before anything is allocated: a column of 2e9 layers, or a trace of 1e12
  // rows, is no build a machine makes (a 1 m tall part is 10 000 layers of 0.1 mm).
  if (layers_added > kMaxSlsLayers || initial_layers > kMaxSlsLayers)
    throw Error("layers_added and initial_layers must be at most " + std::to_string(kMaxSlsLayers) + ", got " +
                std::to_string(std::max(layers_added, initial_layers)));
  if (cells_per_layer > 1000)
    throw Error("cells_per_layer must be at most 1000, got " + std::to_string(cells_per_layer));
  require_positive("layer_time_s", layer_time_s);
  require_finite("initial_temp_c", initial_temp_c);
  require_finite("fresh_powder_temp_c", fresh_powder_temp_c);
  require_finite("setpoint_c", setpoint_c);
  require_positive("kp_w_m2k (PI gain)", kp_w_m2k);
  if (!std::isfinite(ti_s) || ti_s <= 0.0)
    throw Error("ti_s (PI integral time) must be finite and > 0 for a realisable PI, got " +
                std::to_string(ti_s));
  require_finite("flux_min_w_m2", flux_min_w_m2);
  require_finite("flux_max_w_m2", flux_max_w_m2);
  if (!(flux_max_w_m2 > flux_min_w_m2))
    throw Error("saturation limits reversed: flux_max_w_m2 (" + std::to_string(flux_max_w_m2) +
                ") must exceed flux_min_w_m2 (" + std::to_string(flux_min_w_m2) + ")");
  if (anti_windup == control::AntiWindup::back_calculation)
    require_positive("tracking_time_s", tracking_time_s);
  require_finite("laser_flux_w_m2", laser_flux_w_m2);
  require_non_negative("laser_start_s", laser_start_s);
  require_non_negative("laser_duration_s", laser_duration_s);
  if (cells_per_layer < 1)
    throw Error("cells_per_layer must be >= 1, got " + std::to_string(cells_per_layer));
  require_positive("dt_s (time step)", dt_s);
  {
    const double steps = (static_cast<double>(layers_added) + 1.0) * std::ceil(layer_time_s / dt_s);
    if (steps > kMaxSlsSteps) {
      throw Error("the build would take " + std::to_string(steps) + " time steps ((layers_added + 1) * "
                  "layer_time_s / dt_s), more than " + std::to_string(kMaxSlsSteps) +
                  "; expected fewer layers or a longer dt_s");
    }
  }
  if (dt_s > layer_time_s)
    throw Error("dt_s (" + std::to_string(dt_s) + ") must not exceed layer_time_s (" +
                std::to_string(layer_time_s) + ")");
  require_positive("settle_band_k", settle_band_k);
  if (coarsening.enabled) {
    require_positive("coarsen_below_mm (coarsening min depth)", coarsening.min_depth_m);
    require_positive("coarsen_grading", coarsening.grading);
  }
  if (csv_every < 0) throw Error("csv_every must be >= 0, got " + std::to_string(csv_every));
  for (const auto& c : setpoint_changes) {
    if (c.from_layer < 0) throw Error("setpoint change from_layer must be >= 0");
    require_finite("setpoint change setpoint_c", c.setpoint_c);
  }
}

SlsBuildResult simulate_sls_build(const SlsBuildConfig& cfg) {
  cfg.validate();
  const double h = cfg.layer_thickness_m / cfg.cells_per_layer;
  HeatColumn col(cfg.material, h, cfg.initial_layers * cfg.cells_per_layer, cfg.initial_temp_c,
                 cfg.scheme, 2, cfg.coarsening);
  // An integer number of steps per layer; dt is shortened to fit.
  const int steps_per_layer = std::max(1, int(std::ceil(cfg.layer_time_s / cfg.dt_s - 1e-9)));
  const double dt = cfg.layer_time_s / steps_per_layer;
  const double rho_cp_l0 = cfg.material.volumetric_heat_j_m3k() * cfg.layer_thickness_m;

  SlsBuildResult res;
  const double heat0 = col.heat_j_m2();
  double heat_in = 0.0;  // flux integral plus fresh powder heat
  // PI with saturation and anti-windup; the sample and hold period is dt.
  control::PidOptions pi_options;
  pi_options.output_min = cfg.flux_min_w_m2;
  pi_options.output_max = cfg.flux_max_w_m2;
  pi_options.anti_windup = cfg.anti_windup;
  pi_options.tracking_time_s = cfg.tracking_time_s;
  control::PidController pi(control::PidGains::standard(cfg.kp_w_m2k, cfg.ti_s), pi_options);
  double sum_u2 = 0.0;
  std::int64_t sat_steps = 0;
  double t = 0.0;
  const int intervals = cfg.layers_added + 1;
  res.layers.reserve(std::size_t(intervals));
  if (cfg.csv_every > 0)
    res.trace.reserve(std::size_t(intervals) * std::size_t(steps_per_layer / cfg.csv_every + 1));

  for (int iv = 0; iv < intervals; ++iv) {
    if (iv > 0) {
      heat_in += rho_cp_l0 * cfg.fresh_powder_temp_c;
      col.add_layer(cfg.cells_per_layer, cfg.fresh_powder_temp_c);
    }
    const int layers_now = cfg.initial_layers + iv;
    double sp = cfg.setpoint_c;
    for (const auto& c : cfg.setpoint_changes)
      if (iv >= c.from_layer) sp = c.setpoint_c;
    LayerStats st;
    st.layer = layers_now;
    st.setpoint_c = sp;
    double last_outside = 0.0;  // time (from the addition) of the last sample outside the band
    bool ever_outside = false;
    int sat_here = 0;
    for (int k = 0; k < steps_per_layer; ++k) {
      const double tau = k * dt;  // time since the addition
      const double y = col.top_temp_c();
      const double e = sp - y;
      st.dip_k = std::max(st.dip_k, e);
      st.overshoot_k = std::max(st.overshoot_k, -e);
      if (std::abs(e) > cfg.settle_band_k) {
        last_outside = tau + dt;
        ever_outside = true;
      }
      const control::PidStep pi_step = pi.step(sp, y, dt);
      const double u = pi_step.output;
      const bool saturated = pi_step.saturated;
      const bool laser_on = tau >= cfg.laser_start_s && tau < cfg.laser_start_s + cfg.laser_duration_s;
      const double dist = laser_on ? cfg.laser_flux_w_m2 : 0.0;
      if (cfg.csv_every > 0 && (res.steps % cfg.csv_every) == 0)
        res.trace.push_back({t, col.length_m(), y, sp, u, dist, pi.integral(), layers_now});
      col.step(dt, u + dist);
      heat_in += (u + dist) * dt;
      st.effort_j_m2 += std::abs(u) * dt;
      sum_u2 += u * u * dt;
      if (saturated) { ++sat_here; ++sat_steps; }
      t += dt;
      ++res.steps;
    }
    const double e_end = sp - col.top_temp_c();
    if (std::abs(e_end) > cfg.settle_band_k) {
      st.settled = false;
      st.settling_time_s = cfg.layer_time_s;
    } else {
      st.settled = true;
      st.settling_time_s = ever_outside ? last_outside : 0.0;
    }
    st.final_error_k = e_end;
    st.saturated_fraction = double(sat_here) / steps_per_layer;
    res.layers.push_back(st);
  }

  // Aggregates (the first interval is the start-up from the initial state; report all).
  double sum_settle = 0.0, sum_abs_final = 0.0;
  for (const auto& st : res.layers) {
    res.max_overshoot_k = std::max(res.max_overshoot_k, st.overshoot_k);
    res.max_dip_k = std::max(res.max_dip_k, st.dip_k);
    res.max_settling_time_s = std::max(res.max_settling_time_s, st.settling_time_s);
    sum_settle += st.settling_time_s;
    sum_abs_final += std::abs(st.final_error_k);
    res.total_effort_j_m2 += st.effort_j_m2;
    if (!st.settled) ++res.unsettled_layers;
  }
  const double n = double(res.layers.size());
  res.mean_settling_time_s = sum_settle / n;
  res.mean_abs_final_error_k = sum_abs_final / n;
  res.final_abs_error_k = std::abs(res.layers.back().final_error_k);
  res.rms_flux_w_m2 = std::sqrt(sum_u2 / t);
  res.saturated_fraction = double(sat_steps) / double(res.steps);
  res.energy_balance_error_j_m2 = col.heat_j_m2() - (heat0 + heat_in);
  res.final_nodes = col.cells() + 1;
  return res;
}

}  // namespace amctl::thermal
