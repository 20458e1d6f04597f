#pragma once
// Helpers shared by the interpreter's source files (interpreter.cpp, annotations.cpp,
// arcs.cpp, extended.cpp, retraction.cpp, command_table.cpp). Internal to the gcode module.
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "amctl/core/quantity.hpp"

namespace amctl::gcode::detail {

/// "M220 S must be a factor in [0.001, 1e+06] %, got 1e-300" (the message of a G-code word
/// outside its physical range; PhysicalRange, core/quantity.hpp).
inline std::string out_of_range(std::string_view what, const PhysicalRange& r, double v) {
  return fmt::format("{} must be {}, got {}", what, describe(r), v);
}
/// A speed given in mm/min (F words): the speed range times 60.
inline constexpr PhysicalRange kFeedRange{"feedrate", "mm/min", kSpeedRange.min * 60.0, kSpeedRange.max * 60.0};

// Largest accepted machine coordinate [mm] (1000 km): anything beyond is an overflow or a
// typo, never a print, and squares of distances must stay far from double overflow.
inline constexpr double kMaxCoordinate_mm = 1e9;
// Largest accepted speed/acceleration/jerk limit (mm/s, mm/min, mm/s^2 alike): squared speeds
// and accel * distance products then stay finite.
inline constexpr double kMaxLimit = 1e9;

inline char upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c; }

inline bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (upper(a[i]) != upper(b[i])) return false;
  }
  return true;
}

inline bool starts_with_ci(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && iequals(s.substr(0, prefix.size()), prefix);
}

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

inline std::string to_upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = upper(c);
  return out;
}

/// Thrown by the interpreter when a line's parameters are malformed in lenient mode; caught
/// by Interpreter::feed(), which counts the line as skipped. Never leaves the gcode module.
struct SkipMalformedLine {};

}  // namespace amctl::gcode::detail
