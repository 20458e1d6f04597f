#pragma once
// JSON forms of the plan module's reports: the one writer used by `amctl estimate --json`
// and by the bindings. Keys are part of amctl's stable interface (docs/planner.md).
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {

/// Why an unknown command was skipped, in words (a firmware code vs a printer macro).
[[nodiscard]] std::string explain_unknown_command(const std::string& name);

/// `amctl estimate --json`. compute_time_s is the wall-clock time of the run.
[[nodiscard]] Json to_json(const EstimateReport& report, const machine::Machine& machine,
                           double compute_time_s);

/// `amctl estimate A B ... --json`: {"machine", "files": [one `estimate --json` object per
/// file, or {"file", "error"}]}; a file without moves has "no_moves": true.
[[nodiscard]] Json to_json(const std::vector<EstimateRow>& rows, const machine::Machine& machine);
/// The file's limits commands and the policy applied (`file_limits` of the estimate's JSON).
[[nodiscard]] Json to_json(const FileLimitsReport& file_limits);

/// One velocity profile's figures in `estimate --compare-profiles`.
struct ProfileRun {
  machine::VelocityProfile profile = machine::VelocityProfile::trapezoid;
  double jerk_limit_mm_s3 = 0.0;  ///< scurve7 only (0 otherwise)
  double total_time_s = 0.0;
  double peak_accel_mm_s2 = 0.0;  ///< ProfilePeaks
  double peak_jerk_mm_s3 = 0.0;   ///< ProfilePeaks; +inf for the trapezoid
  std::uint64_t moves = 0;
};

/// Plans the file with trapezoid, bezier5 and scurve7 (jerk: machine.max_jerk_mm_s3), one
/// streaming pass each (over one rewindable input: standard input and FIFOs are read once).
[[nodiscard]] std::vector<ProfileRun> compare_profiles(const GcodeInput& input,
                                                       const machine::Machine& machine,
                                                       bool strict = true);

/// `amctl estimate --compare-profiles --json`.
[[nodiscard]] Json to_json(const std::vector<ProfileRun>& runs, const std::string& file,
                           const machine::Machine& machine);

}  // namespace amctl::plan
