// JSON forms, the trace CSV and the one writer of the 3D model's files (amctl/sls3d/studies.hpp).
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/sls3d/studies.hpp"

namespace amctl::sls3d {

namespace {

Json numbers(const std::vector<double>& v, double scale = 1.0) {
  Json a = Json::array();
  for (double x : v) a.push_back(json_number(x * scale));
  return a;
}

Json material_json(const Material& m) {
  return Json{{"conductivity_w_mk", json_number(m.conductivity_w_mk)},
              {"density_kg_m3", json_number(m.density_kg_m3)},
              {"specific_heat_j_kgk", json_number(m.specific_heat_j_kgk)}};
}

Json mesh_json(std::uint64_t cells, std::uint64_t dofs) {
  return Json{{"cells", cells}, {"dofs", dofs}};
}

}  // namespace

void write_file_atomically(const std::string& path, const std::string& text) {
  // The one output writer: a regular file appears whole or not at all, every write checked.
  OutputFile out(path);
  out.write(text);
  out.commit();
}

Json to_json(const SlabFluxResult& r) {
  const SlabFluxOptions& o = r.options;
  return Json{{"case", "slab-flux"},
              {"thickness_mm", json_number(o.thickness_m * 1e3)},
              {"flux_w_m2", json_number(o.flux_w_m2)},
              {"times_s", numbers(o.times_s)},
              {"top_rise_k", numbers(r.top_rise_k)},
              {"series_top_rise_k", numbers(r.series_top_rise_k)},
              {"material", material_json(o.material)},
              {"scheme", to_string(o.scheme)},
              {"cells_across", o.cells},
              {"steps", r.steps},
              {"mesh", mesh_json(r.cells, r.dofs)},
              {"energy_balance_rel_error", json_number(r.energy_balance_rel_error)},
              {"wall_s", json_number(r.wall_s)}};
}

Json to_json(const SlabPiResult& r) {
  const SlabPiOptions& o = r.options;
  return Json{{"case", "slab-pi"},
              {"thickness_mm", json_number(o.thickness_m * 1e3)},
              {"setpoint_rise_k", json_number(o.setpoint_rise_k)},
              {"kp_w_m2k", json_number(o.kp_w_m2k)},
              {"ti_s", json_number(o.ti_s)},
              {"times_s", numbers(o.times_s)},
              {"top_rise_k", numbers(r.top_rise_k)},
              {"flux_w_m2", numbers(r.flux_w_m2)},
              {"material", material_json(o.material)},
              {"scheme", to_string(o.scheme)},
              {"cells_across", o.cells},
              {"steps", r.steps},
              {"mesh", mesh_json(r.cells, r.dofs)},
              {"energy_balance_rel_error", json_number(r.energy_balance_rel_error)},
              {"wall_s", json_number(r.wall_s)}};
}

Json to_json(const MovingSourceResult& r) {
  const MovingSourceOptions& o = r.options;
  Json probes = Json::array();
  for (const ProbeValue& p : r.probes)
    probes.push_back(Json{{"x_mm", json_number(p.where_m[0] * 1e3)},
                          {"y_mm", json_number(p.where_m[1] * 1e3)},
                          {"z_mm", json_number(p.where_m[2] * 1e3)},
                          {"rise_k", json_number(p.rise_k)},
                          {"analytic_rise_k", json_number(p.analytic_rise_k)}});
  return Json{{"case", "moving-source"},
              {"power_w", json_number(o.power_w)},
              {"beam_radius_mm", json_number(o.beam_radius_m * 1e3)},
              {"speed_mm_s", json_number(o.speed_m_s * 1e3)},
              {"peclet", json_number(r.peclet)},
              {"material", material_json(o.material)},
              {"peak_rise_k", json_number(r.peak_rise_k)},
              {"peak_x_mm", json_number(r.peak_x_m * 1e3)},
              {"analytic_peak_rise_k", json_number(r.analytic_peak_rise_k)},
              {"analytic_peak_x_mm", json_number(r.analytic_peak_x_m * 1e3)},
              {"probes", probes},
              {"travel_mm", json_number(r.travel_m * 1e3)},
              {"quasi_steady_drift", json_number(r.quasi_steady_drift)},
              {"cells_per_radius", o.cells_per_radius},
              {"steps_per_radius", o.steps_per_radius},
              {"steps", r.steps},
              {"mesh", mesh_json(r.cells, r.dofs)},
              {"energy_balance_rel_error", json_number(r.energy_balance_rel_error)},
              {"wall_s", json_number(r.wall_s)}};
}

Json to_json(const LumpingPatchResult& r) {
  const LumpingPatchOptions& o = r.options;
  Json rows = Json::array();
  for (const auto& row : r.rows)
    rows.push_back(Json{{"t_s", json_number(row.t_s)},
                        {"after_scan_s", json_number(row.after_scan_s)},
                        {"fine_mean_c", json_number(row.fine_mean_c)},
                        {"lumped_mean_c", json_number(row.lumped_mean_c)},
                        {"fine_max_c", json_number(row.fine_max_c)},
                        {"lumped_max_c", json_number(row.lumped_max_c)},
                        {"rms_difference_k", json_number(row.rms_difference_k)},
                        {"max_difference_k", json_number(row.max_difference_k)}});
  return Json{{"case", "lumping-patch"},
              {"patch_mm", json_number(o.patch_m * 1e3)},
              {"power_w", json_number(o.power_w)},
              {"beam_radius_mm", json_number(o.beam_radius_m * 1e3)},
              {"speed_mm_s", json_number(o.speed_m_s * 1e3)},
              {"hatch_mm", json_number(o.hatch_m * 1e3)},
              {"part_scale_dt_s", json_number(o.part_scale_dt_s)},
              {"material", material_json(o.material)},
              {"scan_time_s", json_number(r.scan_time_s)},
              {"fine_peak_c", json_number(r.fine_peak_c)},
              {"rows", rows},
              {"fine_steps", r.fine_steps},
              {"lumped_steps", r.lumped_steps},
              {"mesh", mesh_json(r.cells, r.dofs)},
              {"energy_balance_rel_error", json_number(r.energy_balance_rel_error)},
              {"wall_s", json_number(r.wall_s)}};
}

Json to_json(const ScenarioResult& r, bool with_trace) {
  const ScenarioConfig& c = r.config;
  Json snaps = Json::array();
  for (const Snapshot& s : r.snapshots)
    snaps.push_back(Json{{"time_s", json_number(s.time_s)},
                         {"file", s.file.empty() ? Json(nullptr) : Json(s.file)},
                         {"measured_c", json_number(s.measured_c)},
                         {"top_mean_c", json_number(s.top_mean_c)}});
  Json layers = Json::array();
  for (const LayerRecord& l : r.layers)
    layers.push_back(Json{{"layer", l.layer},
                          {"spread_s", json_number(l.spread_s)},
                          {"exposure_start_s", json_number(l.exposure_start_s)},
                          {"exposure_end_s", json_number(l.exposure_end_s)},
                          {"scan_length_mm", json_number(l.scan_length_m * 1e3)},
                          {"laser_energy_j", json_number(l.laser_energy_j)},
                          {"spreading_enthalpy_change_j", json_number(l.enthalpy_change_j)},
                          {"fresh_powder_enthalpy_j", json_number(l.fresh_enthalpy_j)}});
  const EnergyTotals& e = r.energy;
  double umin = 0, umax = 0, ymin = 0, ymax = 0;
  if (!r.trace.empty()) {
    umin = umax = r.trace.front().flux_w_m2;
    ymin = ymax = r.trace.front().measured_c;
    for (const TracePoint& p : r.trace) {
      umin = std::min(umin, p.flux_w_m2);
      umax = std::max(umax, p.flux_w_m2);
      ymin = std::min(ymin, p.measured_c);
      ymax = std::max(ymax, p.measured_c);
    }
  }
  Json j{{"case", "scenario"},
         {"config", c.source.empty() ? Json(nullptr) : Json(c.source)},
         {"config_defaults", c.source.empty() ? Json(nullptr) : Json(c.defaulted)},
         {"end_time_s", json_number(c.end_time_s)},
         {"dt_s", json_number(c.dt_s)},
         {"source_scale", c.source_scale == SourceScale::fine ? "fine" : "part_scale"},
         {"snapshots", snaps},
         {"pvd", r.pvd_file.empty() ? Json(nullptr) : Json(r.pvd_file)},
         {"layers", layers},
         {"energy_balance_rel_error", json_number(r.energy_balance_rel_error)},
         {"energy_j",
          Json{{"initial", json_number(e.initial_j)},
               {"final", json_number(e.final_j)},
               {"laser", json_number(e.laser_j)},
               {"preheating_flux", json_number(e.top_flux_j)},
               {"radiation", json_number(e.radiation_j)},
               {"convection", json_number(e.convection_j)},
               {"spreading", json_number(e.spreading_j)},
               {"remesh", json_number(e.remesh_j)},
               {"densification", json_number(e.densification_j)},
               {"step_errors", json_number(e.step_errors_j)},
               {"closure", json_number(e.closure_j)}}},
         {"controller",
          Json{{"kp_w_m2k", json_number(c.kp_w_m2k)},
               {"ti_s", json_number(c.ti_s)},
               {"setpoint_c", json_number(c.setpoint_c)},
               {"flux_min_w_m2", json_number(c.flux_min_w_m2)},
               {"flux_max_w_m2", json_number(c.flux_max_w_m2)},
               {"anti_windup", control::to_string(c.anti_windup)},
               {"holding_flux_w_m2", json_number(r.holding_flux_w_m2)},
               {"measurement", c.measurement.kind == TopWeight::Kind::spot ? "spot" : "area_mean"},
               {"saturated_steps", r.saturated_steps},
               {"flux_range_w_m2", numbers({umin, umax})},
               {"measured_range_c", numbers({ymin, ymax})}}},
         {"steps", r.steps},
         {"newton_iterations", r.newton_iterations},
         {"linear_iterations", r.linear_iterations},
         {"mesh",
          Json{{"cells_at_end", r.mesh_at_end.active_cells},
               {"dofs_at_end", r.mesh_at_end.dofs},
               {"max_cells", r.max_cells},
               {"max_dofs", r.max_dofs},
               {"max_level", r.mesh_at_end.max_level}}},
         {"mpi_ranks", r.mesh_at_end.ranks},
         {"seconds_per_step", json_number(r.seconds_per_step)},
         {"solve_s", json_number(r.solve_s)},
         {"wall_s", json_number(r.wall_s)}};
  if (with_trace) {
    Json t{{"t_s", Json::array()}, {"flux_w_m2", Json::array()}, {"measured_c", Json::array()},
           {"saturated", Json::array()}, {"top_max_c", Json::array()}};
    for (const TracePoint& p : r.trace) {
      t["t_s"].push_back(json_number(p.t_s));
      t["flux_w_m2"].push_back(json_number(p.flux_w_m2));
      t["measured_c"].push_back(json_number(p.measured_c));
      t["saturated"].push_back(p.saturated);
      t["top_max_c"].push_back(json_number(p.top_max_c));
    }
    j["trace"] = t;
  }
  return j;
}

void write_trace_csv(const std::string& path, const ScenarioResult& r) {
  std::string s = "t_s,flux_w_m2,unsaturated_flux_w_m2,saturated,measured_c,setpoint_c,top_max_c,laser_w,layers\n";
  for (const TracePoint& p : r.trace)
    s += fmt::format("{:.6g},{:.9g},{:.9g},{},{:.9g},{:.9g},{:.9g},{:.6g},{}\n", p.t_s, p.flux_w_m2,
                     p.unsaturated_flux_w_m2, p.saturated ? 1 : 0, p.measured_c, p.setpoint_c, p.top_max_c,
                     p.laser_w, p.layers);
  write_file_atomically(path, s);
}

}  // namespace amctl::sls3d
