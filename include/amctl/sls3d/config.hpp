#pragma once
// The closed-loop scenario on the 3D powder bed (configs/sls_seed002_3d.toml documents every
// key). Lengths are millimetres in the file and metres here.
#include <map>
#include <string>
#include <vector>

#include "amctl/control/pid.hpp"
#include "amctl/core/error.hpp"
#include "amctl/sls3d/plant.hpp"

namespace amctl::sls3d {

/// What the controller measures on the top surface.
struct MeasurementConfig {
  TopWeight::Kind kind = TopWeight::Kind::spot;
  double x_m = 0.0, y_m = 0.0;
  double radius_m = 0.01;                 ///< spot: 1/e^2 radius of the pyrometer's weight
  double inner_radius_m = 0.0, outer_radius_m = 1.0;  ///< area mean: the annulus around (x, y)
};

enum class SourceScale { part_scale, fine };

struct ScenarioConfig {
  // [bed]
  double disc_radius_m = 0.1;
  double base_depth_m = 5e-3;
  double layer_thickness_m = 1e-4;
  int layers = 2;
  double initial_temp_c = 172.0;
  double fresh_powder_temp_c = 150.0;
  // [part]: a hollow cylinder
  double part_inner_radius_m = 0.05;
  double part_outer_radius_m = 0.055;
  // [powder], [sintered], [melting], [losses]
  Material powder{0.1, 450.0, 1928.0};
  Material sintered{0.28, 1010.0, 1928.0};
  Melting melting{true, 176.0, 186.0, 1.0e5};
  SurfaceLosses losses{0.9, 25.0, 5.0, 150.0};
  // [laser]
  double laser_power_w = 30.0;
  double absorptivity = 0.9;
  double scan_speed_m_s = 5.0;
  double hatch_m = 3e-4;
  double spot_radius_m = 2.5e-4;  ///< 1/e^2 radius
  double field_radius_m = 0.2;    ///< the galvanometer's reach around the axis
  double hatch_angle_rad = 0.0;
  double layer_rotation_rad = 1.5707963267948966;  ///< hatch turned by this from layer to layer
  double first_exposure_s = 14.0;  ///< exposure of the first layer (spread at t = 0) starts
  double preheat_s = 11.9;         ///< from the spreading of a later layer to its exposure
  double recoat_s = 0.0;           ///< from the end of an exposure to the next spreading
  // [controller]: U = PI(r - y) on the preheating flux, C(s) = kp (Ti s + 1)/(Ti s)
  double setpoint_c = 172.0;
  double kp_w_m2k = 0.3;
  double ti_s = 0.5;
  double flux_min_w_m2 = 0.0;
  double flux_max_w_m2 = 3000.0;
  control::AntiWindup anti_windup = control::AntiWindup::conditional_integration;
  double tracking_time_s = 1.0;
  /// Start the integral at the flux that holds the bed at the set point against the losses
  /// (the bed starts in that steady state); false: at zero.
  bool start_at_holding_flux = true;
  // [measurement]
  MeasurementConfig measurement{};
  // [numerics]
  SourceScale source_scale = SourceScale::part_scale;
  double dt_s = 0.1;
  double theta = 1.0;
  double coarse_cell_m = 5e-3;
  int cells_per_layer = 1;
  int edge_level = 2;          ///< refinement at the part's edges
  double edge_band_m = 5e-4;   ///< half-width of the refined band around each edge
  int part_level = 1;          ///< refinement over the part's cross-section and the pyrometer spot
  int laser_level = 3;         ///< around the beam (fine scale)
  double refine_depth_m = 5e-4;  ///< refinement reaches this far below the top
  /// Uniform refinements on top of all of the above (every cell, every zone's level + this):
  /// each halves every cell, for mesh-convergence studies.
  int global_refinements = 0;
  SolverSettings solver{};
  // [output]
  double end_time_s = 28.1;
  std::vector<double> snapshot_times_s{14.0, 15.1, 28.1};
  int map_pixels = 160;

  /// Where each key was set ("laser.power_w" -> file:line:col), for messages.
  std::map<std::string, SourceLocation> where;
  /// "section.key" of every key the file left to its built-in value, in reading order (the
  /// output lists them, so a misspelt section is seen; empty without a file).
  std::vector<std::string> defaulted;
  std::string source;  ///< the file read ("" for the built-in defaults)

  /// Throws amctl::Error naming the key (at its place in the file) for a value the model
  /// cannot use: non-positive properties, a part that does not fit the disc, a laser that
  /// never reaches the part, a time step the scheme cannot use, snapshot times off the grid.
  void validate() const;
  /// The place of `key` ("section.key"), or the file alone.
  [[nodiscard]] SourceLocation at(const std::string& key) const;
};

/// Reads a TOML file (configs/sls_seed002_3d.toml); unknown sections and keys, wrong types
/// and values validate() refuses throw amctl::Error with file:line:col.
[[nodiscard]] ScenarioConfig load_scenario_config(const std::string& path);

/// Spreading, exposure start and exposure end of layer i (1-based) and the scan duration.
struct LayerSchedule {
  double spread_s = 0, exposure_start_s = 0, exposure_end_s = 0;
};
[[nodiscard]] std::vector<LayerSchedule> layer_schedule(const ScenarioConfig& c);

/// The flux that holds a surface at temp_c against the losses, W/m^2.
[[nodiscard]] double holding_flux_w_m2(const SurfaceLosses& l, double temp_c);

}  // namespace amctl::sls3d
