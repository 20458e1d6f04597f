#pragma once
// FDM hotend and heated-bed temperature loops: a lumped plant in the structure of Marlin's
// MPC model, a PID with anti-windup, relay autotune in the manner of M303, and a model-based
// (MPC-like) controller whose model is identified from a heat-up curve as M306 T does.
// Our own implementation; Marlin's behaviour was read for reference (docs/thermal.md).
#include <cstdint>
#include <deque>
#include <functional>
#include <utility>
#include <string>
#include <vector>

#include "amctl/control/pid.hpp"

namespace amctl::thermal {

/// The "true" simulated heater: the block losing heat to ambient through a coefficient that
/// grows linearly with the part-cooling fan, a filament flow heat load, a first-order sensor lag
/// and a transport delay (which the MPC model does not have, so the identified model is not the
/// plant), optionally a heater core coupled to the block.
///
/// The defaults are an E3D V6 hotend with a 40 W cartridge as Prusa-Firmware's thermal model of
/// it (Firmware/thermal_model/e3d_v6.h, the model the MK3S checks its hotend against): heater
/// power 38 W, heat capacity 12.1 J/K, resistance to ambient 20.5 K/W with the fan off and
/// 10.1 K/W at full fan, a first-order filter of factor 0.065 per 0.27 s sample (time constant
/// 0.27 / -ln(1 - 0.065) = 4.02 s) and a response lag of 2.1 s. Its relay autotune gives about
/// Marlin-scale P 23, I 2.2, D 60, where published tunings of 40 W hotends lie around P 16-22,
/// I 1.1-1.6, D 56-110 (docs/thermal.md 4.3).
struct HeaterPlantParams {
  double heater_power_w = 38.0;
  double core_capacity_j_k = 0.0;       ///< heater cartridge core; 0 removes the node (lumped)
  double core_to_block_w_k = 2.0;       ///< used only with a core
  double block_capacity_j_k = 12.1;
  double ambient_c = 25.0;
  double loss_w_k = 1.0 / 20.5;         ///< to ambient, fan off
  double fan_extra_loss_w_k = 1.0 / 10.1 - 1.0 / 20.5;  ///< added at 100 % fan
  double filament_j_mm3k = 2.2e-3;      ///< rho c of the filament (PLA ~ 1.24e-3 g/mm^3 * 1.8 J/(g K))
  double sensor_time_constant_s = 4.02;
  /// Transport delay between the block and the reading [s]: the heat's way from the heater
  /// core through the block to the thermistor and the firmware's filtering (Prusa's thermal
  /// model of the E3D V6 calls it the response lag). 0: none.
  double sensor_delay_s = 2.1;
  double sensor_noise_k = 0.0;          ///< standard deviation of added white noise
  std::uint32_t noise_seed = 1;

  void validate() const;  ///< throws amctl::Error naming the bad field
  /// An E3D V6 with a 40 W cartridge (Prusa-Firmware's thermal model, the defaults above).
  [[nodiscard]] static HeaterPlantParams hotend();
  /// A 24 V 220 W 235 x 235 mm aluminium bed.
  [[nodiscard]] static HeaterPlantParams bed();
};

/// Plant state and integrator (RK4 on a fixed internal step).
class HeaterPlant {
 public:
  explicit HeaterPlant(const HeaterPlantParams& p);
  /// Advance by dt with duty in [0, 1], fan in [0, 1], volumetric flow in mm^3/s.
  void step(double dt_s, double duty, double fan, double flow_mm3_s);
  /// Sensor reading (lagged, with noise if configured).
  [[nodiscard]] double measured_c();
  [[nodiscard]] double block_c() const { return x_[1]; }
  /// The sensor's reading without noise: the sensor node sensor_delay_s ago.
  [[nodiscard]] double sensor_c() const { return delayed_sensor_c(); }
  [[nodiscard]] const HeaterPlantParams& params() const { return p_; }

