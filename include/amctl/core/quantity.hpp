#pragma once
// Physical ranges: what each kind of quantity may be in amctl, in its unit (docs/machine.md,
// "Physical ranges"). A value outside is bad input (amctl::Error naming where it is), caught
// where it is read (a G-code word, a machine key, a flag), so that no later computation sees
// a speed of 1e-300 mm/s (an infinite print time), an acceleration that squares to zero or a
// sample rate no machine could simulate. The same ranges hold in the CLI, Python and the
// fleet, which all read through the same code.
#include <optional>
#include <string>
#include <string_view>

namespace amctl {

struct PhysicalRange {
  std::string_view quantity;  ///< "speed"
  std::string_view unit;      ///< "mm/s"
  double min = 0.0;           ///< smallest value > 0 accepted (0 itself only where a key says so)
  double max = 0.0;
};

/// 1 um/s (F0.06) to 1 km/s: slower than any print move, faster than any machine.
inline constexpr PhysicalRange kSpeedRange{"speed", "mm/s", 1e-3, 1e6};
/// 1 um/s^2 to 1e9 mm/s^2 (100 000 g).
inline constexpr PhysicalRange kAccelRange{"acceleration", "mm/s^2", 1e-3, 1e9};
/// Jerk of a jerk-limited profile.
inline constexpr PhysicalRange kJerkRange{"jerk", "mm/s^3", 1e-3, 1e15};
/// M220 / M221 factors: 0.001 % to 10^6 %.
inline constexpr PhysicalRange kPercentRange{"factor", "%", 1e-3, 1e6};
/// A dwell or pause: up to 10^7 s (116 days).
inline constexpr PhysicalRange kDurationRange{"duration", "s", 0.0, 1e7};
/// A length of the machine (a nozzle, a resolution, a retraction): 1 nm to 1000 km.
inline constexpr PhysicalRange kLengthRange{"length", "mm", 1e-6, 1e9};
/// A mechanical frequency (a resonance, a shaper).
inline constexpr PhysicalRange kFrequencyRange{"frequency", "Hz", 1e-3, 1e6};
/// A simulation's or a command's sample rate: 1 Hz to 1 MHz.
inline constexpr PhysicalRange kSampleRateRange{"sample rate", "Hz", 1.0, 1e6};

/// The range of a machine key's unit ("mm/s", "mm/s^2", "mm/s^3", "mm"), if it has one.
[[nodiscard]] std::optional<PhysicalRange> range_for_unit(std::string_view unit);
/// finite and min <= v <= max.
[[nodiscard]] bool in_range(const PhysicalRange& r, double v);
/// "a speed in [0.001, 1e+06] mm/s".
[[nodiscard]] std::string describe(const PhysicalRange& r);
/// Throws amctl::Error "WHAT must be a speed in [0.001, 1e+06] mm/s, got V" unless in_range.
void require_in_range(std::string_view what, const PhysicalRange& r, double v);

}  // namespace amctl
