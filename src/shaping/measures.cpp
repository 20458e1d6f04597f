// Klipper's smoothing, max-accel and remaining-vibration estimates (measures.hpp).
#include "amctl/shaping/measures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "amctl/core/error.hpp"

namespace amctl::shaping {

double smoothing_mm(const Shaper& shaper, double accel_mm_s2, double scv_mm_s) {
  const auto& A = shaper.amplitudes;
  const auto& T = shaper.times_s;
  const double half_accel = 0.5 * accel_mm_s2;
  const double inv_sum = 1.0 / shaper.amplitude_sum();
  double ts = 0.0;
  for (std::size_t i = 0; i < A.size(); ++i) ts += A[i] * T[i];
  ts *= inv_sum;
  // A 90-degree corner: one axis stops while the other starts at scv; the offset is that of
  // the axis still moving after the centre t_s. A 180-degree turn: every impulse contributes.
  double offset_90 = 0.0;
  double offset_180 = 0.0;
  for (std::size_t i = 0; i < A.size(); ++i) {
    const double dt = T[i] - ts;
    if (T[i] >= ts) offset_90 += A[i] * (scv_mm_s + half_accel * dt) * dt;
    offset_180 += A[i] * half_accel * dt * dt;
  }
  offset_90 *= inv_sum * std::numbers::sqrt2;
  offset_180 *= inv_sum;
  return std::max(offset_90, offset_180);
}

double max_accel_mm_s2(const Shaper& shaper, double scv_mm_s, double target_smoothing_mm) {
  const auto ok = [&](double accel) {
    return smoothing_mm(shaper, accel, scv_mm_s) <= target_smoothing_mm;
  };
  // Klipper's _bisect, step for step, so that the answer is the same double.
  if (!ok(1e-9)) return 0.0;
  double left = 1.0;
  double right = 1.0;
  while (!ok(left)) {
    right = left;
    left *= 0.5;
  }
  if (right == left) {
    while (ok(right)) {
      right *= 2.0;
      // A shaper that never smooths (zero duration) has no finite limit.
      if (!std::isfinite(right)) return std::numeric_limits<double>::infinity();
    }
  }
  while (right - left > 1e-8) {
    const double middle = (left + right) * 0.5;
    // Above about 1e8 mm/s^2 no double lies between left and right while they are still 1e-8
    // apart (Klipper's loop would not end either): the answer is as close as doubles get.
    if (middle == left || middle == right) break;
    if (ok(middle)) {
      left = middle;
    } else {
      right = middle;
    }
  }
  return left;
}

double remaining_vibration(const Shaper& shaper, double freq_hz, double test_damping_ratio) {
  const auto& A = shaper.amplitudes;
  const auto& T = shaper.times_s;
  const double omega = 2.0 * std::numbers::pi * freq_hz;
  const double damping = test_damping_ratio * omega;
  const double omega_d = omega * std::sqrt(1.0 - test_damping_ratio * test_damping_ratio);
  const double t_last = T.back();
  double S = 0.0;
  double C = 0.0;
  for (std::size_t i = 0; i < A.size(); ++i) {
    const double W = A[i] * std::exp(-damping * (t_last - T[i]));
    S += W * std::sin(omega_d * T[i]);
    C += W * std::cos(omega_d * T[i]);
  }
  return std::sqrt(S * S + C * C) * (1.0 / shaper.amplitude_sum());
}

VibrationCurve vibration_curve(const Shaper& shaper, std::span<const double> freqs_hz,
                               double test_damping_ratio) {
  require_damping_ratio("test_damping_ratio", test_damping_ratio);
  VibrationCurve c;
  c.test_damping_ratio = test_damping_ratio;
  c.freqs_hz.assign(freqs_hz.begin(), freqs_hz.end());
  c.remaining_fraction.reserve(freqs_hz.size());
  for (double f : freqs_hz) {
    require_positive("residual_at_hz", f);
    c.remaining_fraction.push_back(remaining_vibration(shaper, f, test_damping_ratio));
  }
  return c;
}

}  // namespace amctl::shaping
