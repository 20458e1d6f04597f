#pragma once
// Calibrating a time estimator from measured print durations: find the parameters (e.g. the
// machine's acceleration, square corner velocity and maximum speed) that make the estimator
// reproduce the measured durations best, by Levenberg-Marquardt on the logarithms of the
// parameters (they are positive and span decades) with a finite-difference Jacobian. The
// estimator is any callback, so the same code calibrates the look-ahead planner (module plan)
// and is tested on synthetic estimators with known answers.
#include <functional>
#include <string>
#include <vector>

namespace amctl::process {

struct CalibrationParameter {
  std::string name;
  double initial = 1.0;  ///< > 0
  double lower = 1e-9;   ///< > 0
  double upper = 1e12;
};

/// Returns the predicted duration [s] of every sample for one parameter vector.
using DurationEstimator = std::function<std::vector<double>(const std::vector<double>& params)>;

struct CalibrationOptions {
  /// Minimise relative residuals (m - p)/m (true) or absolute ones in seconds.
  bool relative = true;
  int max_iterations = 50;
  double tolerance = 1e-10;          ///< on the relative decrease of the cost
  double log_step = 1e-3;            ///< central-difference step in log(parameter)
  double confidence = 0.95;
};

struct CalibrationResult {
  std::vector<std::string> names;
  std::vector<double> values;
  std::vector<double> std_errors;      ///< delta method from the log-space covariance (NaN if dof = 0)
  std::vector<double> ci_lo, ci_hi;    ///< exp(log p -/+ t se_log): positive, asymmetric
  std::vector<bool> identifiable;      ///< false: no effect on any sample, held at its start
  std::vector<std::vector<double>> correlation;
  std::vector<double> measured_s, predicted_s, residual_s, relative_residual;
  double rms_s = 0.0;
  double rms_relative = 0.0;
  int iterations = 0;
  int evaluations = 0;
  bool converged = false;
  std::size_t dof = 0;
};

/// Throws amctl::Error when samples are fewer than parameters, a measurement is not > 0,
/// a start value lies outside its bounds, or no parameter changes any prediction.
[[nodiscard]] CalibrationResult calibrate_durations(const DurationEstimator& estimator,
                                                    const std::vector<double>& measured_s,
                                                    const std::vector<CalibrationParameter>& params,
                                                    const CalibrationOptions& options = {});

}  // namespace amctl::process
