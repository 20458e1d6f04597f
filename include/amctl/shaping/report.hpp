#pragma once
// One shaper with Klipper's figures for it: what `amctl shaper show` prints (and the
// bindings return). The JSON keys are an interface (acceptance checks read them):
//   type, freq_hz, damping_ratio, amplitudes, times_s, duration_s, time_shift_s,
//   smoothing_mm, smoothing_accel_mm_s2, scv_mm_s, max_accel_mm_s2, target_smoothing_mm,
//   test_damping_ratio, residual_at_hz, residual_vibration, klipper_max_damping_ratio.
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
};

/// Builds the shaper and its figures. Throws amctl::Error naming the parameter on bad input
/// (type, freq_hz, damping_ratio, residual_at_hz, test_damping_ratio).
[[nodiscard]] ShaperReport shaper_report(const ShaperReportOptions& options);

/// The report as one JSON object (keys above; every double via json_number).
[[nodiscard]] Json to_json(const ShaperReport& report);

/// The report as a readable table (the impulses, then the figures).
[[nodiscard]] std::string to_text(const ShaperReport& report);

}  // namespace amctl::shaping
