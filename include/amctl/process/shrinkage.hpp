#pragma once
// Shrinkage compensation from measured test parts (seed 004, section 2).
//
// For a feature of nominal size h the measured error is modelled per range as
//     E = measured - nominal = A h + B                                   (seed eq. 1)
// and the scale factor that compensates the proportional part is
//     C = 1 / (1 + A)                                                     (seed eq. 2)
// because a part built at C*h comes out at (1 + A) C h = h (plus the offset B).
#include <optional>
#include <string>
#include <vector>

#include "amctl/process/csv.hpp"
#include "amctl/process/stats.hpp"

namespace amctl::process {

/// One measurement of one feature: nominal size and measured size, both in mm.
struct ShrinkSample {
  char axis = 'Z';          ///< 'X', 'Y' or 'Z'
  double nominal_mm = 0.0;
  double measured_mm = 0.0;
  std::uint64_t line = 0;   ///< CSV line (for messages), 0 if unknown
};

/// Reads samples from a CSV whose header contains nominal_<u> and measured_<u> (u = mm, um
/// or in; both columns must use the same unit; values are converted to mm), optionally an
/// `axis` column (X, Y, Z; default Z). Other columns are ignored. Rejects negative or zero
/// nominal values, negative measurements, mismatched units, and files without data.
[[nodiscard]] std::vector<ShrinkSample> read_shrink_samples(const CsvTable& table);

/// How ranges are chosen.
struct ShrinkFitOptions {
  /// Fit the mean of repeated measurements at each nominal value (the seed's procedure)
  /// instead of every measurement.
  bool average_repeats = false;
  /// User breakpoints in mm (strictly increasing, inside the data). A sample with
  /// nominal <= b belongs to the range below b (the seed's "0-10 mm" includes 10).
  std::vector<double> breaks_mm;
  /// Number of ranges to find from the data when breaks_mm is empty: 1 = single line;
  /// 0 = choose 1..max_auto_ranges by the Bayesian information criterion.
  int ranges = 1;
  int max_auto_ranges = 3;
  /// Minimum points (after averaging) per range for automatic breakpoints.
  int min_points_per_range = 3;
  /// Two-sided confidence level for the intervals.
  double confidence = 0.95;
};

/// The fit of one range.
struct RangeFit {
  double lower_mm = 0.0;       ///< range bound (exclusive except for the first range); -inf-free: 0 for the first
  double upper_mm = 0.0;       ///< range bound (inclusive); +inf for the last range
  double data_min_mm = 0.0;    ///< smallest nominal in the range
  double data_max_mm = 0.0;    ///< largest nominal in the range
  LineFit line;                ///< E = slope h + intercept
  std::size_t levels = 0;      ///< distinct nominal values
  double factor = 1.0;         ///< C = 1 / (1 + slope)
  double factor_se = 0.0;      ///< delta method: slope_se / (1 + slope)^2
  double slope_ci_lo = 0.0, slope_ci_hi = 0.0;
  double factor_ci_lo = 0.0, factor_ci_hi = 0.0;  ///< exact transform of the slope interval
  /// Lack-of-fit F test when repeats exist (raw fit only): p-value, or nullopt.
  std::optional<double> lack_of_fit_p;
  double pure_error_sd_mm = 0.0;  ///< SD of repeats about their level means (0 if none)
};

struct AxisShrinkFit {
  char axis = 'Z';
  std::vector<RangeFit> ranges;
  double total_sse = 0.0;
  bool breaks_from_data = false;
  double confidence = 0.95;
};

/// Fits each axis present in `samples` separately (sorted X, Y, Z).
[[nodiscard]] std::vector<AxisShrinkFit> fit_shrinkage(const std::vector<ShrinkSample>& samples,
                                                       const ShrinkFitOptions& options);

/// Fits one axis (all samples must share it).
[[nodiscard]] AxisShrinkFit fit_shrinkage_axis(const std::vector<ShrinkSample>& samples,
                                               const ShrinkFitOptions& options);

/// Optimal segmentation of points sorted by x into `k` contiguous groups, each with its own
/// least-squares line, minimising the total SSE. Points sharing one x are never split. Returns
/// the index (into the sorted points) where each range after the first starts. Throws when
/// no segmentation satisfies `min_points` per segment and two distinct x per segment.
[[nodiscard]] std::vector<std::size_t> best_segmentation(const std::vector<double>& x_sorted,
                                                         const std::vector<double>& y,
                                                         int k, int min_points);

}  // namespace amctl::process
