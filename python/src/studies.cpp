// Thermal and process studies: each binding calls the one library function the matching
// command calls (apps/amctl/cmd_thermal.cpp, cmd_process.cpp) with the GIL released and
// returns its JSON form as a dict; traces come as numpy arrays (moved, not copied).
#include <optional>

#include <fmt/format.h>
#include <pybind11/stl.h>

#include "amctl/control/pid.hpp"
#include "amctl/core/error.hpp"
#include "amctl/process/shrink_model.hpp"
#include "amctl/process/time_study.hpp"
#include "amctl/thermal/checks.hpp"
#include "amctl/thermal/studies.hpp"
#include "common.hpp"

namespace amctl::py_bind {
namespace {

namespace th = amctl::thermal;
namespace pr = amctl::process;

/// Errors name a parameter by its keyword, as the user passed it.
std::string keyword(std::string_view k) { return std::string(k); }

py::object sls_margins(double kp_w_m2k, double ti_s, int modes, double length_mm, double density_kg_m3,
                       double specific_heat_j_kgk, double conductivity_w_mk, double beta_1_s,
                       int hamiltonian_modes) {
  th::MarginStudyOptions o;
  o.kp_w_m2k = kp_w_m2k;
  o.ti_s = ti_s;
  o.modes = modes;
  o.length_m = length_mm * 1e-3;
  o.material = th::PowderMaterial{density_kg_m3, specific_heat_j_kgk, conductivity_w_mk};
  o.beta_1_s = beta_1_s;
  o.hamiltonian_modes = hamiltonian_modes;
  th::check_margin_study(o, keyword);  // the checks of `amctl thermal sls-margins`
  Json j;
  {
    py::gil_scoped_release nogil;
    j = th::to_json(th::run_margin_study(o));
  }
  return to_python(j);
}

py::object sls_build(const std::string& config, std::optional<int> layers, const std::string& anti_windup,
                     bool trace) {
  th::SlsRunOptions o;
  o.config_path = config;
  th::check_sls_layers(layers, keyword);  // the checks of `amctl thermal sls`
  o.layers_added = layers.value_or(-1);
  if (!anti_windup.empty()) {
    o.anti_windup = control::anti_windup_from_string(anti_windup);
    if (!o.anti_windup) {
      throw Error("anti_windup '" + anti_windup +
                  "' unknown; expected none, clamp_integral, back_calculation or conditional_integration");
    }
  }
  o.trace = trace;
  std::optional<th::SlsRun> run;
  {
    py::gil_scoped_release nogil;
    run = th::run_sls_build(o);
  }
  py::dict out(to_python(th::to_json(*run)));
  py::list per_layer;
  for (const auto& s : run->result.layers) {
    py::dict d;
    d["layers"] = s.layer;
    d["setpoint_c"] = s.setpoint_c;
    d["dip_k"] = s.dip_k;
    d["overshoot_k"] = s.overshoot_k;
    d["settling_time_s"] = s.settling_time_s;
    d["settled"] = s.settled;
    d["final_error_k"] = s.final_error_k;
    d["effort_j_m2"] = s.effort_j_m2;
    d["saturated_fraction"] = s.saturated_fraction;
    per_layer.append(d);
  }
  out["per_layer"] = per_layer;
  if (trace) {
    const auto& tr = run->result.trace;
    std::vector<double> t, depth, y, r, flux, dist, integ;
    std::vector<std::int32_t> layers_col;
    for (const auto& p : tr) {
      t.push_back(p.t_s);
      layers_col.push_back(p.layers);
      depth.push_back(p.depth_m);
      y.push_back(p.y_c);
      r.push_back(p.setpoint_c);
      flux.push_back(p.flux_w_m2);
      dist.push_back(p.disturbance_w_m2);
      integ.push_back(p.integral_w_m2);
    }
    py::dict d;
    d["t_s"] = adopt(std::move(t));
    d["layers"] = adopt(std::move(layers_col));
    d["depth_m"] = adopt(std::move(depth));
    d["y_c"] = adopt(std::move(y));
    d["setpoint_c"] = adopt(std::move(r));
    d["flux_w_m2"] = adopt(std::move(flux));
    d["disturbance_w_m2"] = adopt(std::move(dist));
    d["integral_w_m2"] = adopt(std::move(integ));
    out["trace"] = d;
  }
  return out;
}

py::object heater(bool bed, std::optional<double> target_c, std::optional<double> noise_k,
                  std::optional<int> cycles, const std::string& rule, std::optional<double> power_w,
                  std::optional<double> capacity_j_k, std::optional<double> loss_w_k,
                  std::optional<double> fan_loss_w_k, std::optional<double> sensor_tau_s,
                  std::optional<double> sensor_delay_s, std::optional<double> core_capacity_j_k,
                  std::optional<double> core_to_block_w_k) {
  th::HeaterStudyOptions o = bed ? th::HeaterStudyOptions::bed_defaults() : th::HeaterStudyOptions::hotend();
  if (target_c) o.target_c = *target_c;
  if (noise_k) o.sensor_noise_k = *noise_k;
  if (cycles) o.cycles = *cycles;
  if (!rule.empty()) {
    const auto r = th::tuning_rule_from_string(rule);
    if (!r) throw Error("rule '" + rule + "' unknown; expected classic_zn, some_overshoot or no_overshoot");
    o.rule = *r;
  }
  if (power_w) o.plant.heater_power_w = *power_w;
  if (capacity_j_k) o.plant.block_capacity_j_k = *capacity_j_k;
  if (loss_w_k) o.plant.loss_w_k = *loss_w_k;
  if (fan_loss_w_k) o.plant.fan_extra_loss_w_k = *fan_loss_w_k;
  if (sensor_tau_s) o.plant.sensor_time_constant_s = *sensor_tau_s;
  if (sensor_delay_s) o.plant.sensor_delay_s = *sensor_delay_s;
  if (core_capacity_j_k) o.plant.core_capacity_j_k = *core_capacity_j_k;
  if (core_to_block_w_k) o.plant.core_to_block_w_k = *core_to_block_w_k;
  th::check_heater_study(o, keyword);  // the checks of `amctl thermal hotend|bed`
  std::optional<th::HeaterStudy> s;
  {
    py::gil_scoped_release nogil;
    s = th::run_heater_study(o);
  }
  py::dict out(to_python(th::to_json(*s)));
  py::dict traces;
  for (auto& r : s->runs) {
    py::dict d;
    d["t_s"] = adopt(std::move(r.t_s));
    d["measured_c"] = adopt(std::move(r.measured_c));
    d["duty"] = adopt(std::move(r.duty));
    traces[py::str(r.controller)] = d;
  }
  out["traces"] = traces;
  return out;
}

py::object shrink_fit(const std::string& csv_path, std::optional<char> axis, bool average, int ranges,
                      const std::vector<double>& breaks_mm, int min_points, double confidence) {
  pr::ShrinkFitOptions opt;
  opt.average_repeats = average;
  opt.ranges = ranges;
  opt.breaks_mm = breaks_mm;
  opt.min_points_per_range = min_points;
  opt.confidence = confidence;
  Json j;
  {
    py::gil_scoped_release nogil;
    j = pr::shrink_model_json(pr::fit_shrinkage_file(csv_path, axis, opt), csv_path, average);
  }
  return to_python(j);
}

py::object estimate_empirical(const std::string& path, const std::string& params) {
  Json j;
  {
    py::gil_scoped_release nogil;
    j = pr::empirical_estimate_json(pr::estimate_empirical(path, params));
  }
  return to_python(j);
}

}  // namespace

void register_studies(py::module_& m) {
  m.def("_sls_margins", &sls_margins, py::arg("kp_w_m2k"), py::arg("ti_s"), py::arg("modes"),
        py::arg("length_mm"), py::arg("density_kg_m3"), py::arg("specific_heat_j_kgk"),
        py::arg("conductivity_w_mk"), py::arg("beta_1_s"), py::arg("hamiltonian_modes"),
        "thermal::run_margin_study + to_json (`amctl thermal sls-margins --json`).");
  m.def("_sls_build", &sls_build, py::arg("config"), py::arg("layers"), py::arg("anti_windup"), py::arg("trace"),
        "thermal::run_sls_build + to_json (`amctl thermal sls --json`), per-layer table and trace.");
  m.def("_heater", &heater, py::arg("bed"), py::arg("target_c"), py::arg("noise_k"), py::arg("cycles"),
        py::arg("rule"), py::arg("power_w"), py::arg("capacity_j_k"), py::arg("loss_w_k"),
        py::arg("fan_loss_w_k"), py::arg("sensor_tau_s"), py::arg("sensor_delay_s") = py::none(),
        py::arg("core_capacity_j_k") = py::none(), py::arg("core_to_block_w_k") = py::none(),
        "thermal::run_heater_study + to_json (`amctl thermal hotend|bed --json`) with the traces.");
  m.def("_shrink_fit", &shrink_fit, py::arg("csv_path"), py::arg("axis"), py::arg("average"), py::arg("ranges"),
        py::arg("breaks_mm"), py::arg("min_points"), py::arg("confidence"),
        "process::fit_shrinkage_file + shrink_model_json (`amctl shrink fit --json`).");
  m.def("_estimate_empirical", &estimate_empirical, py::arg("path"), py::arg("params"),
        "process::estimate_empirical + empirical_estimate_json (`amctl estimate --mode empirical --json`).");
}

}  // namespace amctl::py_bind
