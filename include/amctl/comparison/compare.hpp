#pragma once
// `amctl compare` (issue 10): every feedforward compensation method and the input shapers on
// one file, with the plant equal to the model and with the plant's natural frequency off by
// given percentages, in one table (docs/compensation.md, "Comparison").
//
// Each compensation row is compensation::compensate_file with the model (F, Z) and the plant
// (F (1 + offset/100), Z): the same numbers `amctl compensate --plant-natural-frequency-hz`
// gives. Each shaper row is simulation::simulate_shaped_print of the plant with the shaper at
// the model's F and Z. The uncompensated row of an offset is dynamics::simulate_print of the
// plant: the contour error `amctl simulate` reports. Every row carries the max contour error
// (distance of the simulated nozzle to the planned path), the one metric all rows have.
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::comparison {

struct ComparisonOptions {
  /// Compensation methods (invert, fbf, lpfbf, rfbf, collocation) and shapers (zv, mzv, ei),
  /// in table order.
  std::vector<std::string> methods = {"invert", "fbf", "lpfbf", "rfbf", "collocation", "zv", "mzv", "ei"};
  /// Bound on the compensation commands' acceleration [mm/s^2] (+inf: none): collocation
  /// enforces it, the other methods' rows say "base_accel_limit_exceeded" when they break it.
  double max_base_accel_mm_s2 = std::numeric_limits<double>::infinity();
  /// Plant natural frequency off the model's by these percentages (> -100).
  std::vector<double> plant_offsets_pct = {-20.0, -10.0, 0.0, 10.0, 20.0};
  double natural_frequency_hz = 0.0;  ///< model (and shaper) natural frequency [Hz]
  double damping_ratio = 0.1;         ///< model (and shaper) damping ratio
  double sample_rate_hz = 1000.0;     ///< command step and simulation output rate [Hz]
  /// Only the moves of this layer (plan::PlannedMove::layer), every row on that move span:
  /// compensation::compensate on the span, the uncompensated run through
  /// dynamics::StreamingSimulation and the shaped runs through
  /// simulation::ShapedStreamingSimulation on the same span (starting at rest at its first
  /// move). Unset: the whole file through the file-level runs named above.
  std::optional<int> layer;
};


/// Throws amctl::Error naming the parameter (--methods, --plant-offsets, --layer (no moves),
/// --natural-frequency-hz, --damping-ratio) for an unknown or repeated method, an offset
/// <= -100 % or not finite, a frequency <= 0, a damping ratio < 0 (shapers: >= 1).
void validate(const ComparisonOptions& options);

struct ComparisonRow {
  std::string method;  ///< "uncompensated", a compensation method or a shaper type
  std::string kind;    ///< "uncompensated" | "compensation" | "shaper"
  double plant_offset_pct = 0.0;
  double plant_natural_frequency_hz = 0.0;
  std::string status = "ok";  ///< compensation: its status (invert may be unbounded)
  double max_contour_error_mm = 0.0;
  /// NaN (JSON null) where the row's run does not give it: tracking error for shapers and
  /// the uncompensated row (its contour error is the meter's), RMS contour and residual
  /// vibration for compensation.
  double rms_contour_error_mm = 0.0;
  double max_tracking_error_mm = 0.0;
  double rms_tracking_error_mm = 0.0;
  double max_residual_vibration_mm = 0.0;
  double smoothing_mm = 0.0;  ///< shapers: max distance of the shaped command from the plan
  double lead_in_s = 0.0;     ///< compensation: command time before the first move
  /// Compensation: peak |command''| (+inf, JSON null, when unbounded); shapers and
  /// uncompensated: the plan's peak ramp acceleration (a shaper's command, a weighted sum of
  /// delayed copies of the plan, accelerates no more than it).
  double peak_command_accel_mm_s2 = 0.0;
  double motion_time_s = 0.0;
  double compute_time_s = 0.0;  ///< shapers: the run with and without the shaper
  double real_time_factor = 0.0;
};

struct ComparisonResult {
  std::string file;
  double natural_frequency_hz = 0.0;
  double damping_ratio = 0.0;
  double sample_rate_hz = 0.0;
  double max_base_accel_mm_s2 = std::numeric_limits<double>::infinity();  ///< the bound given
  std::optional<int> layer;
  /// Per offset (in the given order): the uncompensated row, then every method in order.
  std::vector<ComparisonRow> rows;
};

/// Runs the study. Throws amctl::Error as validate() and as the runs it makes.
[[nodiscard]] ComparisonResult compare_file(const plan::GcodeInput& input, const machine::Machine& machine,
                                            const ComparisonOptions& options);

/// {"file", "layer" (null: all), "model": {natural_frequency_hz, damping_ratio, sample_rate_hz},
/// "rows": [...]};
/// non-finite numbers are null.
[[nodiscard]] Json to_json(const ComparisonResult& result);

}  // namespace amctl::comparison
