#pragma once
// Synthetic accelerometer records with a known resonance, for tests and for comparing with
// Klipper on a record whose answer is known.
#include <cstdint>
#include <string>
#include <vector>

namespace amctl::resonance {

/// A further mode of a synthetic record: the record holds gain * its absolute acceleration
/// (the same base-driven form, integrated beside the main mode) added to the main mode's.
struct SyntheticMode {
  double natural_freq_hz = 0.0;
  double damping_ratio = 0.0;
  double gain = 0.0;
};

/// A single mode (natural frequency f_n, damping ratio zeta) on `axis` driven by a linear
/// sine sweep of the base acceleration a(t) = A sin(2 pi (f0 t + rate t^2 / 2)) from f0 to f1
/// (A constant, or accel_per_hz f(t)).
/// The record is the absolute acceleration of the mass, -(2 zeta w x' + w^2 x) for the
/// relative motion x'' + 2 zeta w x' + w^2 x = -a(t) (integrated with RK4, 8 steps a sample),
/// plus 5 % of it on the other horizontal axis, gravity on z, and uniform noise from a
/// fixed-seed generator; values are written with 3 decimals and times with 6, as Klipper's
/// raw CSV (`#time,accel_x,accel_y,accel_z`) writes them.
struct SyntheticSweep {
  double natural_freq_hz = 42.0;
  double damping_ratio = 0.08;
  double f0_hz = 5.0;
  double f1_hz = 120.0;
  double rate_hz_s = 10.0;
  double accel_mm_s2 = 3000.0;
  /// When > 0 the amplitude follows the instantaneous frequency, accel_per_hz * f(t), as in
  /// Klipper's own test (TEST_RESONANCES' accel_per_hz), and accel_mm_s2 is not used.
  double accel_per_hz_mm_s2 = 0.0;
  double sample_rate_hz = 3200.0;
  double lead_s = 0.5;       ///< rest before and after the sweep
  double noise_mm_s2 = 50.0; ///< half width of the uniform noise
  char axis = 'x';
  std::uint64_t seed = 1;
  /// Modes beside the main one (which has gain 1): the response is 1 h_main + sum g_i h_i.
  std::vector<SyntheticMode> extra_modes;
};

/// The record as Klipper-raw CSV text.
[[nodiscard]] std::string synthetic_sweep_csv(const SyntheticSweep& s);

}  // namespace amctl::resonance
