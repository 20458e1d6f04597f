// amctl thermal sls3d: the SLS powder bed in 3D (docs/sls3d.md). The closed-loop scenario of
// a configuration file, or one of the verification cases (--case). Parses flags, calls one
// function of amctl/sls3d/studies.hpp and prints; under mpirun only rank 0 prints and writes.
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/report/sls3d_page.hpp"
#include "amctl/sls3d/studies.hpp"
#include "commands.hpp"

namespace amctl::cli {

namespace {

struct Sls3dArgs {
  std::string config;
  std::string kase = "scenario";
  bool json_out = false;
  std::string vtu_dir, report, csv;
  // Cases.
  double power_w = -1, beam_radius_mm = -1, speed_mm_s = -1;
  std::vector<std::string> probes_mm;
  int cells_per_radius = 8, steps_per_radius = 8;
  double thickness_mm = -1, flux_w_m2 = 1000, setpoint_rise_k = 10, kp = 0.3, ti_s = 0.5;
  std::vector<double> times_s;
  int cells = -1;
  double dt_s = 0;
  std::string scheme = "crank_nicolson";
  double conductivity = -1, density = -1, specific_heat = -1;
  double patch_mm = 2, hatch_mm = 0.3;
};

std::array<double, 3> parse_probe(const std::string& text) {
  std::array<double, 3> p{};
  std::stringstream ss(text);
  std::string item;
  int n = 0;
  while (std::getline(ss, item, ',')) {
    if (n >= 3) n = 4;
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(v)) n = 4;
    if (n < 3) p[n] = v * 1e-3;
    ++n;
  }
  if (n != 3) throw Error("--probe-mm: found '" + text + "', expected X,Y,Z in mm (three numbers)");
  return p;
}

sls3d::Material material(const Sls3dArgs& a, sls3d::Material m) {
  if (a.conductivity != -1) m.conductivity_w_mk = a.conductivity;
  if (a.density != -1) m.density_kg_m3 = a.density;
  if (a.specific_heat != -1) m.specific_heat_j_kgk = a.specific_heat;
  return m;
}

sls3d::Scheme scheme(const std::string& s) {
  if (s == "crank_nicolson") return sls3d::Scheme::crank_nicolson;
  if (s == "backward_euler") return sls3d::Scheme::backward_euler;
  throw Error("--scheme: found '" + s + "', expected crank_nicolson or backward_euler");
}

void need(bool given, const char* flag, const std::string& kase) {
  if (!given) throw Error(std::string(flag) + ": not given, expected it for --case " + kase);
}

void print(const Json& j, bool json_out, const std::string& text) {
  if (json_out) std::cout << j.dump(2) << "\n";
  else std::cout << text;
}

void run(const Sls3dArgs& a) {
  const bool root = sls3d::launcher_rank() == 0;
  const std::string& k = a.kase;
  if (k != "scenario" && (!a.vtu_dir.empty() || !a.report.empty() || !a.csv.empty()))
    throw Error("--case " + k + ": --vtu-dir, --report and --csv belong to the scenario, expected none of them");
  if (k != "scenario" && !a.config.empty())
    throw Error("--config: a configuration is for the scenario, expected no --case or --case scenario");
  if (k == "moving-source") {
    need(a.power_w != -1, "--power-w", k);
    need(a.beam_radius_mm != -1, "--beam-radius-mm", k);
    need(a.speed_mm_s != -1, "--speed-mm-s", k);
    sls3d::MovingSourceOptions o;
    o.power_w = a.power_w;
    o.beam_radius_m = a.beam_radius_mm * 1e-3;
    o.speed_m_s = a.speed_mm_s * 1e-3;
    o.material = material(a, o.material);
    for (const std::string& p : a.probes_mm) o.probes_m.push_back(parse_probe(p));
    o.cells_per_radius = a.cells_per_radius;
    o.steps_per_radius = a.steps_per_radius;
    const sls3d::MovingSourceResult r = sls3d::run_moving_source(o);
    if (!root) return;
    std::string text = fmt::format(
        "moving Gaussian source: P {:g} W, W {:g} mm, v {:g} mm/s, Peclet v W/(2a) = {:.3g}\n"
        "  peak rise {:.5g} K at x = {:.4g} mm (Eagar-Tsai: {:.5g} K at {:.4g} mm, {:+.2f} %)\n",
        o.power_w, a.beam_radius_mm, a.speed_mm_s, r.peclet, r.peak_rise_k, r.peak_x_m * 1e3,
        r.analytic_peak_rise_k, r.analytic_peak_x_m * 1e3, 100 * (r.peak_rise_k / r.analytic_peak_rise_k - 1));
    for (const auto& p : r.probes)
      text += fmt::format("  probe ({:g}, {:g}, {:g}) mm: {:.5g} K (Eagar-Tsai {:.5g} K)\n", p.where_m[0] * 1e3,
                          p.where_m[1] * 1e3, p.where_m[2] * 1e3, p.rise_k, p.analytic_rise_k);
    text += fmt::format("  {} steps, {} cells, {} dofs, drift over the last radius {:.1e}, {:.1f} s\n", r.steps,
                        r.cells, r.dofs, r.quasi_steady_drift, r.wall_s);
    print(sls3d::to_json(r), a.json_out, text);
  } else if (k == "slab-flux" || k == "slab-pi") {
    need(a.thickness_mm != -1, "--thickness-mm", k);
    need(!a.times_s.empty(), "--times-s", k);
    std::string text;
    Json j;
    if (k == "slab-flux") {
      sls3d::SlabFluxOptions o;
      o.thickness_m = a.thickness_mm * 1e-3;
      o.flux_w_m2 = a.flux_w_m2;
      o.times_s = a.times_s;
      o.material = material(a, o.material);
      if (a.cells != -1) o.cells = a.cells;
      o.max_dt_s = a.dt_s;
      o.scheme = scheme(a.scheme);
      const sls3d::SlabFluxResult r = sls3d::run_slab_flux(o);
      j = sls3d::to_json(r);
      text = fmt::format("slab {:g} mm under {:g} W/m^2, insulated below: top rise\n", a.thickness_mm, o.flux_w_m2);
      for (std::size_t i = 0; i < r.top_rise_k.size(); ++i)
        text += fmt::format("  t = {:g} s: {:.7g} K (series {:.7g} K)\n", o.times_s[i], r.top_rise_k[i],
                            r.series_top_rise_k[i]);
    } else {
      sls3d::SlabPiOptions o;
      o.thickness_m = a.thickness_mm * 1e-3;
      o.setpoint_rise_k = a.setpoint_rise_k;
      o.kp_w_m2k = a.kp;
      o.ti_s = a.ti_s;
      o.times_s = a.times_s;
      o.material = material(a, o.material);
      if (a.cells != -1) o.cells = a.cells;
      o.max_dt_s = a.dt_s;
      o.scheme = scheme(a.scheme);
      const sls3d::SlabPiResult r = sls3d::run_slab_pi(o);
      j = sls3d::to_json(r);
      text = fmt::format("slab {:g} mm under the PI (kp {:g}, Ti {:g} s) to a set point {:g} K up: top rise\n",
                         a.thickness_mm, o.kp_w_m2k, o.ti_s, o.setpoint_rise_k);
      for (std::size_t i = 0; i < r.top_rise_k.size(); ++i)
        text += fmt::format("  t = {:g} s: {:.7g} K, U {:.5g} W/m^2\n", o.times_s[i], r.top_rise_k[i], r.flux_w_m2[i]);
    }
    if (root) print(j, a.json_out, text);
  } else if (k == "lumping-patch") {
    sls3d::LumpingPatchOptions o;
    o.patch_m = a.patch_mm * 1e-3;
    if (a.power_w != -1) o.power_w = a.power_w;
    if (a.beam_radius_mm != -1) o.beam_radius_m = a.beam_radius_mm * 1e-3;
    if (a.speed_mm_s != -1) o.speed_m_s = a.speed_mm_s * 1e-3;
    o.hatch_m = a.hatch_mm * 1e-3;
    if (a.dt_s > 0) o.part_scale_dt_s = a.dt_s;
    if (!a.times_s.empty()) o.times_after_s = a.times_s;
    o.material = material(a, o.material);
    const sls3d::LumpingPatchResult r = sls3d::run_lumping_patch(o);
    std::string text = fmt::format("lumping on a {:g} mm patch (scan {:.3g} ms, fine peak {:.1f} C)\n", a.patch_mm,
                                   r.scan_time_s * 1e3, r.fine_peak_c);
    for (const auto& row : r.rows)
      text += fmt::format("  t = {:g} s: mean {:.3f} / {:.3f} C, max {:.3f} / {:.3f} C (fine / lumped), rms diff {:.3g} K\n",
                          row.t_s, row.fine_mean_c, row.lumped_mean_c, row.fine_max_c, row.lumped_max_c,
                          row.rms_difference_k);
    if (root) print(sls3d::to_json(r), a.json_out, text);
  } else if (k == "scenario") {
    sls3d::ScenarioConfig c;
    if (!a.config.empty()) c = sls3d::load_scenario_config(a.config);
    else c.validate();
    // The outputs are checked before the simulation, not after it (the one output writer's
    // checks: a directory, a missing directory, the configuration itself).
    if (root) {
      if (!a.csv.empty()) check_output(a.csv, OutputOptions{"--csv", {a.config}, {}});
      if (!a.report.empty()) check_output(a.report, OutputOptions{"--report", {a.config}, {}});
    }
    sls3d::ScenarioOptions o;
    o.vtu_dir = a.vtu_dir;
    o.keep_rasters = !a.report.empty();
    const sls3d::ScenarioResult r = sls3d::run_scenario(c, o);
    if (!root) return;
    if (!a.csv.empty()) sls3d::write_trace_csv(a.csv, r);
    if (!a.report.empty()) report::write_sls3d_report(r, a.report);
    std::string text = fmt::format("SLS powder bed in 3D: {} steps of {:g} s to {:g} s, {} layer(s), {} rank(s)\n",
                                   r.steps, c.dt_s, c.end_time_s, r.layers.size(), r.mesh_at_end.ranks);
    for (const auto& s : r.snapshots)
      text += fmt::format("  t = {:6.2f} s: measured {:.3f} C, surface mean {:.3f} C{}\n", s.time_s, s.measured_c,
                          s.top_mean_c, s.file.empty() ? "" : "  " + s.file);
    text += fmt::format("  U in [{:.4g}, {:.4g}] W/m^2, {} saturated steps; energy balance per step {:.1e}\n",
                        r.trace.empty() ? 0.0 : r.trace.front().flux_w_m2, r.trace.empty() ? 0.0 : r.trace.back().flux_w_m2,
                        r.saturated_steps, r.energy_balance_rel_error);
    text += fmt::format("  mesh: up to {} cells, {} dofs; {:.3f} s per step, {:.1f} s wall\n", r.max_cells, r.max_dofs,
                        r.seconds_per_step, r.wall_s);
    if (a.config.empty()) {
      text += "  configuration: the built-in values (no --config)\n";
    } else if (!c.defaulted.empty()) {
      text += fmt::format("  built-in values used for the {} keys {} leaves out: {}\n", c.defaulted.size(), a.config,
                          fmt::join(c.defaulted, ", "));
    }
    print(sls3d::to_json(r), a.json_out, text);
  } else {
    throw Error("--case: found '" + k + "', expected scenario, moving-source, slab-flux, slab-pi or lumping-patch");
  }
}

// The options of `amctl thermal sls3d` on `c`; the same in amctl and in amctl-sls3d.
std::shared_ptr<Sls3dArgs> add_options(CLI::App* c) {
  auto a = std::make_shared<Sls3dArgs>();
  c->add_option("--config", a->config, "scenario TOML (configs/sls_seed002_3d.toml; default: its built-in values)");
  c->add_option("--case", a->kase,
                "scenario | moving-source | slab-flux | slab-pi | lumping-patch")->capture_default_str();
  c->add_flag("--json", a->json_out, "print one JSON object");
  c->add_option("--vtu-dir", a->vtu_dir, "scenario: write VTU snapshots and sls3d.pvd (ParaView) into DIR");
  c->add_option("--report", a->report, "scenario: write the HTML page (maps, U(t), y(t)) to this file");
  c->add_option("--csv", a->csv, "scenario: write U and y per step to this CSV");
  c->add_option("--power-w", a->power_w, "moving-source, lumping-patch: absorbed power P, W");
  c->add_option("--beam-radius-mm", a->beam_radius_mm, "moving-source, lumping-patch: 1/e^2 radius W, mm");
  c->add_option("--speed-mm-s", a->speed_mm_s, "moving-source, lumping-patch: scan speed, mm/s");
  c->add_option("--probe-mm", a->probes_mm, "moving-source: X,Y,Z from the beam centre (X along the scan, Z depth), mm")
      ->take_all();
  c->add_option("--cells-per-radius", a->cells_per_radius, "moving-source: finest cells per beam radius")
      ->capture_default_str();
  c->add_option("--steps-per-radius", a->steps_per_radius, "moving-source: time steps per radius of travel")
      ->capture_default_str();
  c->add_option("--thickness-mm", a->thickness_mm, "slab-flux, slab-pi: slab thickness L, mm");
  c->add_option("--flux-w-m2", a->flux_w_m2, "slab-flux: flux U on the top, W/m^2")->capture_default_str();
  c->add_option("--setpoint-rise-k", a->setpoint_rise_k, "slab-pi: set point above the initial temperature, K")
      ->capture_default_str();
  c->add_option("--kp", a->kp, "slab-pi: PI gain kp, W/(m^2 K)")->capture_default_str();
  c->add_option("--ti-s", a->ti_s, "slab-pi: PI integral time Ti, s")->capture_default_str();
  c->add_option("--times-s", a->times_s, "slab-flux, slab-pi, lumping-patch: output times T1,T2,..., s")
      ->delimiter(',');
  c->add_option("--cells", a->cells, "slab-flux, slab-pi: cells across the slab");
  c->add_option("--dt-s", a->dt_s, "slab-flux, slab-pi: largest time step (0: automatic); lumping-patch: part-scale step");
  c->add_option("--scheme", a->scheme, "slab-flux, slab-pi: crank_nicolson | backward_euler")->capture_default_str();
  c->add_option("--conductivity-w-mk", a->conductivity, "cases: conductivity, W/(m K) (default: the case's material)");
  c->add_option("--density-kg-m3", a->density, "cases: density, kg/m^3");
  c->add_option("--specific-heat-j-kgk", a->specific_heat, "cases: specific heat, J/(kg K)");
  c->add_option("--patch-mm", a->patch_mm, "lumping-patch: side of the square patch, mm")->capture_default_str();
  c->add_option("--hatch-mm", a->hatch_mm, "lumping-patch: hatch spacing, mm")->capture_default_str();
  return a;
}

// The command line of this process (argv as the kernel holds it).
std::vector<std::string> own_command_line() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> args;
  std::string arg;
  while (std::getline(in, arg, '\0')) args.push_back(arg);
  return args;
}

