// The closed-loop scenario of the SLS paper on the 3D powder bed (amctl/sls3d/studies.hpp,
// docs/sls3d.md section 5): the growing bed, the ring hatched layer by layer, the PI on the
// preheating flux acting on the measured top temperature, snapshots and maps.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string_view>
#include <numbers>

#include <fmt/format.h>

#include "amctl/control/pid.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/sls3d/scan.hpp"
#include "amctl/sls3d/studies.hpp"

namespace amctl::sls3d {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Coarse slices of the base: the top slice a cell of a layer thick, each one below twice as
// thick, at most 2 mm, down to the base depth.
std::vector<double> base_slices(const ScenarioConfig& c) {
  std::vector<double> z{0.0};
  double dz = c.layer_thickness_m / c.cells_per_layer;
  while (z.back() > -c.base_depth_m + 1e-12) {
    const double next = z.back() - dz;
    z.push_back(next < -c.base_depth_m + 0.25 * dz ? -c.base_depth_m : next);
    dz = std::min(2e-3, 2.0 * dz);
  }
  z.back() = -c.base_depth_m;
  std::reverse(z.begin(), z.end());
  return z;
}

PlantSpec scenario_spec(const ScenarioConfig& c) {
  PlantSpec p;
  p.mesh.footprint = MeshSpec::Footprint::disc;
  p.mesh.disc_radius_m = c.disc_radius_m;
  p.mesh.coarse_cell_m = c.coarse_cell_m;
  p.mesh.base_slices_m = base_slices(c);
  p.mesh.layers = c.layers;
  p.mesh.layer_thickness_m = c.layer_thickness_m;
  p.mesh.cells_per_layer = c.cells_per_layer;
  p.powder = c.powder;
  p.sintered = c.sintered;
  p.melting = c.melting;
  p.losses = c.losses;
  p.initial_temp_c = c.initial_temp_c;
  p.initial_state = 0.0;
  p.theta = c.theta;
  p.solver = c.solver;
  return p;
}

// The part's edges at edge_level, its cross-section at part_level (down to refine_depth
// below the top); around the beam at laser_level for the fine source scale.
std::vector<RefineZone> part_zones(const ScenarioConfig& c) {
  std::vector<RefineZone> z;
  auto annulus = [&](double r0, double r1, int level) {
    RefineZone a;
    a.shape = RefineZone::Shape::annulus;
    a.r0_m = std::max(0.0, r0);
    a.r1_m = r1;
    a.depth_m = c.refine_depth_m;
    a.level = level;
    z.push_back(a);
  };
  annulus(c.part_inner_radius_m - c.edge_band_m, c.part_outer_radius_m + c.edge_band_m, c.part_level);
  for (double r : {c.part_inner_radius_m, c.part_outer_radius_m})
    z.push_back(RefineZone{RefineZone::Shape::annulus, 0, 0, 0, 0, 0, std::max(0.0, r - c.edge_band_m),
                           r + c.edge_band_m, 0.5 * c.refine_depth_m, c.edge_level});
  // Where the controller measures.
  RefineZone m;
  m.x0_m = m.x1_m = c.measurement.x_m;
  m.y0_m = m.y1_m = c.measurement.y_m;
  m.radius_m = c.measurement.kind == TopWeight::Kind::spot ? 1.5 * c.measurement.radius_m : 0.0;
  m.depth_m = c.refine_depth_m;
  m.level = c.part_level;
  if (c.measurement.kind == TopWeight::Kind::spot) z.push_back(m);
  // Uniform refinements: every zone one level finer per refinement, and every cell at least
  // that level (a zone over the whole bed, all the way down).
  if (c.global_refinements > 0) {
    for (RefineZone& zone : z) zone.level += c.global_refinements;
    z.push_back(RefineZone{RefineZone::Shape::annulus, 0, 0, 0, 0, 0, 0.0, 2.0 * c.disc_radius_m, 1e9,
                           c.global_refinements});
  }
  return z;
}

std::string stem_of(std::size_t i) { return fmt::format("sls3d_{:04d}", i); }

// The .pvd time series of the snapshots (ParaView's collection format).
std::string pvd_text(const std::vector<Snapshot>& snaps) {
  std::string s = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n";
  for (const Snapshot& sn : snaps)
    if (!sn.file.empty())
      s += fmt::format("    <DataSet timestep=\"{:.9g}\" group=\"\" part=\"0\" file=\"{}\"/>\n", sn.time_s,
                       fs::path(sn.file).filename().string());
  s += "  </Collection>\n</VTKFile>\n";
  return s;
}

}  // namespace

