#pragma once
// The studies behind `amctl thermal ...`: each takes plain options, runs the models of this
// module and returns a result struct; the CSV formats and the JSON forms of the results live
// here too, so the command line only parses flags, calls one function and prints.
// JSON follows amctl::json_number (non-finite -> null); see docs/thermal.md, section 5.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/control/pid.hpp"
#include "amctl/core/json.hpp"
#include "amctl/thermal/fdm_heater.hpp"
#include "amctl/thermal/powder_bed_sim.hpp"
#include "amctl/thermal/powder_bed_tf.hpp"
#include "amctl/thermal/robust_margin.hpp"

namespace amctl::thermal {

// ------------------------------------------------------------------------- SLS PI margins

/// Inputs of the margin study (seed 002, section 4): a PI on the powder bed of depth l.
struct MarginStudyOptions {
  PowderMaterial material{1010.0, 1928.0, 0.28};
  double length_m = 1e-4;      ///< powder depth l
  double kp_w_m2k = 0.3;       ///< PI gain kp, W/(m^2 K)
  double ti_s = 0.5;           ///< PI integral time Ti, s
  int modes = 1;               ///< modal truncation order N
  double beta_1_s = -0.01;     ///< stability margin beta < 0 of the Hankel bound, 1/s
  int hamiltonian_modes = 60;  ///< modes M of the second margin on G
};

struct MarginStudy {
  MarginStudyOptions options;
  PowderBedTf plant;
  MarginReport report;
};

/// Validates the options (amctl::Error naming the bad one: the PI messages name kp and Ti)
/// and computes every figure of compute_margins().
[[nodiscard]] MarginStudy run_margin_study(const MarginStudyOptions& o);
/// The `sls-margins --json` object.
[[nodiscard]] Json to_json(const MarginStudy& s);
/// Bode data of G and G_N (401 points, 1e-4 to 1e6 rad/s):
/// omega_rad_s,mag_G_db,phase_G_deg,mag_GN_db,phase_GN_deg. Throws amctl::Error if the file
/// cannot be written.
void write_bode_csv(const std::string& path, const PowderBedTf& g, int modes);

// ------------------------------------------------------------------------------ SLS build

/// Where the build configuration comes from and what to override.
struct SlsRunOptions {
  std::string config_path;  ///< TOML (configs/sls_pa12.toml); empty: built-in PA12 values
  int layers_added = -1;    ///< >= 0 overrides the configuration
  std::optional<control::AntiWindup> anti_windup;  ///< overrides the configuration
  bool trace = true;        ///< keep the trace (false: csv_every = 0)
};

struct SlsRun {
  SlsBuildConfig config;
  SlsBuildResult result;
};

/// Loads the configuration, applies the overrides and runs simulate_sls_build().
[[nodiscard]] SlsRun run_sls_build(const SlsRunOptions& o);
/// The `sls --json` summary object.
[[nodiscard]] Json to_json(const SlsRun& r);
/// The trace: t_s,layers,depth_m,y_c,setpoint_c,flux_w_m2,disturbance_w_m2,integral_w_m2.
/// `inputs`: files the trace must never overwrite (the configuration).
void write_sls_trace_csv(const std::string& path, const SlsBuildResult& r,
                         const std::vector<std::string>& inputs = {});

// ------------------------------------------------------------------------ FDM heater loops

/// The heater-tuning study: relay autotune, M306-like identification, then the same
/// scenario under the tuned PID, the classic Ziegler-Nichols PID (if another rule was
/// chosen) and the identified MPC.
struct HeaterStudyOptions {
  bool bed = false;
  HeaterPlantParams plant;        ///< the simulated heater (noise-free; see sensor_noise_k)
  double target_c = 210.0;        ///< scenario and autotune target, C
  double sensor_noise_k = 0.0;    ///< standard deviation of the sensor noise, K
  int cycles = 5;                 ///< autotune cycles (M303 C), >= 3
  TuningRule rule = TuningRule::classic_zn;

  /// The default hotend (an E3D V6 with a 40 W cartridge, HeaterPlantParams::hotend) at 210 C,
  /// classic Ziegler-Nichols.
  [[nodiscard]] static HeaterStudyOptions hotend();
  /// A 220 W bed at 60 C, the no-overshoot rule, a longer scenario.
  [[nodiscard]] static HeaterStudyOptions bed_defaults();
};

struct HeaterStudy {
  HeaterStudyOptions options;
  HeaterScenario scenario;
  AutotuneResult autotune;
  IdentifyResult identified;
  std::vector<HeaterRunStats> runs;
};

/// Throws amctl::Error naming the bad option, or if the autotune fails.
[[nodiscard]] HeaterStudy run_heater_study(const HeaterStudyOptions& o);
/// The `hotend/bed --json` object.
[[nodiscard]] Json to_json(const HeaterStudy& s);
/// Traces of every run: t_s, then <controller>_c,<controller>_duty per run.
void write_heater_traces_csv(const std::string& path, const HeaterStudy& s);

/// "classic_zn", "some_overshoot" or "no_overshoot"; nullopt else.
[[nodiscard]] std::optional<TuningRule> tuning_rule_from_string(std::string_view name);

}  // namespace amctl::thermal
