#pragma once
// Build-time studies behind `amctl estimate --mode empirical` and `amctl calibrate-time`:
// the empirical parameter file, the empirical estimate of one file, and the calibration of
// the empirical model or of the planner's machine limits from measured print durations.
//
// The empirical parameter file (written by `calibrate-time --mode empirical --save`, read
// by `--params`) is one JSON object, optionally wrapped as {"model": {...}} (the JSON that
// calibrate-time prints):
//   raster_speed_mm_s, contour_speed_mm_s, travel_speed_mm_s        numbers, > 0
//   link_widths_mm, link_speeds_mm_s                                 arrays of numbers
//   layer_change_s, retract_s, wipe_s, fixed_s                       numbers, >= 0
//   link_length_widths, filament_diameter_mm                         numbers (scan options)
// Keys left out keep the seed's values (EmpiricalTimeModel::fdm2000_seed()). Every error
// names file:line.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/process/calibrate.hpp"
#include "amctl/process/empirical_time.hpp"
#include "amctl/process/time_calibration.hpp"

namespace amctl::process {

struct EmpiricalParams {
  EmpiricalTimeModel model = EmpiricalTimeModel::fdm2000_seed();
  ScanOptions scan;  ///< link_widths_mm follows model.link_widths_mm
};

/// The seed's parameters, overridden by the file at `path` when it is not empty.
[[nodiscard]] EmpiricalParams read_empirical_params(const std::string& path);
[[nodiscard]] EmpiricalParams parse_empirical_params(const std::string& text,
                                                     const std::string& name);
[[nodiscard]] Json empirical_params_json(const EmpiricalTimeModel& model, const ScanOptions& scan);

struct EmpiricalEstimate {
  std::string file;
  /// The parameter file (`--params`, e.g. `calibrate-time --mode empirical --save`'s). Empty:
  /// the model runs on the process-planning study's FDM 2000 speeds (a 2000-era Stratasys
  /// machine, ~24 mm/s rasters), not on this printer's, and `caveat` says so in the output.
  std::string params_file;
  std::string caveat;
  EmpiricalParams params;
  GcodeTimeScan scan;
  double total_time_s = 0.0;
};

/// `amctl estimate FILE --mode empirical [--params P]`.
[[nodiscard]] EmpiricalEstimate estimate_empirical(const std::string& gcode_path,
                                                   const std::string& params_path);
[[nodiscard]] Json empirical_estimate_json(const EmpiricalEstimate& e);
[[nodiscard]] std::string empirical_estimate_text(const EmpiricalEstimate& e);

struct EmpiricalCalibrationRequest {
  std::string timings_csv;   ///< gcode,duration_s[,layer]
  std::string params_path;   ///< starting parameters ("" = the seed's)
  std::vector<std::string> fix;  ///< "name" or "name=value": held parameters
  bool separate_contour = false;
};

struct PlannerCalibrationRequest {
  std::string timings_csv;
  machine::Machine machine;
  std::vector<std::string> limits;  ///< empty: default_limits_for(machine)
  /// The files' own limits commands: kept as the firmware does (default, as `amctl estimate`),
  /// ignored (the fitted limits hold throughout) or capped at the fitted limits.
  plan::FileLimits file_limits = plan::FileLimits::keep;
  bool absolute = false;            ///< residuals in seconds instead of relative ones
};

/// A calibration of either kind: what `calibrate-time` prints and saves.
struct TimeCalibration {
  std::string file;
  std::vector<PrintTiming> timings;
  std::vector<double> measured_s;
  // Empirical mode.
  std::optional<EmpiricalFit> empirical;
  ScanOptions scan;
  // Planner mode.
  std::optional<CalibrationResult> planner;
  /// Planner mode: the policy, and the limits commands the files set (distinct files, planned
  /// once more with the calibrated machine).
  plan::FileLimits file_limits = plan::FileLimits::keep;
  std::uint64_t file_limit_commands = 0;
  std::size_t files_setting_limits = 0;
  std::size_t files = 0;
  std::vector<CalibrationParameter> start;
  machine::Machine calibrated;  ///< the machine with the fitted limits
};

[[nodiscard]] TimeCalibration calibrate_empirical_time(const EmpiricalCalibrationRequest& request);
[[nodiscard]] TimeCalibration calibrate_planner_time(const PlannerCalibrationRequest& request);
[[nodiscard]] Json time_calibration_json(const TimeCalibration& c);
[[nodiscard]] std::string time_calibration_text(const TimeCalibration& c);
/// What `--save` writes: the parameter file (empirical) or the machine's TOML (planner).
[[nodiscard]] std::string time_calibration_file(const TimeCalibration& c);

}  // namespace amctl::process
