#pragma once
// Time-domain simulation of the SLS powder bed of seed 002: the 1D heat equation (1)-(4) on a
// column that grows by one layer of fresh powder (its own temperature) every layer time, with
// the preheating flux U at the top (2), an insulated bottom (3) and the top temperature as
// output. Finite volumes on a uniform mesh of `cells_per_layer` cells per layer that follows
// the growing domain (nodes are appended, never remeshed); Crank-Nicolson with Rannacher
// start-up or BDF2 with a backward-Euler start, both second order.
#include <cstdint>
#include <string>
#include <vector>

#include "amctl/thermal/powder_bed_tf.hpp"

namespace amctl::thermal {

enum class TimeScheme { crank_nicolson, bdf2, backward_euler };

/// The bed column and its time stepper. Owns its state (temperatures and work buffers).
/// Node j sits at z = j h; the end nodes own half cells, so sum(capacity_j T_j) is the
/// column's heat content and each step conserves it exactly up to the flux in.
class HeatColumn {
 public:
  /// Column of `cells` cells of size `cell_m` at uniform `initial_temp_c`.
  HeatColumn(const PowderMaterial& material, double cell_m, int cells, double initial_temp_c,
             TimeScheme scheme = TimeScheme::bdf2, int rannacher_half_steps = 2);

  /// Sets the node temperatures (size cells + 1) and restarts the multistep history.
  void set_temperatures(const std::vector<double>& temps_c);
  /// Advances by dt with the top flux (W/m^2, positive heats) held over the step.
  void step(double dt_s, double top_flux_w_m2);
  /// Appends `cells` cells of fresh powder at `temp_c` on top (the old top node becomes interior;
  /// its half cell is completed with fresh powder, so its temperature becomes the mean).
  /// The multistep history is restarted.
  void add_layer(int cells, double temp_c);

  [[nodiscard]] double top_temp_c() const { return t_.back(); }
  [[nodiscard]] const std::vector<double>& temperatures_c() const { return t_; }
  [[nodiscard]] double length_m() const { return cell_m_ * double(t_.size() - 1); }
  [[nodiscard]] double cell_m() const { return cell_m_; }
  [[nodiscard]] int cells() const { return int(t_.size()) - 1; }
  /// Heat content per unit area relative to 0 C, J/m^2.
  [[nodiscard]] double heat_j_m2() const;

 private:
  void solve_tridiagonal(double diag_scale, double off, std::vector<double>& rhs);
  void implicit_step(double dt_s, double flux, double theta);  // theta = 1 BE, 0.5 CN

  PowderMaterial material_;
  double cell_m_;
  TimeScheme scheme_;
  int rannacher_half_steps_;
  std::vector<double> t_, t_prev_, rhs_, cprime_;
  bool have_prev_ = false;   // BDF2 history available
  bool fresh_start_ = true;  // CN: next step is a Rannacher start-up
};

enum class AntiWindup { none, back_calculation, conditional_integration };

/// One constant set point from a given layer on.
struct SetpointChange {
  int from_layer = 0;
  double setpoint_c = 0.0;
};

/// A full build: material, geometry, controller, actuator limits, disturbance, numerics.
struct SlsBuildConfig {
  PowderMaterial material{};
  double layer_thickness_m = 1e-4;  ///< l0
  int initial_layers = 1;           ///< l(0) = initial_layers * l0
  int layers_added = 100;           ///< layer additions after t = 0
  double layer_time_s = 14.0;       ///< time between additions
  double initial_temp_c = 172.0;
  double fresh_powder_temp_c = 150.0;
  double setpoint_c = 172.0;
  std::vector<SetpointChange> setpoint_changes{};
  // PI C(s) = kp (Ti s + 1)/(Ti s) on e = r - y, output = flux at the top.
  double kp_w_m2k = 2000.0;
  double ti_s = 4.0;
  double flux_min_w_m2 = 0.0;
  double flux_max_w_m2 = 20000.0;
  AntiWindup anti_windup = AntiWindup::back_calculation;
  double tracking_time_s = 2.0;  ///< Tt of back-calculation
  // Sintering laser: extra flux (layer average) during [start, start + duration) of each layer.
  double laser_flux_w_m2 = 0.0;
  double laser_start_s = 2.0;
  double laser_duration_s = 6.0;
  // Numerics.
  int cells_per_layer = 2;
  double dt_s = 0.25;
  TimeScheme scheme = TimeScheme::bdf2;
  double settle_band_k = 0.5;  ///< |e| band for the settling time
  int csv_every = 1;           ///< write every n-th step to the CSV (0: no trace)

  /// Throws amctl::Error naming the first bad field.
  void validate() const;
};

/// Per-layer figures (the interval between an addition and the next).
struct LayerStats {
  int layer = 0;                 ///< number of layers in the column during the interval
  double setpoint_c = 0.0;
  double dip_k = 0.0;            ///< max(r - y) after the addition
  double overshoot_k = 0.0;      ///< max(y - r, 0)
  double settling_time_s = 0.0;  ///< from the addition until |e| stays within the band
  bool settled = false;
  double final_error_k = 0.0;    ///< r - y at the end of the interval
  double effort_j_m2 = 0.0;      ///< integral of the control flux
  double saturated_fraction = 0.0;
};

struct TracePoint {
  double t_s, depth_m, y_c, setpoint_c, flux_w_m2, disturbance_w_m2, integral_w_m2;
  int layers;
};

struct SlsBuildResult {
  std::vector<LayerStats> layers;
  std::vector<TracePoint> trace;
  double max_overshoot_k = 0.0;
  double max_dip_k = 0.0;
  double mean_settling_time_s = 0.0;
  double max_settling_time_s = 0.0;
  int unsettled_layers = 0;
  double final_abs_error_k = 0.0;
  double mean_abs_final_error_k = 0.0;
  double total_effort_j_m2 = 0.0;
  double rms_flux_w_m2 = 0.0;
  double saturated_fraction = 0.0;
  double energy_balance_error_j_m2 = 0.0;  ///< heat content - (initial + fluxes + fresh powder)
  std::int64_t steps = 0;
  int final_nodes = 0;
};

/// Runs the closed loop through all layer additions.
[[nodiscard]] SlsBuildResult simulate_sls_build(const SlsBuildConfig& cfg);

/// Reads a TOML configuration (see configs/sls_pa12.toml); errors carry file:line:col.
[[nodiscard]] SlsBuildConfig load_sls_config(const std::string& path);

[[nodiscard]] const char* to_string(AntiWindup a);
[[nodiscard]] const char* to_string(TimeScheme s);

}  // namespace amctl::thermal
