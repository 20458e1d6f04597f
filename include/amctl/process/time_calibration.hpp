#pragma once
// Glue between measured print timings, the look-ahead planner (module plan) and the generic
// calibration: which machine limits are fitted, how they are written into a Machine, and the
// estimator callback that re-plans every timed file for a trial parameter vector.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/machine/machine.hpp"
#include "amctl/plan/file_limits.hpp"
#include "amctl/process/calibrate.hpp"
#include "amctl/process/csv.hpp"

namespace amctl::process {

/// One timed print (or one timed layer of it).
struct PrintTiming {
  std::string gcode_path;
  std::optional<long> layer;   ///< slicer layer index (0-based) for per-layer timings
  double duration_s = 0.0;
  std::uint64_t csv_line = 0;
};

/// Reads a CSV with a `gcode` column (paths relative to the CSV's directory unless absolute)
/// and one of duration_s / duration_min / duration_h; an optional `layer` column. Durations
/// must be > 0.
[[nodiscard]] std::vector<PrintTiming> read_print_timings(const CsvTable& table);

/// The G-code with every limit command (M201, M203, M204, M205, M566, SET_VELOCITY_LIMIT)
/// blanked, line numbers kept, so the limits being calibrated are not overridden by the file.
[[nodiscard]] std::string strip_limit_commands(std::string_view gcode);

/// Machine limits that can be calibrated:
///   accel         Klipper max_accel; Marlin/RRF print, travel and retract acceleration
///   scv           Klipper square_corner_velocity
///   jd            Marlin junction deviation
///   jerk          classic jerk of X and Y
///   max_velocity  Klipper max_velocity; Marlin max feedrate of X and Y
[[nodiscard]] std::vector<std::string> calibratable_limits();
/// The limits that matter for `m`'s junction policy: accel, (scv | jd | jerk), max_velocity.
[[nodiscard]] std::vector<std::string> default_limits_for(const machine::Machine& m);
[[nodiscard]] double get_limit(const machine::Machine& m, const std::string& name);
void set_limit(machine::Machine& m, const std::string& name, double value);
/// Start values from `m`, bounds wide enough for any printer.
[[nodiscard]] std::vector<CalibrationParameter> limit_parameters(
    const machine::Machine& m, const std::vector<std::string>& names);

/// An estimator over `timings` (files loaded once): for a parameter vector, sets the named
/// limits on a copy of `base` and returns the planner's motion time of each file (or of each
/// timed layer), the files' own limits commands kept, ignored or capped (`file_limits`, as
/// `amctl estimate --file-limits`).
[[nodiscard]] DurationEstimator planner_duration_estimator(const machine::Machine& base,
                                                           const std::vector<std::string>& names,
                                                           const std::vector<PrintTiming>& timings,
                                                           plan::FileLimits file_limits);

}  // namespace amctl::process