std::string sls3d_command_path() {
  if (const char* env = std::getenv("AMCTL_SLS3D_COMMAND"); env && *env) return env;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path next = self.parent_path() / "amctl-sls3d";
    if (std::filesystem::exists(next)) return next.string();
  }
#ifdef AMCTL_SLS3D_COMMAND_PATH
  return AMCTL_SLS3D_COMMAND_PATH;
#else
  return "amctl-sls3d";
#endif
}

}  // namespace

void register_thermal_sls3d(CLI::App* thermal) {
  auto* c = thermal->add_subcommand(
      "sls3d", "The SLS powder bed in 3D (finite elements, deal.II): the PI scenario or a verification case");
  (void)add_options(c);
  // The options are checked here; the work is done by amctl-sls3d, which this process becomes:
  // the finite-element engine must not share a process with IPOPT's stub MPI functions
  // (docs/sls3d.md, "Build and loading").
  c->callback([] {
    const std::vector<std::string> args = own_command_line();
    std::size_t i = 0;
    while (i < args.size() && args[i] != "sls3d") ++i;
    const std::string path = sls3d_command_path();
    std::vector<char*> argv;
    std::string name = path;
    argv.push_back(name.data());
    std::vector<std::string> rest(args.begin() + std::min(args.size(), i + 1), args.end());
    for (std::string& s : rest) argv.push_back(s.data());
    argv.push_back(nullptr);
    std::cout.flush();
    ::execv(path.c_str(), argv.data());
    throw Error(path + ": cannot run the 3D powder-bed command (" + std::strerror(errno) +
                "), expected amctl-sls3d next to amctl");
  });
}

void register_sls3d_command(CLI::App& app) {
  auto a = add_options(&app);
  app.callback([a] {
    // Under mpirun every rank runs this; ranks other than 0 end quietly on bad input (rank 0
    // reports it).
    if (sls3d::launcher_rank() != 0) {
      try {
        run(*a);
      } catch (const Error&) {
        std::exit(2);
      }
      return;
    }
    run(*a);
  });
}

}  // namespace amctl::cli
