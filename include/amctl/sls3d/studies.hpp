#pragma once
// The runs behind `amctl thermal sls3d` (docs/sls3d.md): three verification cases with
// analytic references and the seed's closed-loop scenario on the powder bed. Each returns a
// value type with a JSON form; the CLI and the Python binding call these functions.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/sls3d/config.hpp"
#include "amctl/sls3d/plant.hpp"

namespace amctl::sls3d {

/// Time integration of the verification cases.
enum class Scheme { backward_euler, crank_nicolson };
[[nodiscard]] const char* to_string(Scheme s);

// ---------------------------------------------------------------------------------------
// Case 1: a slab of thickness L, insulated below, uniform flux U on top from t = 0.

struct SlabFluxOptions {
  double thickness_m = 1e-3;
  double flux_w_m2 = 1000.0;
  std::vector<double> times_s{1.0, 5.0, 20.0};
  Material material{};    ///< the seed's PA12 (k 0.28, rho 1010, cp 1928)
  int cells = 64;         ///< cells across the thickness
  /// Largest step [s]; 0: automatic (L^2/(100 a), and at most 1/20 of each interval between
  /// the requested times).
  double max_dt_s = 0.0;
  Scheme scheme = Scheme::crank_nicolson;  ///< with two backward-Euler half steps at the start
  void validate() const;
};

struct SlabFluxResult {
  SlabFluxOptions options;
  std::vector<double> top_rise_k;         ///< finite elements, at times_s
  std::vector<double> series_top_rise_k;  ///< Carslaw & Jaeger's series, same times
  int steps = 0;
  std::uint64_t cells = 0, dofs = 0;
  double energy_balance_rel_error = 0.0;  ///< largest per step
  double wall_s = 0.0;
};

[[nodiscard]] SlabFluxResult run_slab_flux(const SlabFluxOptions& o);
/// T(L, t) - T0 of the slab (Carslaw & Jaeger 1959, section 3.3), the series summed until
/// its terms are below 1e-16 of the result.
[[nodiscard]] double slab_flux_top_rise(const Material& m, double thickness_m, double flux_w_m2,
                                        double t_s);

// ---------------------------------------------------------------------------------------
// Case 2: the same slab under the PI of the 1D design acting on its top temperature: a set
// point S above the initial temperature, U = PI(S - y), no saturation.

struct SlabPiOptions {
  double thickness_m = 1e-4;
  double setpoint_rise_k = 10.0;
  double kp_w_m2k = 0.3;
  double ti_s = 0.5;
  std::vector<double> times_s{10.0, 30.0, 60.0};
  Material material{};
  int cells = 16;
  double max_dt_s = 0.0;  ///< 0: automatic (min(0.02 s, Ti/20, L^2/(20 a)))
  Scheme scheme = Scheme::crank_nicolson;
  void validate() const;
};

struct SlabPiResult {
  SlabPiOptions options;
  std::vector<double> top_rise_k;
  std::vector<double> flux_w_m2;  ///< U at the requested times
  int steps = 0;
  std::uint64_t cells = 0, dofs = 0;
  double energy_balance_rel_error = 0.0;
  double wall_s = 0.0;
};

[[nodiscard]] SlabPiResult run_slab_pi(const SlabPiOptions& o);

// ---------------------------------------------------------------------------------------
// Case 3: a Gaussian surface source q = 2P/(pi W^2) exp(-2 r^2/W^2) moving at speed v along
// +x over a semi-infinite body (the half y >= 0 with its symmetry plane), run until the field
// around the beam is quasi-steady; compared with the Eagar-Tsai integral.

struct MovingSourceOptions {
  double power_w = 1.0;        ///< absorbed power P
  double beam_radius_m = 1e-4;  ///< W, 1/e^2 radius
  double speed_m_s = 0.01;
  Material material{};
  /// Probe points relative to the beam centre at the end: x along the scan (negative
  /// behind), y across, z the depth below the surface (>= 0).
  std::vector<std::array<double, 3>> probes_m;
  /// Resolution: cells per beam radius at the finest level in the plane (the vertical is
  /// four times finer near the surface).
  int cells_per_radius = 8;
  /// Steps per beam radius of travel.
  int steps_per_radius = 8;
  void validate() const;
};

struct ProbeValue {
  std::array<double, 3> where_m{};
  double rise_k = 0.0;
  double analytic_rise_k = 0.0;
};

struct MovingSourceResult {
  MovingSourceOptions options;
  double peclet = 0.0;          ///< v W / (2 a)
  double peak_rise_k = 0.0;     ///< largest rise of the surface (quadratic through the nodes)
  double peak_x_m = 0.0;        ///< where, relative to the beam centre (negative behind)
  double analytic_peak_rise_k = 0.0;
  double analytic_peak_x_m = 0.0;
  std::vector<ProbeValue> probes;
  double travel_m = 0.0;
  double quasi_steady_drift = 0.0;  ///< relative change of the peak over the last radius of travel
  int steps = 0;
  std::uint64_t cells = 0, dofs = 0;
  double energy_balance_rel_error = 0.0;
  double wall_s = 0.0;
};

[[nodiscard]] MovingSourceResult run_moving_source(const MovingSourceOptions& o);

/// The quasi-steady rise of the Eagar-Tsai solution (Eagar & Tsai 1983) for the source of
/// MovingSourceOptions at (xi, y, z) relative to the beam centre (xi along the motion, z depth).
[[nodiscard]] double eagar_tsai_rise(const Material& m, double power_w, double beam_radius_m,
                                     double speed_m_s, double xi_m, double y_m, double z_m);
/// Largest surface rise on the track (y = z = 0) and where it is.
[[nodiscard]] std::pair<double, double> eagar_tsai_peak(const Material& m, double power_w,
                                                        double beam_radius_m, double speed_m_s);

// ---------------------------------------------------------------------------------------
// Case 4: the lumping error of the part-scale source on a hatched patch: the same patch
// scanned with the resolved spot (fine) and with the lumped strips (part scale), compared
// after the scan.

struct LumpingPatchOptions {
  double patch_m = 2e-3;       ///< side of the square patch
  double power_w = 30.0;       ///< absorbed
  double beam_radius_m = 2.5e-4;
  double speed_m_s = 5.0;
  double hatch_m = 3e-4;
  Material material{0.1, 450.0, 1928.0};
  double initial_temp_c = 172.0;
  /// After the scan ends; each is rounded up to the part-scale step grid (the comparison is
  /// where both runs have a solution), times that round to the same step giving one row.
  std::vector<double> times_after_s{0.05, 0.2, 0.5};
  double part_scale_dt_s = 0.1;
  void validate() const;
};

struct LumpingPatchResult {
  LumpingPatchOptions options;
  struct Row {
    double t_s = 0;
    double after_scan_s = 0;                      ///< t_s minus the end of the scan
    double fine_mean_c = 0, lumped_mean_c = 0;    ///< mean over the patch
    double fine_max_c = 0, lumped_max_c = 0;      ///< top maximum
    double rms_difference_k = 0;                  ///< over the patch's top surface
    double max_difference_k = 0;
  };
  std::vector<Row> rows;
  double scan_time_s = 0.0;
  double fine_peak_c = 0.0;  ///< largest temperature during the fine scan
  int fine_steps = 0, lumped_steps = 0;
  std::uint64_t cells = 0, dofs = 0;
  double energy_balance_rel_error = 0.0;
  double wall_s = 0.0;
};

[[nodiscard]] LumpingPatchResult run_lumping_patch(const LumpingPatchOptions& o);

// ---------------------------------------------------------------------------------------
// The closed-loop scenario of the SLS paper on the powder bed (configs/sls_seed002_3d.toml).

struct ScenarioOptions {
  std::string vtu_dir;       ///< write VTU snapshots and DIR/sls3d.pvd there (empty: none)
  bool keep_rasters = true;  ///< top-surface maps at the snapshot times (the report's maps)
};

struct TracePoint {
  double t_s = 0;
  double flux_w_m2 = 0;              ///< U applied over [t, t + dt]
  double unsaturated_flux_w_m2 = 0;  ///< what the PI asked for
  double measured_c = 0;             ///< y at t
  double setpoint_c = 0;
  double top_max_c = 0;              ///< largest top-surface temperature after the step
  double laser_w = 0;                ///< mean absorbed laser power over the step
  int layers = 0;
  bool saturated = false;
};

struct Snapshot {
  double time_s = 0;
  std::string file;  ///< VTU file name inside vtu_dir (empty without one)
  TopRaster map;     ///< top surface (when keep_rasters)
  double measured_c = 0;
  double top_mean_c = 0;
};

struct LayerRecord {
  int layer = 0;
  double spread_s = 0, exposure_start_s = 0, exposure_end_s = 0;
  double scan_length_m = 0;
  double laser_energy_j = 0;
  double enthalpy_change_j = 0;  ///< of the spreading
  double fresh_enthalpy_j = 0;
};

struct EnergyTotals {
  double initial_j = 0, final_j = 0;
  double laser_j = 0, top_flux_j = 0, radiation_j = 0, convection_j = 0;
  double spreading_j = 0, remesh_j = 0, densification_j = 0;
  double step_errors_j = 0;  ///< sum of the per-step balance errors
  /// final - initial - (laser + flux - losses + spreading + remesh + densification)
  double closure_j = 0;
};

struct ScenarioResult {
  ScenarioConfig config;
  std::vector<TracePoint> trace;
  std::vector<Snapshot> snapshots;
  std::vector<LayerRecord> layers;
  EnergyTotals energy;
  double energy_balance_rel_error = 0.0;  ///< largest per-step relative error
  int steps = 0, newton_iterations = 0, linear_iterations = 0;
  MeshStats mesh_at_end;
  std::uint64_t max_cells = 0, max_dofs = 0;
  double wall_s = 0.0, solve_s = 0.0;
  double seconds_per_step = 0.0;
  std::string pvd_file;  ///< DIR/sls3d.pvd (empty without vtu_dir)
  double holding_flux_w_m2 = 0.0;
  int saturated_steps = 0;
};

/// Runs the scenario. With vtu_dir, the snapshots are written to a staging directory inside
/// it and moved into place at the end, so a run that fails leaves nothing. Throws
/// amctl::Error for a solve that does not converge (naming the step, the time and the
/// solver's report).
[[nodiscard]] ScenarioResult run_scenario(const ScenarioConfig& config, const ScenarioOptions& o);

// ---------------------------------------------------------------------------------------
// Outputs.

[[nodiscard]] Json to_json(const SlabFluxResult& r);
[[nodiscard]] Json to_json(const SlabPiResult& r);
[[nodiscard]] Json to_json(const MovingSourceResult& r);
[[nodiscard]] Json to_json(const LumpingPatchResult& r);
/// The summary (no traces, no maps); `with_trace` adds the trace arrays.
[[nodiscard]] Json to_json(const ScenarioResult& r, bool with_trace = false);
/// t_s, flux_w_m2, unsaturated_flux_w_m2, saturated, measured_c, setpoint_c, top_max_c,
/// laser_w, layers: one row per step. Written through a temporary file renamed into place.
void write_trace_csv(const std::string& path, const ScenarioResult& r);
/// Writes `text` to `path` whole or not at all (a temporary file renamed into place).
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace amctl::sls3d
