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
    j["theorem2_lower_bound"] = r.theorem2_lower_bound;
    j["theorem2_holds"] = r.theorem2_holds;
    j["beta"] = r.beta;
    j["hankel_best_margin"] = r.hankel_best_margin;
    j["paper_claims"] = {{"margin_on_G1", 3.3}, {"margin_on_G", 0.78}};
    j["units"] = "margins and norms in K m^2 s/W (units of G); kp W/(m^2 K); Ti s";
    std::cout << j.dump(2) << "\n";
  } else {
    fmt::print("SLS powder bed, l = {:.4g} mm, a^2 = {:.5g} m^2/s, PI kp = {:.4g}, Ti = {:.4g} s\n",
               a.length_mm, alpha2, a.kp, a.ti);
    fmt::print("  ||G - G_{}||_inf       {:.6e}  (a-priori bound {:.6e}, printed eq.13 {:.6e})\n",
               a.modes, r.hinf_g_minus_gn, r.bound_tail, r.bound_printed_13);
    fmt::print("  margin on G_{}         {:.6e}  sweep | {:.6e} Hamiltonian  (paper: 3.3)\n",
               a.modes, margin_gn, r.margin_on_gn_hamiltonian);
    fmt::print("  margin on G           {:.6e}  sweep | {:.6e} Hamiltonian on G_{}+D (paper: 0.78)\n",
               margin_g, r.margin_on_g_hamiltonian, r.hamiltonian_modes_for_g);
    fmt::print("  Theorem 2: eps_a - delta = {:.6e} <= margin on G: {}\n", r.theorem2_lower_bound,
               r.theorem2_holds ? "yes" : "NO");
    fmt::print("  closed loop stable: G_N {} (max Re {:.4g}), G_M {} (max Re {:.4g})\n",
               r.stable_gn, r.max_pole_real_gn, r.stable_gm, r.max_pole_real_gm);
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
}

}  // namespace amctl::cli
