// amctl thermal ...: SLS powder-bed transfer-function tools, margins, PDE closed loop, and the
// FDM hotend/bed loops. See docs/thermal.md.
#include <cmath>
#include <iostream>
#include <limits>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "amctl/core/error.hpp"
#include "amctl/thermal/fdm_heater.hpp"
#include "amctl/thermal/powder_bed_sim.hpp"
#include "amctl/thermal/powder_bed_tf.hpp"
#include "amctl/thermal/robust_margin.hpp"
#include "commands.hpp"

namespace amctl::cli {

namespace {

using nlohmann::json;

json num(double v) {
  if (std::isfinite(v)) return v;
  return v > 0 ? json("inf") : json(nullptr);
}

struct MarginArgs {
  double kp = 0.3;
  double ti = 0.5;
  int modes = 1;
  double length_mm = 0.1;
  double rho = 1010.0, cp = 1928.0, k = 0.28;
  double beta = -0.01;
  int ham_modes = 60;
  bool json_out = false;
  std::string bode_csv;
};

void run_margins(const MarginArgs& a) {
  thermal::PowderMaterial mat{a.rho, a.cp, a.k};
  mat.validate();
  require_positive("--length-mm (powder depth l)", a.length_mm);
  const thermal::PowderBedTf g(mat, a.length_mm * 1e-3);
  const thermal::PiController pi{a.kp, a.ti};
  pi.validate();
  if (a.modes < 1)
    throw Error("--modes (N) must be >= 1, got " + std::to_string(a.modes));
  if (a.ham_modes < 1)
    throw Error("--hamiltonian-modes must be >= 1, got " + std::to_string(a.ham_modes));
  const auto r = thermal::compute_margins(g, pi, a.modes, a.beta, a.ham_modes);
  const double alpha2 = mat.diffusivity_m2_s();
  const double margin_gn = r.margin_on_gn_sweep, margin_g = r.margin_on_g_sweep;
  if (a.json_out) {
    json j;
    j["length_m"] = r.length_m;
    j["modes"] = r.modes;
    j["kp"] = a.kp;
    j["ti_s"] = a.ti;
    j["diffusivity_m2_s"] = alpha2;
    j["integrator_residue"] = g.residue(0);
    j["first_modal_pole_rad_s"] = g.pole(1);
    json poles = json::array(), zeros = json::array();
    for (int k = 0; k <= std::max(3, a.modes); ++k) poles.push_back(g.pole(k));
    for (int k = 0; k <= std::max(2, a.modes - 1); ++k) zeros.push_back(g.zero(k));
    j["poles_rad_s"] = poles;
    j["zeros_rad_s"] = zeros;
    j["modal_residues"] = {g.residue(0), g.residue(1)};
    j["high_frequency_ceiling_1_over_kp"] = 1.0 / a.kp;
    j["margin_on_GN"] = num(margin_gn);
    j["margin_on_G"] = num(margin_g);
    j["margin_on_GN_hamiltonian"] = num(r.margin_on_gn_hamiltonian);
    j["margin_on_G_hamiltonian"] = num(r.margin_on_g_hamiltonian);
    j["hamiltonian_modes_for_G"] = r.hamiltonian_modes_for_g;
    j["peak_omega_GN_rad_s"] = num(r.peak_omega_gn);
    j["peak_omega_G_rad_s"] = num(r.peak_omega_g);
    j["hinf_G_minus_GN"] = r.hinf_g_minus_gn;
    j["hinf_G_minus_GN_omega_rad_s"] = r.hinf_g_minus_gn_omega;
    j["bound_G_minus_GN"] = r.bound_tail;
    j["bound_printed_eq13"] = r.bound_printed_13;
    j["closed_loop_stable_GN"] = r.stable_gn;
    j["closed_loop_stable_G"] = r.stable_gm;
    j["closed_loop_max_pole_real_GN"] = r.max_pole_real_gn;
    j["closed_loop_max_pole_real_G"] = r.max_pole_real_gm;
    j["closed_loop_rhp_poles_G_nyquist"] = r.nyquist_rhp_poles_g;
    j["theorem2_lower_bound"] = r.theorem2_lower_bound;
    j["theorem2_applicable"] = r.theorem2_applicable;
    j["theorem2_holds"] = r.theorem2_holds;
    j["beta"] = r.beta;
    j["hankel_best_margin"] = r.hankel_best_margin;
    j["paper_claims"] = {{"margin_on_G1", 3.3}, {"margin_on_G", 0.78}};
    j["units"] = "margins and norms in K m^2/W (units of G); residues K m^2/(W s); kp W/(m^2 K); Ti s";
    std::cout << j.dump(2) << "\n";
  } else {
    fmt::print("SLS powder bed, l = {:.4g} mm, a^2 = {:.5g} m^2/s, PI kp = {:.4g}, Ti = {:.4g} s\n",
               a.length_mm, alpha2, a.kp, a.ti);
    fmt::print("  ||G - G_{}||_inf       {:.6e}  (a-priori bound {:.6e}, printed eq.13 {:.6e})\n",
               a.modes, r.hinf_g_minus_gn, r.bound_tail, r.bound_printed_13);
    fmt::print("  margin on G_{}         {:.6e}  sweep | {:.6e} Hamiltonian  (paper: 3.3)\n",
               a.modes, margin_gn, r.margin_on_gn_hamiltonian);
    fmt::print("  margin on G           {:.6e}  sweep | {:.6e} Hamiltonian on G_{}+tail pole (paper: 0.78)\n",
               margin_g, r.margin_on_g_hamiltonian, r.hamiltonian_modes_for_g);
    if (r.theorem2_applicable)
      fmt::print("  Theorem 2: eps_a - delta = {:.6e} <= margin on G: {}\n", r.theorem2_lower_bound,
                 r.theorem2_holds ? "yes" : "NO");
    else
      fmt::print("  Theorem 2: not applicable, delta = {:.6e} >= eps_a = {:.6e}\n",
                 r.hinf_g_minus_gn, margin_gn);
    fmt::print("  closed loop stable: G_N {} (max Re {:.4g}), G_M {} (max Re {:.4g}); exact G: {} RHP"
               " poles by the Nyquist argument\n",
               r.stable_gn, r.max_pole_real_gn, r.stable_gm, r.max_pole_real_gm,
               r.nyquist_rhp_poles_g);
    fmt::print("  best achievable margin (Hankel, beta = {:.4g}): {:.6e}\n", r.beta,
               r.hankel_best_margin);
  }
  if (!a.bode_csv.empty()) {
    const auto be = g.bode(1e-4, 1e6, 401, -1);
    const auto bn = g.bode(1e-4, 1e6, 401, a.modes);
    std::FILE* f = std::fopen(a.bode_csv.c_str(), "w");
    if (!f) throw Error("--bode-csv: cannot open '" + a.bode_csv + "' for writing");
    std::fprintf(f, "omega_rad_s,mag_G_db,phase_G_deg,mag_GN_db,phase_GN_deg\n");
    for (std::size_t i = 0; i < be.size(); ++i)
      std::fprintf(f, "%.9g,%.9g,%.9g,%.9g,%.9g\n", be[i].omega_rad_s, be[i].magnitude_db,
                   be[i].phase_deg, bn[i].magnitude_db, bn[i].phase_deg);
    std::fclose(f);
  }
}

struct SlsArgs {
  std::string config;
  std::string csv = "sls_trace.csv";
  bool json_out = false;
  int layers = -1;
  std::string anti_windup;
};

void run_sls(const SlsArgs& a) {
  thermal::SlsBuildConfig cfg;
  if (!a.config.empty()) cfg = thermal::load_sls_config(a.config);
  if (a.layers >= 0) cfg.layers_added = a.layers;
  if (!a.anti_windup.empty()) {
    if (a.anti_windup == "none") cfg.anti_windup = thermal::AntiWindup::none;
    else if (a.anti_windup == "back_calculation") cfg.anti_windup = thermal::AntiWindup::back_calculation;
    else if (a.anti_windup == "conditional_integration")
      cfg.anti_windup = thermal::AntiWindup::conditional_integration;
    else
      throw Error("--anti-windup '" + a.anti_windup +
                  "' unknown; expected none, back_calculation or conditional_integration");
  }
  if (a.csv.empty()) cfg.csv_every = 0;
  const auto r = thermal::simulate_sls_build(cfg);
  if (!a.csv.empty()) {
    std::FILE* f = std::fopen(a.csv.c_str(), "w");
    if (!f) throw Error("--csv: cannot open '" + a.csv + "' for writing");
    std::fprintf(f, "t_s,layers,depth_m,y_c,setpoint_c,flux_w_m2,disturbance_w_m2,integral_w_m2\n");
    for (const auto& p : r.trace)
      std::fprintf(f, "%.6f,%d,%.9g,%.6f,%.6f,%.6f,%.6f,%.6f\n", p.t_s, p.layers, p.depth_m, p.y_c,
                   p.setpoint_c, p.flux_w_m2, p.disturbance_w_m2, p.integral_w_m2);
    std::fclose(f);
  }
  if (a.json_out) {
    json j;
    j["layers_added"] = cfg.layers_added;
    j["steps"] = r.steps;
    j["final_nodes"] = r.final_nodes;
    j["anti_windup"] = thermal::to_string(cfg.anti_windup);
    j["scheme"] = thermal::to_string(cfg.scheme);
    j["max_overshoot_k"] = r.max_overshoot_k;
    j["max_dip_k"] = r.max_dip_k;
    j["mean_settling_time_s"] = r.mean_settling_time_s;
    j["max_settling_time_s"] = r.max_settling_time_s;
    j["unsettled_layers"] = r.unsettled_layers;
    j["final_abs_error_k"] = r.final_abs_error_k;
    j["mean_abs_final_error_k"] = r.mean_abs_final_error_k;
    j["total_effort_j_m2"] = r.total_effort_j_m2;
    j["rms_flux_w_m2"] = r.rms_flux_w_m2;
    j["saturated_fraction"] = r.saturated_fraction;
    j["energy_balance_error_j_m2"] = r.energy_balance_error_j_m2;
    std::cout << j.dump(2) << "\n";
    return;
  }
  fmt::print("SLS build: {} layer additions every {:g} s, l0 = {:g} mm, PI kp = {:g} W/(m^2 K), "
             "Ti = {:g} s, flux [{:g}, {:g}] W/m^2, anti-windup {}, scheme {}\n",
             cfg.layers_added, cfg.layer_time_s, cfg.layer_thickness_m * 1e3, cfg.kp_w_m2k,
             cfg.ti_s, cfg.flux_min_w_m2, cfg.flux_max_w_m2, thermal::to_string(cfg.anti_windup),
             thermal::to_string(cfg.scheme));
  fmt::print("{:>6} {:>9} {:>8} {:>10} {:>10} {:>9} {:>11} {:>8}\n", "layers", "setpoint",
             "dip_K", "overshoot", "settle_s", "final_K", "effort_J/m2", "sat_%");
  const auto& L = r.layers;
  for (std::size_t i = 0; i < L.size(); ++i) {
    if (L.size() > 12 && i >= 5 && i + 5 < L.size()) {
      if (i == 5) fmt::print("{:>6}\n", "...");
      continue;
    }
    const auto& s = L[i];
    fmt::print("{:>6} {:>9.2f} {:>8.3f} {:>10.3f} {:>10.2f}{} {:>9.4f} {:>11.1f} {:>8.1f}\n",
               s.layer, s.setpoint_c, s.dip_k, s.overshoot_k, s.settling_time_s,
               s.settled ? ' ' : '*', s.final_error_k, s.effort_j_m2, 100 * s.saturated_fraction);
  }
  fmt::print("summary: max dip {:.3f} K, max overshoot {:.3f} K, settling mean {:.2f} s max {:.2f} s"
             " ({} layers unsettled), final |e| {:.2e} K (mean over layers {:.2e} K),\n"
             "         effort {:.4g} J/m^2, rms flux {:.4g} W/m^2, saturated {:.1f} %, "
             "energy balance error {:.2e} J/m^2, {} steps, {} nodes\n",
             r.max_dip_k, r.max_overshoot_k, r.mean_settling_time_s, r.max_settling_time_s,
             r.unsettled_layers, r.final_abs_error_k, r.mean_abs_final_error_k,
             r.total_effort_j_m2, r.rms_flux_w_m2, 100 * r.saturated_fraction,
             r.energy_balance_error_j_m2, r.steps, r.final_nodes);
  if (!a.csv.empty()) fmt::print("trace written to {}\n", a.csv);
}

struct HeaterArgs {
  bool bed = false;
  double power_w = -1, capacity_j_k = -1, loss_w_k = -1, fan_loss_w_k = -1, sensor_tau_s = -1;
  double target = -1.0;
  double noise = 0.0;
  int cycles = 5;
  std::string rule;
  std::string csv;
  bool json_out = false;
};

void run_heater(const HeaterArgs& a) {
  using namespace thermal;
  HeaterPlantParams pp = a.bed ? HeaterPlantParams::bed() : HeaterPlantParams::hotend();
  if (a.power_w != -1) pp.heater_power_w = a.power_w;
  if (a.capacity_j_k != -1) pp.block_capacity_j_k = a.capacity_j_k;
  if (a.loss_w_k != -1) pp.loss_w_k = a.loss_w_k;
  if (a.fan_loss_w_k != -1) pp.fan_extra_loss_w_k = a.fan_loss_w_k;
  if (a.sensor_tau_s != -1) pp.sensor_time_constant_s = a.sensor_tau_s;
  pp.validate();
  HeaterPlantParams noisy = pp;
  require_non_negative("--noise", a.noise);
  noisy.sensor_noise_k = a.noise;
  HeaterScenario sc;
  sc.target_c = a.target > 0 ? a.target : (a.bed ? 60.0 : 210.0);
  if (!(sc.target_c > pp.ambient_c + 20.0))
    throw Error("--target must be at least 20 K above ambient (" + std::to_string(pp.ambient_c) + " C)");
  if (a.bed) {
    sc.duration_s = 1500.0;
    sc.fan_on_at_s = 900.0;
    sc.flow_start_s = 1200.0;
    sc.flow_end_s = 1500.0;
    sc.flow_high_mm3_s = 0.0;
    sc.flow_low_mm3_s = 0.0;
  }
  if (a.cycles < 3) throw Error("--cycles must be >= 3, got " + std::to_string(a.cycles));
  auto parse_rule = [](const std::string& r) {
    if (r == "classic_zn") return TuningRule::classic_zn;
    if (r == "some_overshoot") return TuningRule::some_overshoot;
    if (r == "no_overshoot") return TuningRule::no_overshoot;
    throw Error("--rule '" + r + "' unknown; expected classic_zn, some_overshoot or no_overshoot");
  };
  const TuningRule default_rule = a.bed ? TuningRule::no_overshoot : TuningRule::classic_zn;
  const TuningRule rule = a.rule.empty() ? default_rule : parse_rule(a.rule);

  AutotuneOptions ao;
  ao.target_c = sc.target_c;
  ao.cycles = a.cycles;
  ao.rule = rule;
  if (a.bed) ao.timeout_s = 7200.0;
  const AutotuneResult at = relay_autotune(HeaterPlant(noisy), ao);
  if (!at.ok) throw Error("relay autotune failed: " + at.message);
  const PidGains classic = tuning_rule(TuningRule::classic_zn, at.ku, at.tu_s);

  IdentifyOptions io;
  io.ambient_c = pp.ambient_c;
  io.target_c = a.bed ? 100.0 : 200.0;
  io.filament_j_mm3k = pp.filament_j_mm3k;
  if (a.bed) {
    io.sample_distance_s = 5.0;
    io.settle_s = 600.0;
    io.measure_s = 300.0;
  }
  const IdentifyResult id = identify_mpc_model(HeaterPlant(noisy), io);

  std::vector<HeaterRunStats> runs;
  {
    PidController pid(at.gains, PidOptions{});
    runs.push_back(run_heater_scenario(noisy, sc,
        [&](double t, double y, double, double, double dt) { return pid.update(t, y, dt); },
        std::string("PID ") + to_string(rule)));
  }
  if (rule != TuningRule::classic_zn) {
    PidController pid(classic, PidOptions{});
    runs.push_back(run_heater_scenario(noisy, sc,
        [&](double t, double y, double, double, double dt) { return pid.update(t, y, dt); },
        "PID classic_zn"));
  }
  {
    MpcController mpc(id.model, MpcOptions{}, pp.ambient_c);
    runs.push_back(run_heater_scenario(noisy, sc,
        [&](double t, double y, double f, double q, double dt) { return mpc.update(t, y, f, q, dt); },
        "MPC identified"));
  }
  if (!a.csv.empty()) {
    std::FILE* f = std::fopen(a.csv.c_str(), "w");
    if (!f) throw Error("--csv: cannot open '" + a.csv + "' for writing");
    std::fprintf(f, "t_s");
    for (const auto& r : runs) std::fprintf(f, ",%s_c,%s_duty", r.controller.c_str(), r.controller.c_str());
    std::fprintf(f, "\n");
    for (std::size_t i = 0; i < runs[0].t_s.size(); ++i) {
      std::fprintf(f, "%.2f", runs[0].t_s[i]);
      for (const auto& r : runs) std::fprintf(f, ",%.4f,%.4f", r.measured_c[i], r.duty[i]);
      std::fprintf(f, "\n");
    }
    std::fclose(f);
  }
  if (a.json_out) {
    json j;
    j["heater"] = a.bed ? "bed" : "hotend";
    j["target_c"] = sc.target_c;
    j["autotune"] = {{"ku_per_k", at.ku}, {"tu_s", at.tu_s}, {"bias", at.bias}, {"amplitude", at.amplitude},
                     {"rule", to_string(rule)}, {"kp", at.gains.kp}, {"ki", at.gains.ki}, {"kd", at.gains.kd},
                     {"marlin_kp", 255 * at.gains.kp}, {"marlin_ki", 255 * at.gains.ki}, {"marlin_kd", 255 * at.gains.kd},
                     {"duration_s", at.duration_s}};
    j["identified"] = {{"block_capacity_j_k", id.model.block_capacity_j_k},
                       {"sensor_responsiveness_1_s", id.model.sensor_responsiveness_1_s},
                       {"loss_w_k", id.model.loss_w_k}, {"loss_full_fan_w_k", id.model.loss_w_k + id.model.fan_extra_loss_w_k},
                       {"asymptote_c", id.asymptotic_temp_c}, {"loss_from_curve_w_k", id.loss_from_curve_w_k}};
    j["true_plant"] = {{"block_capacity_j_k", pp.block_capacity_j_k + pp.core_capacity_j_k},
                       {"sensor_responsiveness_1_s", 1.0 / pp.sensor_time_constant_s},
                       {"loss_w_k", pp.loss_w_k}, {"loss_full_fan_w_k", pp.loss_w_k + pp.fan_extra_loss_w_k}};
    json rs = json::array();
    for (const auto& r : runs)
      rs.push_back({{"controller", r.controller}, {"heat_up_time_s", num(r.heat_up_time_s)},
                    {"overshoot_k", r.overshoot_k}, {"fan_max_dev_k", r.fan_max_dev_k},
                    {"fan_recovery_s", r.fan_recovery_s}, {"flow_ripple_k", r.flow_ripple_k},
                    {"flow_rms_k", r.flow_rms_k}, {"energy_j", r.energy_j}});
    j["runs"] = rs;
    std::cout << j.dump(2) << "\n";
    return;
  }
  fmt::print("{} at {:g} C (sensor noise {:g} K)\n", a.bed ? "Heated bed" : "Hotend", sc.target_c, a.noise);
  fmt::print("relay autotune (M303-like, {} cycles): Ku = {:.4g} duty/K, Tu = {:.4g} s, bias {:.3f}, d {:.3f}\n",
             at.cycles, at.ku, at.tu_s, at.bias, at.amplitude);
  fmt::print("  {} gains: kp {:.4g} /K, ki {:.4g} /(K s), kd {:.4g} s/K  (Marlin 0-255 scale: P {:.3g} I {:.3g} D {:.3g})\n",
             to_string(rule), at.gains.kp, at.gains.ki, at.gains.kd, 255 * at.gains.kp,
             255 * at.gains.ki, 255 * at.gains.kd);
  fmt::print("identified model (M306 T-like): C {:.4g} J/K (true {:.4g}+{:.4g}), sensor {:.4g} 1/s (true {:.4g}),"
             " loss {:.4g} W/K (true {:.4g}), full fan {:.4g} W/K (true {:.4g})\n",
             id.model.block_capacity_j_k, pp.block_capacity_j_k, pp.core_capacity_j_k,
             id.model.sensor_responsiveness_1_s, 1.0 / pp.sensor_time_constant_s, id.model.loss_w_k,
             pp.loss_w_k, id.model.loss_w_k + id.model.fan_extra_loss_w_k,
             pp.loss_w_k + pp.fan_extra_loss_w_k);
  fmt::print("{:<22} {:>10} {:>11} {:>11} {:>12} {:>11} {:>9} {:>10}\n", "controller", "heatup_s",
             "overshoot_K", "fan_dev_K", "fan_recov_s", "ripple_K", "rms_K", "energy_kJ");
  for (const auto& r : runs)
    fmt::print("{:<22} {:>10.1f} {:>11.3f} {:>11.3f} {:>12.1f} {:>11.3f} {:>9.3f} {:>10.2f}\n",
               r.controller, r.heat_up_time_s, r.overshoot_k, r.fan_max_dev_k, r.fan_recovery_s,
               r.flow_ripple_k, r.flow_rms_k, r.energy_j / 1000.0);
}

}  // namespace

void register_thermal(CLI::App& app) {
  auto* th = app.add_subcommand("thermal", "SLS powder-bed and FDM hotend/bed temperature control");
  th->require_subcommand(1);

  auto margins = std::make_shared<MarginArgs>();
  auto* sm = th->add_subcommand(
      "sls-margins", "Additive-uncertainty margins of a PI on the SLS powder bed (seed 002)");
  sm->add_option("--kp", margins->kp, "PI gain kp, W/(m^2 K)")->capture_default_str();
  sm->add_option("--ti", margins->ti, "PI integral time Ti, s")->capture_default_str();
  sm->add_option("--modes", margins->modes, "modal truncation order N")->capture_default_str();
  sm->add_option("--length-mm", margins->length_mm, "powder depth l, mm")->capture_default_str();
  sm->add_option("--rho", margins->rho, "density, kg/m^3")->capture_default_str();
  sm->add_option("--cp", margins->cp, "specific heat, J/(kg K)")->capture_default_str();
  sm->add_option("--k", margins->k, "conductivity k0, W/(m K)")->capture_default_str();
  sm->add_option("--beta", margins->beta, "stability margin beta < 0 for the Hankel bound, 1/s")
      ->capture_default_str();
  sm->add_option("--hamiltonian-modes", margins->ham_modes,
                 "modes M of the state-space model used for the second margin on G")
      ->capture_default_str();
  sm->add_option("--bode-csv", margins->bode_csv, "write Bode data of G and G_N to this CSV");
  sm->add_flag("--json", margins->json_out, "print one JSON object");
  sm->callback([margins] { run_margins(*margins); });

  auto sls = std::make_shared<SlsArgs>();
  auto* sc = th->add_subcommand("sls", "Closed-loop SLS powder-bed build (growing 1D heat equation)");
  sc->add_option("--config", sls->config, "TOML configuration (default: built-in PA12 values)");
  sc->add_option("--csv", sls->csv, "trace CSV path ('' for none)")->capture_default_str();
  sc->add_option("--layers", sls->layers, "override the number of layer additions");
  sc->add_option("--anti-windup", sls->anti_windup,
                 "override: none | back_calculation | conditional_integration");
  sc->add_flag("--json", sls->json_out, "print the summary as one JSON object");
  sc->callback([sls] { run_sls(*sls); });

  for (bool bed : {false, true}) {
    auto ha = std::make_shared<HeaterArgs>();
    ha->bed = bed;
    auto* hc = th->add_subcommand(bed ? "bed" : "hotend",
                                  bed ? "Heated-bed loop: relay autotune (gentle rule) vs MPC"
                                      : "Hotend loop: relay autotune PID vs identified MPC");
    hc->add_option("--target", ha->target, "target temperature, C (default 210 hotend, 60 bed)");
    hc->add_option("--noise", ha->noise, "sensor noise standard deviation, K")->capture_default_str();
    hc->add_option("--cycles", ha->cycles, "autotune cycles (M303 C)")->capture_default_str();
    hc->add_option("--rule", ha->rule, "classic_zn | some_overshoot | no_overshoot");
    hc->add_option("--csv", ha->csv, "write the traces of all controllers to this CSV");
    hc->add_option("--power-w", ha->power_w, "plant heater power, W");
    hc->add_option("--capacity-j-k", ha->capacity_j_k, "plant block heat capacity, J/K");
    hc->add_option("--loss-w-k", ha->loss_w_k, "plant loss to ambient with the fan off, W/K");
    hc->add_option("--fan-loss-w-k", ha->fan_loss_w_k, "plant extra loss at 100 % fan, W/K");
    hc->add_option("--sensor-tau-s", ha->sensor_tau_s, "plant sensor time constant, s");
    hc->add_flag("--json", ha->json_out, "print one JSON object");
    hc->callback([ha] { run_heater(*ha); });
  }
}

}  // namespace amctl::cli