ScenarioResult run_scenario(const ScenarioConfig& c, const ScenarioOptions& o) {
  c.validate();
  const auto wall0 = Clock::now();
  ScenarioResult r;
  r.config = c;
  const std::vector<LayerSchedule> schedule = layer_schedule(c);
  auto plant = make_plant(scenario_spec(c));
  const bool root = plant->stats().rank == 0;

  // VTU snapshots go to a staging directory, moved into place once the run succeeded.
  fs::path staging;
  bool created_dir = false;
  if (!o.vtu_dir.empty()) {
    staging = fs::path(o.vtu_dir) / ".sls3d-partial";
    if (root) {
      std::error_code ec;
      created_dir = !fs::exists(o.vtu_dir);
      fs::create_directories(staging, ec);
      if (ec) throw Error(o.vtu_dir + ": cannot create the snapshot directory: " + ec.message());
    }
    plant->barrier();
  }
  auto cleanup = [&] {
    if (!root || staging.empty()) return;
    std::error_code ec;
    fs::remove_all(staging, ec);
    if (created_dir) fs::remove(o.vtu_dir, ec);
  };

  try {
    const std::vector<RefineZone> zones = part_zones(c);
    const int steps = int(std::llround(c.end_time_s / c.dt_s));
    const TopWeight weight{c.measurement.kind, c.measurement.x_m, c.measurement.y_m, c.measurement.radius_m,
                           c.measurement.inner_radius_m, c.measurement.outer_radius_m};
    const TopWeight whole{TopWeight::Kind::area, 0, 0, 0, 0, 1e9};
    // The PI of the 1D design on the preheating flux: U = bias + C(s) e, the bias being the
    // integral's starting value (the flux that held the bed at the set point before t = 0).
    r.holding_flux_w_m2 = holding_flux_w_m2(c.losses, c.setpoint_c);
    const double bias = c.start_at_holding_flux
                            ? std::clamp(r.holding_flux_w_m2, c.flux_min_w_m2, c.flux_max_w_m2)
                            : 0.0;
    control::PidOptions po;
    po.output_min = c.flux_min_w_m2 - bias;
    po.output_max = c.flux_max_w_m2 - bias;
    po.anti_windup = c.anti_windup;
    po.tracking_time_s = c.tracking_time_s;
    control::PidController pi(control::PidGains::standard(c.kp_w_m2k, c.ti_s), po);

    std::vector<ScanPath> paths;
    for (std::size_t i = 0; i < schedule.size(); ++i)
      paths.push_back(hatch_ring(c.part_inner_radius_m, c.part_outer_radius_m,
                                 HatchSettings{c.hatch_m, c.scan_speed_m_s,
                                               c.hatch_angle_rad + double(i) * c.layer_rotation_rad}));
    const double power = c.absorptivity * c.laser_power_w;
    std::vector<double> snap_times = c.snapshot_times_s;
    std::sort(snap_times.begin(), snap_times.end());
    snap_times.erase(std::unique(snap_times.begin(), snap_times.end()), snap_times.end());
    std::size_t next_snap = 0, next_layer = 0;
    auto on_step = [&](double t, int n) { return std::abs(t - n * c.dt_s) <= 1e-9 * std::max(1.0, t); };
    auto take_snapshot = [&](double t) {
      Snapshot s;
      s.time_s = t;
      s.measured_c = plant->top_mean(weight);
      s.top_mean_c = plant->top_mean(whole);
      if (o.keep_rasters) {
        const int n = c.map_pixels;
        const double d = 2.0 * c.disc_radius_m / n;
        s.map = plant->raster_top(-c.disc_radius_m + 0.5 * d, -c.disc_radius_m + 0.5 * d, d, d, n, n);
      }
      if (!staging.empty()) {
        // Written by rank 0 through the one output writer (atomic, removed on a signal),
        // into the staging directory, moved into place once the whole run succeeded.
        const std::string name = stem_of(r.snapshots.size()) + ".vtu";
        // Errors (opening, writing, committing) are raised inside the sink, so the engine
        // passes them on to every rank.
        std::unique_ptr<OutputFile> file;
        plant->write_vtu(
            [&](std::string_view bytes) {
              if (!file) file = std::make_unique<OutputFile>((staging / name).string());
              if (bytes.empty()) file->commit();
              else file->write(bytes);
            },
            t);
        s.file = (fs::path(o.vtu_dir) / name).string();
      }
      r.snapshots.push_back(std::move(s));
    };
    auto track_mesh = [&] {
      const MeshStats ms = plant->stats();
      r.max_cells = std::max<std::uint64_t>(r.max_cells, ms.active_cells);
      r.max_dofs = std::max<std::uint64_t>(r.max_dofs, ms.dofs);
    };
    r.energy.initial_j = plant->enthalpy_j();
    r.energy.remesh_j += plant->remesh(zones).enthalpy_change_j;
    for (int n = 0; n <= steps; ++n) {
      const double t = n * c.dt_s;
      // Snapshots first: an instant at which a layer is spread shows the bed as the step
      // before left it (the paper's 15.1 s: the first layer just sintered, before the next
      // powder covers it).
      while (next_snap < snap_times.size() && on_step(snap_times[next_snap], n)) {
        take_snapshot(snap_times[next_snap]);  // the requested instant (n dt up to rounding)
        ++next_snap;
      }
      // Spreading.
      while (next_layer < schedule.size() && on_step(schedule[next_layer].spread_s, n)) {
        const LayerReport lr = plant->add_layer(c.fresh_powder_temp_c);
        const RemeshReport rr = plant->remesh(zones);
        r.energy.spreading_j += lr.enthalpy_change_j;
        r.energy.remesh_j += rr.enthalpy_change_j;
        LayerRecord rec;
        rec.layer = lr.layer;
        rec.spread_s = t;
        rec.exposure_start_s = schedule[next_layer].exposure_start_s;
        rec.exposure_end_s = schedule[next_layer].exposure_end_s;
        rec.scan_length_m = paths[next_layer].length_m();
        rec.enthalpy_change_j = lr.enthalpy_change_j;
        rec.fresh_enthalpy_j = lr.fresh_enthalpy_j;
        r.layers.push_back(rec);
        ++next_layer;
        track_mesh();
      }
      if (n == steps) break;
      // The controller samples y at t and holds U over the step.
      const double y = plant->top_mean(weight);
      const control::PidStep ps = pi.step(c.setpoint_c, y, c.dt_s);
      TracePoint tp;
      tp.t_s = t;
      tp.flux_w_m2 = bias + ps.output;
      tp.unsaturated_flux_w_m2 = bias + ps.unsaturated_output;
      tp.saturated = ps.saturated;
      tp.measured_c = y;
      tp.setpoint_c = c.setpoint_c;
      StepInput in;
      in.t_s = t;
      in.dt_s = c.dt_s;
      in.top_flux_w_m2 = tp.flux_w_m2;
      in.source = c.source_scale == SourceScale::fine ? SourceModel::gaussian : SourceModel::lumped_strip;
      in.beam_radius_m = c.spot_radius_m;
      in.hatch_m = c.hatch_m;
      // The exposure of the layer being built (the last one spread).
      if (!r.layers.empty()) {
        const std::size_t li = r.layers.size() - 1;
        const double ts = schedule[li].exposure_start_s;
        in.passes = paths[li].passes(t - ts, t + c.dt_s - ts, ts, power);
      }
      if (c.source_scale == SourceScale::fine && !in.passes.empty()) {
        std::vector<RefineZone> z = zones;
        for (const LaserPass& lp : in.passes)
          z.push_back(RefineZone{RefineZone::Shape::capsule, lp.x0_m, lp.y0_m, lp.x1_m, lp.y1_m,
                                 3.0 * c.spot_radius_m, 0, 0, c.refine_depth_m,
                                 c.laser_level + c.global_refinements});
        r.energy.remesh_j += plant->remesh(z).enthalpy_change_j;
      }
      const StepReport sr = plant->step(in);
      for (const LaserPass& lp : in.passes) tp.laser_w += lp.power_w * (lp.t1_s - lp.t0_s) / c.dt_s;
      tp.top_max_c = sr.max_temp_c;
      tp.layers = int(r.layers.size());
      r.trace.push_back(tp);
      if (!r.layers.empty()) r.layers.back().laser_energy_j += sr.laser_j;
      r.energy.laser_j += sr.laser_j;
      r.energy.top_flux_j += sr.top_flux_j;
      r.energy.radiation_j += sr.radiation_j;
      r.energy.convection_j += sr.convection_j;
      r.energy.densification_j += sr.densification_j;
      r.energy.step_errors_j += sr.balance_error_j;
      r.energy_balance_rel_error = std::max(r.energy_balance_rel_error, sr.balance_rel_error);
      r.newton_iterations += sr.newton_iterations;
      r.linear_iterations += sr.linear_iterations;
      if (tp.saturated) ++r.saturated_steps;
      ++r.steps;
      if (n % 20 == 0) track_mesh();
    }
    track_mesh();
    r.energy.final_j = plant->enthalpy_j();
    const EnergyTotals& e = r.energy;
    r.energy.closure_j = e.final_j - e.initial_j -
                         (e.laser_j + e.top_flux_j - e.radiation_j - e.convection_j + e.spreading_j + e.remesh_j +
                          e.densification_j);
    r.mesh_at_end = plant->stats();
    r.solve_s = plant->solve_seconds();

    if (!staging.empty()) {
      plant->barrier();
      if (root) {
        for (const Snapshot& s : r.snapshots) {
          const fs::path name = fs::path(s.file).filename();
          fs::rename(staging / name, fs::path(o.vtu_dir) / name);
        }
        r.pvd_file = (fs::path(o.vtu_dir) / "sls3d.pvd").string();
        write_file_atomically(r.pvd_file, pvd_text(r.snapshots));
        fs::remove_all(staging);
      } else {
        r.pvd_file = (fs::path(o.vtu_dir) / "sls3d.pvd").string();
      }
      plant->barrier();
    }
  } catch (...) {
    cleanup();
    throw;
  }
  r.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
  r.seconds_per_step = r.steps > 0 ? r.solve_s / r.steps : 0.0;
  return r;
}

}  // namespace amctl::sls3d