 private:
  void deriv(const double* x, double duty, double fan, double flow, double* dx) const;
  HeaterPlantParams p_;
  double x_[3];  // core, block, sensor
  std::uint64_t rng_;
  double t_s_ = 0.0;
  /// (time, sensor node) samples over the last sensor_delay_s (empty without a delay).
  std::deque<std::pair<double, double>> history_;
  [[nodiscard]] double delayed_sensor_c() const;
};

/// The heater PID is a control::PidController on the duty fraction u in [0, 1] with the
/// error in K: gains kp [1/K], ki [1/(K s)], kd [s/K] (control::PidGains::parallel), and these
/// options: conditional integration, a 1 s filter on the measured temperature for the
/// derivative, full on/off beyond 10 K of error (Marlin PID_FUNCTIONAL_RANGE), Tt = 5 s should
/// back-calculation be chosen.
[[nodiscard]] control::PidOptions heater_pid_options();

enum class TuningRule { classic_zn, some_overshoot, no_overshoot };

/// Result of a relay autotune.
struct AutotuneResult {
  bool ok = false;
  std::string message;
  double ku = 0.0;  ///< ultimate gain, duty per K
  double tu_s = 0.0;
  double bias = 0.0, amplitude = 0.0;  ///< last relay bias and half swing (duty)
  double t_max_c = 0.0, t_min_c = 0.0;
  int cycles = 0;
  control::PidGains gains;  ///< parallel form, per K of error on the duty fraction
  double duration_s = 0.0;
};

struct AutotuneOptions {
  double target_c = 210.0;
  int cycles = 5;  ///< M303 C
  double fan = 0.0;
  TuningRule rule = TuningRule::classic_zn;
  double lockout_s = 5.0;   ///< minimum time between relay switches (M303 waits 5 s)
  double max_overshoot_k = 30.0;
  double timeout_s = 1200.0;
  double dt_s = 0.1;
};

/// Relay autotune like M303: a relay around the target with bias/amplitude adaptation after
/// each cycle; Ku = 4 d/(pi a) from the describing function, Tu the relay period.
[[nodiscard]] AutotuneResult relay_autotune(HeaterPlant plant, const AutotuneOptions& o);
/// The gain rule from (Ku [duty/K], Tu [s]), as parallel-form gains.
[[nodiscard]] control::PidGains tuning_rule(TuningRule r, double ku, double tu_s);

/// Model used by the MPC-like controller (the four/five numbers of M306).
struct MpcModel {
  double heater_power_w = 40.0;
  double block_capacity_j_k = 16.7;
  double sensor_responsiveness_1_s = 0.22;
  double loss_w_k = 0.068;
  double fan_extra_loss_w_k = 0.029;
  double filament_j_mm3k = 2.2e-3;
};

struct MpcOptions {
  double horizon_s = 2.0;          ///< plan to reach the target in this time (Marlin: 2 s)
  double smoothing = 0.5;          ///< share of the sensor residual applied per update
  double ambient_gain = 1.0;       ///< share of the residual that updates the ambient estimate
  double steady_state_k_s = 0.5;   ///< |block rate| below this counts as steady
  double min_ambient_change_k_s = 1.0;
};

/// Model-based controller in the manner of Marlin's MPC: a block/sensor model run in
/// parallel, corrected by the residual, the ambient estimate adapted near steady state (the
/// integral action), and power = C (target - block)/horizon + losses(fan, flow) at the
/// modelled block temperature.
class MpcController {
 public:
  MpcController(const MpcModel& m, const MpcOptions& o, double ambient_c);
  /// Duty for the next period; fan and flow are known to the firmware (feedforward).
  double update(double target_c, double measured_c, double fan, double flow_mm3_s, double dt_s);
  [[nodiscard]] double modelled_block_c() const { return block_; }
  [[nodiscard]] double ambient_estimate_c() const { return ambient_; }

 private:
  MpcModel m_;
  MpcOptions o_;
  double block_, sensor_, ambient_;
  double last_duty_ = 0.0;
  bool first_ = true;
};

struct IdentifyOptions {
  double ambient_c = 25.0;
  double target_c = 200.0;       ///< heat at full power until the sensor reaches this
  double sample_distance_s = 1.0;
  double settle_s = 60.0;        ///< hold time before measuring the loss power
  double measure_s = 60.0;
  double dt_s = 0.1;
  double filament_j_mm3k = 2.2e-3;  ///< not measured by M306 (user-provided H)
};

struct IdentifyResult {
  MpcModel model;
  double asymptotic_temp_c = 0.0;
  double block_responsiveness_1_s = 0.0;
  double loss_from_curve_w_k = 0.0;   ///< P/(asymptote - ambient) from the heat-up fit
  std::vector<double> sample_times_s, sample_temps_c;
};

/// M306 T-like identification on the plant: full-power heat-up with three equally spaced
/// samples (asymptote and time constant), sensor responsiveness from the apparent lag, then
/// loss measured from the holding power at the target with the fan off and at 100 %.
[[nodiscard]] IdentifyResult identify_mpc_model(HeaterPlant plant, const IdentifyOptions& o);

/// Scenario for the comparison on one simulated heater.
struct HeaterScenario {
  double target_c = 210.0;
  double duration_s = 360.0;
  double fan_on_at_s = 180.0;          ///< fan 0 -> 100 %
  double flow_start_s = 260.0;         ///< flow square wave starts
  double flow_high_mm3_s = 15.0;
  double flow_low_mm3_s = 2.0;
  double flow_half_period_s = 5.0;
  double flow_end_s = 320.0;
  double dt_s = 0.1;
  double band_k = 0.2;                 ///< recovery band
};

struct HeaterRunStats {
  std::string controller;
  double heat_up_time_s = 0.0;     ///< first time within 1 K below the target
  double overshoot_k = 0.0;        ///< max(T) - target before the fan step
  double fan_max_dev_k = 0.0;      ///< largest |e| after the fan step, before the flow
  double fan_recovery_s = 0.0;     ///< time after the fan step until |e| stays in the band
  double flow_ripple_k = 0.0;      ///< peak-to-peak of the (noise-free) sensor temperature
  double flow_rms_k = 0.0;
  double energy_j = 0.0;
  std::vector<double> t_s, measured_c, duty;  ///< trace (every step)
};

using HeaterController = std::function<double(double target, double measured, double fan,
                                              double flow, double dt)>;

/// Runs a scenario with a controller callback on a fresh plant.
[[nodiscard]] HeaterRunStats run_heater_scenario(const HeaterPlantParams& plant,
                                                 const HeaterScenario& sc,
                                                 const HeaterController& ctl,
                                                 const std::string& name);

[[nodiscard]] const char* to_string(TuningRule r);

}  // namespace amctl::thermal
