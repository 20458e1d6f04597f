#pragma once
// Time-domain simulation of the SLS powder bed of seed 002: the 1D heat equation (1)-(4) on a
// column that grows by one layer of fresh powder (its own temperature) every layer time, with
// the preheating flux U at the top (2), an insulated bottom (3) and the top temperature as
// output. Finite volumes on a uniform mesh of `cells_per_layer` cells per layer that follows
// the growing domain (nodes are appended, never remeshed); TR-BDF2, Crank-Nicolson with
// Rannacher start-up, or BDF2 with a backward-Euler start, all second order.
#include <cstdint>
#include <string>
#include <vector>

#include "amctl/control/pid.hpp"
#include "amctl/thermal/powder_bed_tf.hpp"

namespace amctl::thermal {

/// Time integrators. All are implicit and second order except backward Euler.
///  - tr_bdf2 (default): trapezoid to t + g dt then BDF2, g = 2 - sqrt(2) (Bank et al. 1985,
///    Hosea & Shampine 1996). One-step, L-stable, and with the flux held over the step it
///    conserves heat exactly, so it suits the sampled closed loop.
///  - crank_nicolson: A-stable only (stiff modes flip sign each step); Rannacher start-up of
///    backward-Euler half steps after every restart.
///  - bdf2: L-stable but multistep: with a flux that jumps between samples its energy
///    increment lags (it is exact only for smooth inputs).
enum class TimeScheme { tr_bdf2, crank_nicolson, bdf2, backward_euler };

/// Deep-bed mesh coarsening: far below the top the temperature varies slowly, so pairs of
/// equal intervals are merged (their middle node removed, its heat shared with its neighbours,
/// exactly conservative) while every interval stays <= grading * its depth below the top and no
/// interval starts above `min_depth_m`.
struct Coarsening {
  bool enabled = false;
  double min_depth_m = 2e-3;
  double grading = 0.25;
};

/// The bed column and its time stepper. Owns its state (temperatures and work buffers).
/// Finite volumes on nodes z_0 = 0 < z_1 < ... < z_n = l: node j owns the control volume
/// between the mid-points of its intervals, so sum(capacity_j T_j) is the heat content and
/// every one-step scheme conserves it exactly up to the flux in.
class HeatColumn {
 public:
  /// Column of `cells` cells of size `cell_m` at uniform `initial_temp_c`.
  HeatColumn(const PowderMaterial& material, double cell_m, int cells, double initial_temp_c,
             TimeScheme scheme = TimeScheme::tr_bdf2, int rannacher_half_steps = 2,
             Coarsening coarsening = {});

  /// Sets the node temperatures (one per node) and restarts the multistep history.
  void set_temperatures(const std::vector<double>& temps_c);
  /// Advances by dt with the top flux (W/m^2, positive heats) held over the step.
  void step(double dt_s, double top_flux_w_m2);
  /// Appends `cells` cells of size cell_m of fresh powder at `temp_c` on top (the old top node
  /// becomes interior; its half cell is completed with fresh powder, so its temperature
  /// becomes the capacity-weighted mean), then coarsens the deep bed if enabled. The
  /// multistep history is restarted.
  void add_layer(int cells, double temp_c);

  [[nodiscard]] double top_temp_c() const { return t_.back(); }
  [[nodiscard]] const std::vector<double>& temperatures_c() const { return t_; }
  /// Node positions z_j, m.
  [[nodiscard]] std::vector<double> node_positions_m() const;
  [[nodiscard]] double length_m() const { return length_m_; }
  [[nodiscard]] double cell_m() const { return cell_m_; }
  [[nodiscard]] int cells() const { return int(t_.size()) - 1; }
  /// Heat content per unit area relative to 0 C, J/m^2.
  [[nodiscard]] double heat_j_m2() const;

 private:
  void rebuild_mesh();   // capacities and conductances from intervals
  void coarsen();
  void apply_k(const std::vector<double>& x, std::vector<double>& y) const;  // y = K x
  void solve(double alpha, double beta, std::vector<double>& rhs);  // (alpha C + beta K) x = rhs
  void implicit_step(double dt_s, double flux, double theta);  // theta = 1 BE, 0.5 CN

  PowderMaterial material_;
  double cell_m_;
  TimeScheme scheme_;
  int rannacher_half_steps_;
  Coarsening coarsening_;
  double length_m_ = 0.0;
  std::vector<double> d_;    // interval sizes, d_[j] between node j and j+1
  std::vector<double> cap_;  // capacities / (rho Cp), m
  std::vector<double> g_;    // conductances / (rho Cp) = a^2 / d, m/s
  std::uint64_t mesh_version_ = 0;
  // LU factors of (alpha C + beta K), reused while the mesh and step are unchanged (between
  // layer additions), so each solve is two sweeps without divisions.
  struct Factor {
    double alpha = 0.0, beta = 0.0;
    std::uint64_t version = 0;
    std::vector<double> cprime, inv_m;
  };
  std::vector<Factor> factors_;
  std::vector<double> t_, t_prev_, rhs_, work_;
  bool have_prev_ = false;   // BDF2 history available
  bool fresh_start_ = true;  // CN: next step is a Rannacher start-up
};

/// One constant set point from a given layer on.
struct SetpointChange {
  int from_layer = 0;
  double setpoint_c = 0.0;
};

/// The largest build simulate_sls_build runs (validate() refuses larger ones before allocating).
inline constexpr int kMaxSlsLayers = 100000;
inline constexpr double kMaxSlsSteps = 2e8;

/// A full build: material, geometry, controller, actuator limits, disturbance, numerics.
struct SlsBuildConfig {
  PowderMaterial material{};
  double layer_thickness_m = 1e-4;  ///< l0
  int initial_layers = 50;          ///< l(0) = initial_layers * l0 (a 5 mm base bed)
  int layers_added = 100;           ///< layer additions after t = 0
  double layer_time_s = 14.0;       ///< time between additions
  double initial_temp_c = 172.0;
  double fresh_powder_temp_c = 150.0;
  double setpoint_c = 172.0;
  std::vector<SetpointChange> setpoint_changes{};
  // PI C(s) = kp (Ti s + 1)/(Ti s) on e = r - y, output = flux at the top: a
  // control::PidController with standard-form gains and the flux limits as output limits.
  double kp_w_m2k = 300.0;
  double ti_s = 3.0;
  double flux_min_w_m2 = 0.0;
  double flux_max_w_m2 = 5000.0;
  control::AntiWindup anti_windup = control::AntiWindup::back_calculation;
  double tracking_time_s = 2.0;  ///< Tt of back-calculation
  // Sintering laser: extra flux (layer average) during [start, start + duration) of each layer.
  double laser_flux_w_m2 = 250.0;
  double laser_start_s = 2.0;
  double laser_duration_s = 6.0;
  // Numerics.
  int cells_per_layer = 2;
  double dt_s = 0.25;
  Coarsening coarsening{true, 2e-3, 0.25};
  TimeScheme scheme = TimeScheme::tr_bdf2;
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

[[nodiscard]] const char* to_string(TimeScheme s);

}  // namespace amctl::thermal
