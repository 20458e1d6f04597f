#pragma once
// One shaper with Klipper's figures for it: what `amctl shaper show` prints (and the
// bindings return). The JSON keys are an interface (acceptance checks read them):
//   type, freq_hz, damping_ratio, amplitudes, times_s, duration_s, time_shift_s,
//   smoothing_mm, smoothing_accel_mm_s2, scv_mm_s, max_accel_mm_s2, target_smoothing_mm,
//   test_damping_ratio, residual_at_hz, residual_vibration, klipper_max_damping_ratio,
//   firmware, sample_rate_hz, residual_at_design, compared_with.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::shaping {

struct ShaperReportOptions {
  std::string type = "mzv";  ///< parse_shaper_spec
  double freq_hz = 0.0;
  double damping_ratio = 0.1;  ///< Klipper's DEFAULT_DAMPING_RATIO
  /// Frequencies at which to report the remaining vibration; empty: the shaper frequency.
  std::vector<double> residual_at_hz;
  /// Damping ratio of the vibrating mode for the residual; unset: damping_ratio.
  std::optional<double> test_damping_ratio;
  double smoothing_accel_mm_s2 = kKlipperSmoothingAccelMmS2;
  double scv_mm_s = kKlipperSquareCornerVelocityMmS;
  double target_smoothing_mm = kKlipperTargetSmoothingMm;
  /// Whose definition; unset: the type's own (parse_shaper_spec without a firmware).
  std::optional<Firmware> firmware;
  /// Marlin: impulse times on this grid (FTM_FS); 0: the exact times.
  double marlin_sample_rate_hz = kMarlinFtmSampleRateHz;
};

/// The same type as the other firmware defines it, at the same frequency and damping ratio,
/// and how far the two are apart.
struct FirmwareComparison {
  Shaper shaper;                        ///< the other firmware's
  double residual_at_design = 0.0;      ///< the other's remaining vibration at freq_hz, damping_ratio
  double max_amplitude_difference = 0.0;  ///< of the normalised amplitudes (NaN: counts differ)
  double max_time_difference_s = 0.0;   ///< of the times (NaN: counts differ)
  [[nodiscard]] bool same() const { return max_amplitude_difference <= 1e-12 && max_time_difference_s <= 1e-12; }
};

struct ShaperReport {
  Shaper shaper;
  double smoothing_accel_mm_s2 = 0.0;
  double scv_mm_s = 0.0;
  double smoothing_mm = 0.0;      ///< at smoothing_accel_mm_s2 and scv_mm_s
  double target_smoothing_mm = 0.0;
  double max_accel_mm_s2 = 0.0;   ///< at scv_mm_s for target_smoothing_mm
  VibrationCurve residual;        ///< at the asked frequencies
  std::optional<double> klipper_max_damping_ratio;
  /// Remaining vibration of a mode at the shaper's own frequency and damping ratio.
  double residual_at_design = 0.0;
  /// Marlin on its sample grid: the same with the exact times of its definition.
  std::optional<double> residual_at_design_exact_times;
  /// The other firmware's definition of the type, when it has one.
  std::optional<FirmwareComparison> compared_with;
};

/// Builds the shaper and its figures. Throws amctl::Error naming the parameter on bad input
/// (type, freq_hz, damping_ratio, residual_at_hz, test_damping_ratio).
[[nodiscard]] ShaperReport shaper_report(const ShaperReportOptions& options);
/// The checks of `amctl shaper show` and amctl.shaper_show, one set for both: freq_hz and
/// residual_at_hz frequencies (core/quantity.hpp), damping_ratio and test_damping_ratio in
/// [0, 1), marlin_sample_rate_hz 0 or a sample rate, the type, and a Marlin shaper whose first
/// echo falls on its trajectory grid. Throws amctl::Error "NAME: ..." where NAME is `name` of
/// the parameter's Python keyword ("freq_hz" -> "--freq-hz" on the command line).
void check_report_options(const ShaperReportOptions& options,
                          const std::function<std::string(std::string_view)>& name);

/// The report as one JSON object (keys above; every double via json_number).
[[nodiscard]] Json to_json(const ShaperReport& report);

/// The report as a readable table (the impulses, then the figures).
[[nodiscard]] std::string to_text(const ShaperReport& report);

}  // namespace amctl::shaping
