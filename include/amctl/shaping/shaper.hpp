#pragma once
// Input shapers: a train of impulses (amplitude A_i at time T_i) that, convolved with the
// commanded motion, cancels the vibration of a mode of natural frequency f and damping ratio
// zeta. The definitions are those of Klipper's klippy/extras/shaper_defs.py (ZV, MZV and its
// generalised mzv(n=..,t=..) form, ZVD, EI, 2HUMP_EI, 3HUMP_EI) and of Marlin's
// ft_motion/shaping.cpp (ZVDD, ZVDDD); docs/shaping.md derives each one and names the
// commits they were checked against.
//
// Amplitudes and times are kept as the definitions give them: the amplitudes are not
// normalised (ZV is [1, K]; Klipper divides by their sum where it uses them) and the first
// impulse is at t = 0. Notation used below:
//   d = sqrt(1 - zeta^2),  K = exp(-zeta pi / d),  t_d = 1 / (f d)  (the damped period).
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace amctl::shaping {

/// Whose definition of a shaper type.
enum class Firmware {
  klipper,  ///< klippy/extras/shaper_defs.py
  marlin,   ///< FT_MOTION, ft_motion/shaping.cpp (set_axis_shaping_A / _N)
};

/// Marlin's FT_MOTION trajectory rate FTM_FS [Hz] (its default): the impulse times are
/// rounded to this grid (shaping.cpp rounds the echo delay to whole samples).
inline constexpr double kMarlinFtmSampleRateHz = 1000.0;

/// "klipper" or "marlin" (without regard to case). Throws amctl::Error naming `firmware`, the
/// text and the valid names.
[[nodiscard]] Firmware parse_firmware(std::string_view text);
[[nodiscard]] std::string_view to_string(Firmware firmware);

enum class ShaperType {
  zv,             ///< A = [1, K], T = [0, t_d/2]
  mzv,            ///< Klipper's mzv(n, t): n impulses over t damped periods (default n=3, t=0.75)
  zvd,            ///< A = [1, 2K, K^2], T = [0, t_d/2, t_d]
  ei,             ///< extra-insensitive, Klipper's polynomial fit in zeta and v_tol
  two_hump_ei,    ///< "2hump_ei", Klipper's polynomial fit in zeta (times in 1/f)
  three_hump_ei,  ///< "3hump_ei", Klipper's polynomial fit in zeta (times in 1/f)
  zvdd,           ///< Marlin: A = [1, 3K, 3K^2, K^3], T = i t_d/2
  zvddd,          ///< Marlin: A = [1, 4K, 6K^2, 4K^3, K^4], T = i t_d/2
};

/// A shaper type with its parameters, as written in a Klipper config or on the command line:
/// "zv", "MZV", "mzv(n=4, t=0.9)", "mzv(4, 0.9)", "mzv(n=5, tau=1.2)", "ei(v_tol=0.1)",
/// "2hump_ei", "zvdd". Names are matched without regard to case.
struct ShaperSpec {
  ShaperType type = ShaperType::mzv;
  /// mzv: number of impulses (>= 3).
  int mzv_n = 3;
  /// mzv: time of the last impulse in damped periods t_d; must be below (n - 1) / 2.
  double mzv_t = 0.75;
  /// ei (and, for Marlin, 2hump_ei and 3hump_ei: its M493 Q): the vibration tolerance the
  /// shaper is made insensitive to (fraction). Klipper's 2hump_ei/3hump_ei are fixed at 0.05.
  double ei_v_tol = 0.05;
  /// Whose definition (parse_shaper_spec without a firmware: Klipper's for Klipper's types,
  /// Marlin's for zvdd and zvddd, which only Marlin has).
  Firmware firmware = Firmware::klipper;
  /// Marlin: the impulse times are whole samples of this rate (FTM_FS), as Marlin rounds
  /// them; 0: the exact times of the definition. Ignored for Klipper.
  double sample_rate_hz = 0.0;
};

/// The names parse_shaper_spec accepts (lower case, without parameters), Klipper's first.
[[nodiscard]] std::span<const std::string_view> shaper_type_names();
/// The names `firmware` offers: Klipper zv, mzv, zvd, ei, 2hump_ei, 3hump_ei; Marlin zv, zvd,
/// zvdd, zvddd, ei, 2hump_ei (its 2HEI), 3hump_ei (3HEI), mzv.
[[nodiscard]] std::vector<std::string_view> shaper_type_names(Firmware firmware);
/// The firmware whose definition a type means when none is named: Marlin for zvdd and
/// zvddd, Klipper for the others.
[[nodiscard]] Firmware default_firmware(ShaperType type);

/// Parses a shaper type (see ShaperSpec). Throws amctl::Error naming `type`, the text and
/// the valid names for an unknown type, and the parameter for a bad or out-of-range one
/// (Klipper's own limits for mzv: n >= 3, t < (n - 1)/2; tau= gives t = tau (n-1)/(n+2tau-2);
/// and amctl's n <= 64. Klipper's motion code applies at most 10 impulses.)
[[nodiscard]] ShaperSpec parse_shaper_spec(std::string_view text);
/// Same, in `firmware`'s definitions: throws amctl::Error naming the type and what each
/// firmware accepts when `firmware` lacks the type or the parameter (Marlin has no mzv(n, t);
/// Klipper no zvdd, zvddd, nor a v_tol for 2hump_ei / 3hump_ei). Marlin's times are rounded
/// to sample_rate_hz (default kMarlinFtmSampleRateHz; 0: exact).
[[nodiscard]] ShaperSpec parse_shaper_spec(std::string_view text, Firmware firmware,
                                           double sample_rate_hz = kMarlinFtmSampleRateHz);

/// The canonical spelling: "zv", "mzv", "mzv(n=4, t=0.9)", "2hump_ei", "ei(v_tol=0.1)", ...
/// (parameters are written only when they differ from the defaults; not the firmware).
[[nodiscard]] std::string to_string(const ShaperSpec& spec);

/// Klipper's limit on the damping ratio a shaper is configured with (input_shaper.py via
/// shaper_defs.INPUT_SHAPERS: 0.99 for zv, mzv, zvd; 0.4 ei; 0.3 2hump_ei; 0.2 3hump_ei);
/// nothing for Marlin's types. The polynomial fits (ei, 2hump_ei, 3hump_ei) were made for
/// damping ratios up to these values only.
[[nodiscard]] std::optional<double> klipper_max_damping_ratio(ShaperType type);

/// One shaper at one frequency and damping ratio.
struct Shaper {
  ShaperSpec spec;
  double freq_hz = 0.0;
  double damping_ratio = 0.0;
  std::vector<double> amplitudes;  ///< as the definition gives them (not normalised)
  std::vector<double> times_s;     ///< increasing, times_s[0] = 0

  /// T_last - T_0 [s].
  [[nodiscard]] double duration_s() const;
  /// sum of the amplitudes (the shaper's static gain before normalisation).
  [[nodiscard]] double amplitude_sum() const;
  /// Amplitudes divided by their sum (what is applied to motion).
  [[nodiscard]] std::vector<double> normalized_amplitudes() const;
  /// The amplitude-weighted mean time sum(A_i T_i) / sum(A_i) [s]: the delay Klipper
  /// removes so that a shaped constant-velocity motion equals the unshaped one.
  [[nodiscard]] double time_shift_s() const;
};

/// Builds the shaper. Throws amctl::Error naming the parameter when freq_hz is not a finite
/// number > 0 or damping_ratio is outside [0, 1), and when an mzv(n, t) has no non-negative
/// solution (Klipper's "Negative-valued shaper").
[[nodiscard]] Shaper make_shaper(const ShaperSpec& spec, double freq_hz, double damping_ratio);
/// Same with the type as text (parse_shaper_spec).
[[nodiscard]] Shaper make_shaper(std::string_view type, double freq_hz, double damping_ratio);

/// Throws amctl::Error naming `what` unless 0 <= zeta < 1 (finite).
void require_damping_ratio(std::string_view what, double zeta);

}  // namespace amctl::shaping
