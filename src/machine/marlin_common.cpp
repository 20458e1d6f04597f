#include "marlin_common.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "amctl/machine/loader.hpp"

namespace amctl::machine::detail {

std::vector<MarlinLine> split_lines(std::string_view text) {
  std::vector<MarlinLine> out;
  std::uint64_t n = 0;
  while (!text.empty()) {
    const std::size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text.remove_prefix(nl == std::string_view::npos ? text.size() : nl + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    out.push_back(MarlinLine{line, ++n});
  }
  return out;
}

double parse_marlin_number(std::string_view text, const SourceLocation& where, std::string_view label) {
  std::string_view t = text;
  while (!t.empty() && (t.back() == 'f' || t.back() == 'F' || t.back() == 'u' || t.back() == 'U' ||
                        t.back() == 'l' || t.back() == 'L')) {
    t.remove_suffix(1);
  }
  if (!t.empty() && t.front() == '+') t.remove_prefix(1);
  double v = 0.0;
  const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || p != t.data() + t.size() || !std::isfinite(v)) {
    throw Error(where, fmt::format("{}: found '{}', expected a number", label, text));
  }
  return v;
}

Machine marlin_base_machine(const std::string& source_name) {
  Machine m;
  std::string stem = source_name.substr(source_name.find_last_of('/') == std::string::npos
                                            ? 0
                                            : source_name.find_last_of('/') + 1);
  if (const std::size_t dot = stem.rfind('.'); dot != std::string::npos && dot > 0) stem.resize(dot);
  if (!stem.empty()) m.name = stem;
  m.firmware = Firmware::marlin;
  m.kinematics = kinematics::Cartesian{};
  m.profile = VelocityProfile::trapezoid;
  return m;
}

void set_steps_per_mm(Machine& m, const std::string& name, double steps_per_mm, int microsteps) {
  Stepper& s = m.steppers[name];
  s.microsteps = microsteps;
  s.full_steps_per_rotation = 200;
  s.rotation_distance_mm = s.full_steps_per_rotation * microsteps / steps_per_mm;
}

void finish_marlin_machine(Machine& m, const std::string& source_name) {
  m.max_velocity_mm_s = std::min(m.max_feedrate_mm_s[0], m.max_feedrate_mm_s[1]);
  m.max_accel_mm_s2 = m.print_accel_mm_s2;
  try {
    validate(m);
  } catch (const Error& e) {
    throw Error(SourceLocation{source_name, 0, 0}, e.detail());
  }
}

}  // namespace amctl::machine::detail
