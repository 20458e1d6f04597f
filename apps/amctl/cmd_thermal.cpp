// amctl thermal ...: SLS powder-bed transfer-function tools, margins, PDE closed loop, and the
// FDM hotend/bed loops. Each command parses its flags, calls one study of the thermal module
// (amctl/thermal/studies.hpp) and prints its result. See docs/thermal.md.
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "amctl/control/pid.hpp"
#include "amctl/core/error.hpp"
#include "amctl/thermal/checks.hpp"
#include "amctl/thermal/studies.hpp"
#include "commands.hpp"

namespace amctl::cli {

namespace {

/// The flag of a study parameter, given its Python keyword (thermal/checks.hpp).
std::string flag_name(std::string_view keyword) {
  static const std::pair<std::string_view, std::string_view> kFlags[] = {
      {"kp_w_m2k", "--kp"}, {"ti_s", "--ti"}, {"density_kg_m3", "--rho"}, {"specific_heat_j_kgk", "--cp"},
      {"conductivity_w_mk", "--k"}, {"beta_1_s", "--beta"}, {"target_c", "--target"}, {"noise_k", "--noise"}};
  for (const auto& [k, f] : kFlags) {
    if (k == keyword) return std::string(f);
  }
  std::string flag = "--" + std::string(keyword);
  for (char& c : flag) c = c == '_' ? '-' : c;
  return flag;
}

struct MarginArgs {
  thermal::MarginStudyOptions study;
  double length_mm = 0.1;
  bool json_out = false;
  std::string bode_csv;
};

void run_margins(MarginArgs a) {
  // Each flag checked under its own name, by the checks Python's amctl.sls_margins makes.
  a.study.length_m = a.length_mm * 1e-3;
  thermal::check_margin_study(a.study, flag_name);
  const thermal::MarginStudy study = thermal::run_margin_study(a.study);
  const thermal::MarginReport& r = study.report;
  if (a.json_out) {
    std::cout << thermal::to_json(study).dump(2) << "\n";
  } else {
    fmt::print("SLS powder bed, l = {:.4g} mm, a^2 = {:.5g} m^2/s, PI kp = {:.4g}, Ti = {:.4g} s\n",
               a.length_mm, study.plant.material().diffusivity_m2_s(), a.study.kp_w_m2k,
               a.study.ti_s);
    fmt::print("  ||G - G_{}||_inf       {:.6e}  (a-priori bound {:.6e}, printed eq.13 {:.6e})\n",
               r.modes, r.hinf_g_minus_gn, r.bound_tail, r.bound_printed_13);
    fmt::print("  margin on G_{}         {:.6e}  sweep | {:.6e} Hamiltonian  (paper: 3.3)\n",
               r.modes, r.margin_on_gn_sweep, r.margin_on_gn_hamiltonian);
    fmt::print("  margin on G           {:.6e}  sweep | {:.6e} Hamiltonian on G_{}+tail pole (paper: 0.78)\n",
               r.margin_on_g_sweep, r.margin_on_g_hamiltonian, r.hamiltonian_modes_for_g);
    if (r.theorem2_applicable)
      fmt::print("  Theorem 2: eps_a - delta = {:.6e} <= margin on G: {}\n", r.theorem2_lower_bound,
                 r.theorem2_holds ? "yes" : "NO");
    else
      fmt::print("  Theorem 2: not applicable, delta = {:.6e} >= eps_a = {:.6e}\n",
                 r.hinf_g_minus_gn, r.margin_on_gn_sweep);
    fmt::print("  closed loop stable: G_N {} (max Re {:.4g}), G_M {} (max Re {:.4g}); exact G: {} RHP"
               " poles by the Nyquist argument\n",
               r.stable_gn, r.max_pole_real_gn, r.stable_gm, r.max_pole_real_gm,
               r.nyquist_rhp_poles_g);
    fmt::print("  best achievable margin (Hankel, beta = {:.4g}): {:.6e}\n", r.beta,
               r.hankel_best_margin);
  }
  if (!a.bode_csv.empty()) thermal::write_bode_csv(a.bode_csv, study.plant, a.study.modes);
}

struct SlsArgs {
  std::string config;
  std::string csv;  ///< "" (default): no trace file; the run writes nothing unless asked
  bool json_out = false;
  std::optional<int> layers;
  std::string anti_windup;
};

void run_sls(const SlsArgs& a) {
  thermal::SlsRunOptions o;
  o.config_path = a.config;
  thermal::check_sls_layers(a.layers, flag_name);
  o.layers_added = a.layers.value_or(-1);
  if (!a.anti_windup.empty()) {
    o.anti_windup = control::anti_windup_from_string(a.anti_windup);
    if (!o.anti_windup)
      throw Error("--anti-windup '" + a.anti_windup +
                  "' unknown; expected none, clamp_integral, back_calculation or "
                  "conditional_integration");
  }
  o.trace = !a.csv.empty();
  const thermal::SlsRun run = thermal::run_sls_build(o);
  const thermal::SlsBuildConfig& cfg = run.config;
  const thermal::SlsBuildResult& r = run.result;
  if (!a.csv.empty()) thermal::write_sls_trace_csv(a.csv, r, {a.config});
  if (a.csv == "-") return;  // standard output holds the trace
  if (a.json_out) {
    std::cout << thermal::to_json(run).dump(2) << "\n";
    return;
  }
  fmt::print("SLS build: {} layer additions every {:g} s, l0 = {:g} mm, PI kp = {:g} W/(m^2 K), "
             "Ti = {:g} s, flux [{:g}, {:g}] W/m^2, anti-windup {}, scheme {}\n",
             cfg.layers_added, cfg.layer_time_s, cfg.layer_thickness_m * 1e3, cfg.kp_w_m2k,
             cfg.ti_s, cfg.flux_min_w_m2, cfg.flux_max_w_m2, control::to_string(cfg.anti_windup),
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
  thermal::HeaterStudyOptions study;
  std::string rule;
  std::string csv;
  bool json_out = false;
};

void run_heater(HeaterArgs a) {
  using namespace thermal;
  // Each flag checked under its own name, by the checks Python's amctl.hotend/bed make.
  thermal::check_heater_study(a.study, flag_name);
  if (!a.rule.empty()) {
    const auto rule = tuning_rule_from_string(a.rule);
    if (!rule)
      throw Error("--rule '" + a.rule +
                  "' unknown; expected classic_zn, some_overshoot or no_overshoot");
    a.study.rule = *rule;
  }
  const HeaterStudy s = run_heater_study(a.study);
  if (!a.csv.empty()) write_heater_traces_csv(a.csv, s);
  if (a.csv == "-") return;  // standard output holds the traces
  if (a.json_out) {
    std::cout << to_json(s).dump(2) << "\n";
    return;
  }
  const bool bed = a.study.bed;
  const HeaterPlantParams& pp = a.study.plant;
  const AutotuneResult& at = s.autotune;
  const IdentifyResult& id = s.identified;
  const TuningRule rule = a.study.rule;
  fmt::print("{} at {:g} C (sensor noise {:g} K)\n", bed ? "Heated bed" : "Hotend",
             s.scenario.target_c, a.study.sensor_noise_k);
  fmt::print("relay autotune (M303-like, {} cycles): Ku = {:.4g} duty/K, Tu = {:.4g} s, bias {:.3f}, d {:.3f}\n",
             at.cycles, at.ku, at.tu_s, at.bias, at.amplitude);
  fmt::print("  {} gains: kp {:.4g} /K, ki {:.4g} /(K s), kd {:.4g} s/K  (Marlin 0-255 scale: P {:.3g} I {:.3g} D {:.3g})\n",
             to_string(rule), at.gains.kp(), at.gains.ki_per_s(), at.gains.kd_s(),
             255 * at.gains.kp(), 255 * at.gains.ki_per_s(), 255 * at.gains.kd_s());
  fmt::print("identified model (M306 T-like): C {:.4g} J/K (true {:.4g}+{:.4g}), sensor {:.4g} 1/s (true {:.4g}),"
             " loss {:.4g} W/K (true {:.4g}), full fan {:.4g} W/K (true {:.4g})\n",
             id.model.block_capacity_j_k, pp.block_capacity_j_k, pp.core_capacity_j_k,
             id.model.sensor_responsiveness_1_s, 1.0 / pp.sensor_time_constant_s, id.model.loss_w_k,
             pp.loss_w_k, id.model.loss_w_k + id.model.fan_extra_loss_w_k,
             pp.loss_w_k + pp.fan_extra_loss_w_k);
  fmt::print("{:<22} {:>10} {:>11} {:>11} {:>12} {:>11} {:>9} {:>10}\n", "controller", "heatup_s",
             "overshoot_K", "fan_dev_K", "fan_recov_s", "ripple_K", "rms_K", "energy_kJ");
  for (const auto& r : s.runs)
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
      "sls-margins", "Additive-uncertainty margins of a PI on the SLS powder bed (the SLS temperature-control paper, 2018)");
  thermal::MarginStudyOptions& ms = margins->study;
  sm->add_option("--kp", ms.kp_w_m2k, "PI gain kp, W/(m^2 K)")->capture_default_str();
  sm->add_option("--ti", ms.ti_s, "PI integral time Ti, s")->capture_default_str();
  sm->add_option("--modes", ms.modes, "modal truncation order N")->capture_default_str();
  sm->add_option("--length-mm", margins->length_mm, "powder depth l, mm")->capture_default_str();
  sm->add_option("--rho", ms.material.density_kg_m3, "density, kg/m^3")->capture_default_str();
  sm->add_option("--cp", ms.material.specific_heat_j_kgk, "specific heat, J/(kg K)")
      ->capture_default_str();
  sm->add_option("--k", ms.material.conductivity_w_mk, "conductivity k0, W/(m K)")
      ->capture_default_str();
  sm->add_option("--beta", ms.beta_1_s, "stability margin beta < 0 for the Hankel bound, 1/s")
      ->capture_default_str();
  sm->add_option("--hamiltonian-modes", ms.hamiltonian_modes,
                 "modes M of the state-space model used for the second margin on G")
      ->capture_default_str();
  sm->add_option("--bode-csv", margins->bode_csv, "write Bode data of G and G_N to this CSV");
  sm->add_flag("--json", margins->json_out, "print one JSON object");
  sm->callback([margins] { run_margins(*margins); });

  auto sls = std::make_shared<SlsArgs>();
  auto* sc =
      th->add_subcommand("sls", "Closed-loop SLS powder-bed build (growing 1D heat equation)");
  sc->add_option("--config", sls->config, "TOML configuration (default: built-in PA12 values)");
  sc->add_option("--csv", sls->csv, "write the trace (time, temperatures, heat flux) to this CSV (default: none)");
  sc->add_option("--layers", sls->layers, "override the number of layer additions");
  sc->add_option("--anti-windup", sls->anti_windup,
                 "override: none | clamp_integral | back_calculation | conditional_integration");
  sc->add_flag("--json", sls->json_out, "print the summary as one JSON object");
  sc->callback([sls] { run_sls(*sls); });

  for (bool bed : {false, true}) {
    auto ha = std::make_shared<HeaterArgs>();
    ha->study = bed ? thermal::HeaterStudyOptions::bed_defaults()
                    : thermal::HeaterStudyOptions::hotend();
    auto* hc = th->add_subcommand(bed ? "bed" : "hotend",
                                  bed ? "Heated-bed loop: relay autotune (gentle rule) vs MPC"
                                      : "Hotend loop: relay autotune PID vs identified MPC");
    hc->add_option("--target", ha->study.target_c, "target temperature, C")
        ->capture_default_str();
    hc->add_option("--noise", ha->study.sensor_noise_k, "sensor noise standard deviation, K")
        ->capture_default_str();
    hc->add_option("--cycles", ha->study.cycles, "autotune cycles (M303 C)")
        ->capture_default_str();
    hc->add_option("--rule", ha->rule, "classic_zn | some_overshoot | no_overshoot");
    hc->add_option("--csv", ha->csv, "write the traces of all controllers to this CSV");
    thermal::HeaterPlantParams& plant = ha->study.plant;
    hc->add_option("--power-w", plant.heater_power_w, "plant heater power, W");
    hc->add_option("--capacity-j-k", plant.block_capacity_j_k, "plant block heat capacity, J/K");
    hc->add_option("--loss-w-k", plant.loss_w_k, "plant loss to ambient with the fan off, W/K");
    hc->add_option("--fan-loss-w-k", plant.fan_extra_loss_w_k,
                   "plant extra loss at 100 % fan, W/K");
    hc->add_option("--sensor-tau-s", plant.sensor_time_constant_s, "plant sensor time constant, s");
    hc->add_option("--sensor-delay-s", plant.sensor_delay_s,
                   "plant transport delay from the block to the reading, s");
    hc->add_option("--core-capacity-j-k", plant.core_capacity_j_k,
                   "plant heater-core heat capacity, J/K (0: no core node)");
    hc->add_option("--core-to-block-w-k", plant.core_to_block_w_k, "plant heater core to block conductance, W/K");
    hc->add_flag("--json", ha->json_out, "print one JSON object");
    hc->callback([ha] { run_heater(*ha); });
  }

  register_thermal_sls3d(th);
}

}  // namespace amctl::cli
