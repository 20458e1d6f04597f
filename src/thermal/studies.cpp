#include "amctl/thermal/studies.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"

#include <fmt/format.h>

namespace amctl::thermal {

namespace {

// A CSV written through amctl::OutputFile (whole or not at all; every write checked).
class OutFile {
 public:
  OutFile(const std::string& path, const char* flag, std::vector<std::string> inputs = {})
      : out_(path, OutputOptions{flag, std::move(inputs), {}}) {}
  template <class... A>
  void print(fmt::format_string<A...> f, A&&... a) {
    buf_.clear();
    fmt::format_to(std::back_inserter(buf_), f, std::forward<A>(a)...);
    out_.write(std::string_view(buf_.data(), buf_.size()));
  }
  void commit() { out_.commit(); }

 private:
  OutputFile out_;
  fmt::memory_buffer buf_;
};

}  // namespace

// ------------------------------------------------------------------------- SLS PI margins

MarginStudy run_margin_study(const MarginStudyOptions& o) {
  o.material.validate();
  require_positive("length_m (powder depth l)", o.length_m);
  // The PI messages name kp and Ti (require_realisable_pi) before the gains are built.
  require_positive("kp (PI proportional gain, W/(m^2 K))", o.kp_w_m2k);
  if (!std::isfinite(o.ti_s) || o.ti_s <= 0.0)
    throw Error("Ti (PI integral time) must be finite and > 0 s for a realisable PI, got " +
                std::to_string(o.ti_s));
  if (o.modes < 1) throw Error("modes (N) must be >= 1, got " + std::to_string(o.modes));
  if (o.hamiltonian_modes < 1)
    throw Error("hamiltonian_modes must be >= 1, got " + std::to_string(o.hamiltonian_modes));
  const PowderBedTf g(o.material, o.length_m);
  const auto pi = control::PidGains::standard(o.kp_w_m2k, o.ti_s);
  return MarginStudy{o, g, compute_margins(g, pi, o.modes, o.beta_1_s, o.hamiltonian_modes)};
}

Json to_json(const MarginStudy& s) {
  const MarginReport& r = s.report;
  const PowderBedTf& g = s.plant;
  Json j;
  j["length_m"] = json_number(r.length_m);
  j["modes"] = r.modes;
  j["kp"] = json_number(s.options.kp_w_m2k);
  j["ti_s"] = json_number(s.options.ti_s);
  j["diffusivity_m2_s"] = json_number(g.material().diffusivity_m2_s());
  j["integrator_residue"] = json_number(g.residue(0));
  j["first_modal_pole_rad_s"] = json_number(g.pole(1));
  Json poles = Json::array(), zeros = Json::array();
  for (int k = 0; k <= std::max(3, r.modes); ++k) poles.push_back(json_number(g.pole(k)));
  for (int k = 0; k <= std::max(2, r.modes - 1); ++k) zeros.push_back(json_number(g.zero(k)));
  j["poles_rad_s"] = poles;
  j["zeros_rad_s"] = zeros;
  j["modal_residues"] = {json_number(g.residue(0)), json_number(g.residue(1))};
  j["high_frequency_ceiling_1_over_kp"] = json_number(1.0 / s.options.kp_w_m2k);
  j["margin_on_GN"] = json_number(r.margin_on_gn_sweep);
  j["margin_on_G"] = json_number(r.margin_on_g_sweep);
  j["margin_on_GN_hamiltonian"] = json_number(r.margin_on_gn_hamiltonian);
  j["margin_on_G_hamiltonian"] = json_number(r.margin_on_g_hamiltonian);
  j["hamiltonian_modes_for_G"] = r.hamiltonian_modes_for_g;
  j["peak_omega_GN_rad_s"] = json_number(r.peak_omega_gn);  // null: the sup is at w -> inf
  j["peak_omega_G_rad_s"] = json_number(r.peak_omega_g);
  j["hinf_G_minus_GN"] = json_number(r.hinf_g_minus_gn);
  j["hinf_G_minus_GN_omega_rad_s"] = json_number(r.hinf_g_minus_gn_omega);
  j["bound_G_minus_GN"] = json_number(r.bound_tail);
  j["bound_printed_eq13"] = json_number(r.bound_printed_13);
  j["closed_loop_stable_GN"] = r.stable_gn;
  j["closed_loop_stable_G"] = r.stable_gm;
  j["closed_loop_max_pole_real_GN"] = json_number(r.max_pole_real_gn);
  j["closed_loop_max_pole_real_G"] = json_number(r.max_pole_real_gm);
  j["closed_loop_rhp_poles_G_nyquist"] = r.nyquist_rhp_poles_g;
  j["theorem2_lower_bound"] = json_number(r.theorem2_lower_bound);
  j["theorem2_applicable"] = r.theorem2_applicable;
  j["theorem2_holds"] = r.theorem2_holds;
  j["beta"] = json_number(r.beta);
  j["hankel_best_margin"] = json_number(r.hankel_best_margin);
  j["paper_claims"] = {{"margin_on_G1", 3.3}, {"margin_on_G", 0.78}};
  j["units"] =
      "margins and norms in K m^2/W (units of G); residues K m^2/(W s); kp W/(m^2 K); Ti s";
  return j;
}

void write_bode_csv(const std::string& path, const PowderBedTf& g, int modes) {
  const auto be = g.bode(1e-4, 1e6, 401, -1);
  const auto bn = g.bode(1e-4, 1e6, 401, modes);
  OutFile out(path, "--bode-csv");
  out.print("omega_rad_s,mag_G_db,phase_G_deg,mag_GN_db,phase_GN_deg\n");
  for (std::size_t i = 0; i < be.size(); ++i)
    out.print("{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", be[i].omega_rad_s, be[i].magnitude_db,
                 be[i].phase_deg, bn[i].magnitude_db, bn[i].phase_deg);
  out.commit();
}

// ------------------------------------------------------------------------------ SLS build

SlsRun run_sls_build(const SlsRunOptions& o) {
  SlsRun run;
  if (!o.config_path.empty()) run.config = load_sls_config(o.config_path);
  if (o.layers_added >= 0) run.config.layers_added = o.layers_added;
  if (o.anti_windup) run.config.anti_windup = *o.anti_windup;
  if (!o.trace) run.config.csv_every = 0;
  run.result = simulate_sls_build(run.config);
  return run;
}

Json to_json(const SlsRun& run) {
  const SlsBuildResult& r = run.result;
  Json j;
  j["layers_added"] = run.config.layers_added;
  j["steps"] = r.steps;
  j["final_nodes"] = r.final_nodes;
  j["anti_windup"] = control::to_string(run.config.anti_windup);
  j["scheme"] = to_string(run.config.scheme);
  j["max_overshoot_k"] = json_number(r.max_overshoot_k);
  j["max_dip_k"] = json_number(r.max_dip_k);
  j["mean_settling_time_s"] = json_number(r.mean_settling_time_s);
  j["max_settling_time_s"] = json_number(r.max_settling_time_s);
  j["unsettled_layers"] = r.unsettled_layers;
  j["final_abs_error_k"] = json_number(r.final_abs_error_k);
  j["mean_abs_final_error_k"] = json_number(r.mean_abs_final_error_k);
  j["total_effort_j_m2"] = json_number(r.total_effort_j_m2);
  j["rms_flux_w_m2"] = json_number(r.rms_flux_w_m2);
  j["saturated_fraction"] = json_number(r.saturated_fraction);
  j["energy_balance_error_j_m2"] = json_number(r.energy_balance_error_j_m2);
  return j;
}

void write_sls_trace_csv(const std::string& path, const SlsBuildResult& r,
                         const std::vector<std::string>& inputs) {
  OutFile out(path, "--csv", inputs);
  out.print("t_s,layers,depth_m,y_c,setpoint_c,flux_w_m2,disturbance_w_m2,integral_w_m2\n");
  for (const auto& p : r.trace)
    out.print("{:.6f},{},{:.9g},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n", p.t_s, p.layers, p.depth_m, p.y_c,
                 p.setpoint_c, p.flux_w_m2, p.disturbance_w_m2, p.integral_w_m2);
  out.commit();
}

// ------------------------------------------------------------------------ FDM heater loops

std::optional<TuningRule> tuning_rule_from_string(std::string_view name) {
  for (TuningRule r :
       {TuningRule::classic_zn, TuningRule::some_overshoot, TuningRule::no_overshoot})
    if (name == to_string(r)) return r;
  return std::nullopt;
}

HeaterStudyOptions HeaterStudyOptions::hotend() { return HeaterStudyOptions{}; }

HeaterStudyOptions HeaterStudyOptions::bed_defaults() {
  HeaterStudyOptions o;
  o.bed = true;
  o.plant = HeaterPlantParams::bed();
  o.target_c = 60.0;
  o.rule = TuningRule::no_overshoot;
  return o;
}

HeaterStudy run_heater_study(const HeaterStudyOptions& o) {
  HeaterStudy s;
  s.options = o;
  const HeaterPlantParams& pp = o.plant;
  pp.validate();
  HeaterPlantParams noisy = pp;
  require_non_negative("sensor_noise_k", o.sensor_noise_k);
  noisy.sensor_noise_k = o.sensor_noise_k;
  HeaterScenario& sc = s.scenario;
  sc.target_c = o.target_c;
  if (!(sc.target_c > pp.ambient_c + 20.0))
    throw Error("target_c must be at least 20 K above ambient (" + std::to_string(pp.ambient_c) +
                " C), got " + std::to_string(o.target_c));
  if (o.bed) {
    sc.duration_s = 1500.0;
    sc.fan_on_at_s = 900.0;
    sc.flow_start_s = 1200.0;
    sc.flow_end_s = 1500.0;
    sc.flow_high_mm3_s = 0.0;
    sc.flow_low_mm3_s = 0.0;
  }
  if (o.cycles < 3) throw Error("cycles must be >= 3, got " + std::to_string(o.cycles));

  AutotuneOptions ao;
  ao.target_c = sc.target_c;
  ao.cycles = o.cycles;
  ao.rule = o.rule;
  if (o.bed) ao.timeout_s = 7200.0;
  s.autotune = relay_autotune(HeaterPlant(noisy), ao);
  if (!s.autotune.ok) throw Error("relay autotune failed: " + s.autotune.message);
  const control::PidGains classic = tuning_rule(TuningRule::classic_zn, s.autotune.ku,
                                                s.autotune.tu_s);

  IdentifyOptions io;
  io.ambient_c = pp.ambient_c;
  io.target_c = o.bed ? 100.0 : 200.0;
  io.filament_j_mm3k = pp.filament_j_mm3k;
  if (o.bed) {
    io.sample_distance_s = 5.0;
    io.settle_s = 600.0;
    io.measure_s = 300.0;
  }
  s.identified = identify_mpc_model(HeaterPlant(noisy), io);

  auto run_pid = [&](const control::PidGains& gains, const std::string& name) {
    control::PidController pid(gains, heater_pid_options());
    s.runs.push_back(run_heater_scenario(
        noisy, sc,
        [&](double t, double y, double, double, double dt) { return pid.update(t, y, dt); },
        name));
  };
  run_pid(s.autotune.gains, std::string("PID ") + to_string(o.rule));
  if (o.rule != TuningRule::classic_zn) run_pid(classic, "PID classic_zn");
  MpcController mpc(s.identified.model, MpcOptions{}, pp.ambient_c);
  s.runs.push_back(run_heater_scenario(
      noisy, sc,
      [&](double t, double y, double f, double q, double dt) { return mpc.update(t, y, f, q, dt); },
      "MPC identified"));
  return s;
}

Json to_json(const HeaterStudy& s) {
  const AutotuneResult& at = s.autotune;
  const MpcModel& m = s.identified.model;
  const HeaterPlantParams& pp = s.options.plant;
  const control::PidGains& g = at.gains;
  Json j;
  j["heater"] = s.options.bed ? "bed" : "hotend";
  j["target_c"] = json_number(s.scenario.target_c);
  j["autotune"] = {{"ku_per_k", json_number(at.ku)},
                   {"tu_s", json_number(at.tu_s)},
                   {"bias", json_number(at.bias)},
                   {"amplitude", json_number(at.amplitude)},
                   {"rule", to_string(s.options.rule)},
                   {"kp", json_number(g.kp())},
                   {"ki", json_number(g.ki_per_s())},
                   {"kd", json_number(g.kd_s())},
                   {"marlin_kp", json_number(255 * g.kp())},
                   {"marlin_ki", json_number(255 * g.ki_per_s())},
                   {"marlin_kd", json_number(255 * g.kd_s())},
                   {"duration_s", json_number(at.duration_s)}};
  j["identified"] = {{"block_capacity_j_k", json_number(m.block_capacity_j_k)},
                     {"sensor_responsiveness_1_s", json_number(m.sensor_responsiveness_1_s)},
                     {"loss_w_k", json_number(m.loss_w_k)},
                     {"loss_full_fan_w_k", json_number(m.loss_w_k + m.fan_extra_loss_w_k)},
                     {"asymptote_c", json_number(s.identified.asymptotic_temp_c)},
                     {"loss_from_curve_w_k", json_number(s.identified.loss_from_curve_w_k)}};
  j["true_plant"] = {
      {"block_capacity_j_k", json_number(pp.block_capacity_j_k + pp.core_capacity_j_k)},
      {"sensor_responsiveness_1_s", json_number(1.0 / pp.sensor_time_constant_s)},
      {"loss_w_k", json_number(pp.loss_w_k)},
      {"loss_full_fan_w_k", json_number(pp.loss_w_k + pp.fan_extra_loss_w_k)},
      {"heater_power_w", json_number(pp.heater_power_w)},
      {"sensor_delay_s", json_number(pp.sensor_delay_s)}};
  Json rs = Json::array();
  for (const auto& r : s.runs)
    rs.push_back({{"controller", r.controller},
                  {"heat_up_time_s", json_number(r.heat_up_time_s)},  // null: never reached
                  {"overshoot_k", json_number(r.overshoot_k)},
                  {"fan_max_dev_k", json_number(r.fan_max_dev_k)},
                  {"fan_recovery_s", json_number(r.fan_recovery_s)},
                  {"flow_ripple_k", json_number(r.flow_ripple_k)},
                  {"flow_rms_k", json_number(r.flow_rms_k)},
                  {"energy_j", json_number(r.energy_j)}});
  j["runs"] = rs;
  return j;
}

void write_heater_traces_csv(const std::string& path, const HeaterStudy& s) {
  OutFile out(path, "--csv");
  out.print("t_s");
  for (const auto& r : s.runs)
    out.print(",{}_c,{}_duty", r.controller, r.controller);
  out.print("\n");
  for (std::size_t i = 0; i < s.runs.front().t_s.size(); ++i) {
    out.print("{:.2f}", s.runs.front().t_s[i]);
    for (const auto& r : s.runs) out.print(",{:.4f},{:.4f}", r.measured_c[i], r.duty[i]);
    out.print("\n");
  }
  out.commit();
}

}  // namespace amctl::thermal
