#pragma once
// What a shaper costs and what it leaves, as Klipper estimates them
// (klippy/extras/shaper_calibrate.py: _get_shaper_smoothing, find_shaper_max_accel / _bisect,
// _estimate_shaper). Every function uses the normalised amplitudes a_i = A_i / sum(A).
#include <span>
#include <vector>

#include "amctl/shaping/shaper.hpp"

namespace amctl::shaping {

/// Klipper's defaults for the smoothing figure it prints (accel 5000 mm/s^2, scv 5 mm/s) and
/// the smoothing its max-accel suggestion aims at.
inline constexpr double kKlipperSmoothingAccelMmS2 = 5000.0;
inline constexpr double kKlipperSquareCornerVelocityMmS = 5.0;
inline constexpr double kKlipperTargetSmoothingMm = 0.12;

/// Klipper's smoothing measure [mm]: how far the shaped path strays at a corner taken at
/// square corner velocity scv with acceleration accel. With t_s = sum a_i T_i:
///   offset_90  = sqrt(2) sum_{T_i >= t_s} a_i (scv + accel/2 (T_i - t_s)) (T_i - t_s)
///   offset_180 = sum_i a_i accel/2 (T_i - t_s)^2
///   smoothing  = max(offset_90, offset_180).
[[nodiscard]] double smoothing_mm(const Shaper& shaper, double accel_mm_s2, double scv_mm_s);

/// Klipper's suggested max_accel [mm/s^2]: the largest accel with
/// smoothing_mm(shaper, accel, scv) <= target, found with Klipper's bisection (start at 1,
/// halve or double to bracket, then bisect until the bracket is under 1e-8 mm/s^2; 0 when
/// even 1e-9 mm/s^2 smooths more than the target).
[[nodiscard]] double max_accel_mm_s2(const Shaper& shaper, double scv_mm_s,
                                     double target_smoothing_mm = kKlipperTargetSmoothingMm);

/// Klipper's estimate of the vibration left by the shaper on a mode of frequency f and
/// damping ratio zeta_test, as a fraction of the unshaped vibration (_estimate_shaper):
///   w = 2 pi f, w_d = w sqrt(1 - zeta_test^2), W_i = a_i exp(-zeta_test w (T_last - T_i)),
///   V = sqrt((sum W_i sin(w_d T_i))^2 + (sum W_i cos(w_d T_i))^2).
[[nodiscard]] double remaining_vibration(const Shaper& shaper, double freq_hz,
                                         double test_damping_ratio);

/// The vibration-remaining curve over frequency for one test damping ratio.
struct VibrationCurve {
  double test_damping_ratio = 0.0;
  std::vector<double> freqs_hz;
  std::vector<double> remaining_fraction;  ///< remaining_vibration at each frequency
};

/// remaining_vibration at each frequency. Throws amctl::Error naming the parameter when a
/// frequency is not a finite number > 0 or the test damping ratio is outside [0, 1).
[[nodiscard]] VibrationCurve vibration_curve(const Shaper& shaper,
                                             std::span<const double> freqs_hz,
                                             double test_damping_ratio);

}  // namespace amctl::shaping
