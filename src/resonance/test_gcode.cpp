// Resonance-test G-code (resonance/test_gcode.hpp; docs/resonance.md).
#include "amctl/resonance/test_gcode.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::resonance {
namespace {

constexpr std::size_t kMaxHalfPeriods = 1000000;

void check_options(const TestGcodeOptions& o) {
  auto positive = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) throw Error(fmt::format("{}: must be > 0, got {}", name, v));
  };
  if (o.axis != 'x' && o.axis != 'y') throw Error(fmt::format("--axis: must be x or y, got '{}'", o.axis));
  positive(o.freq_start_hz, "--freq-start");
  positive(o.freq_end_hz, "--freq-end");
  if (o.freq_end_hz < o.freq_start_hz) {
    throw Error(fmt::format("--freq-end: must be >= --freq-start ({1}), got {0}", o.freq_end_hz, o.freq_start_hz));
  }
  positive(o.hz_per_sec, "--hz-per-sec");
  if (o.style == TestStyle::klipper) {
    // Klipper's limits (resonance_tester.py): FREQ_START >= 1, FREQ_END <= 300, HZ_PER_SEC <= 2.
    if (o.freq_start_hz < 1.0) throw Error(fmt::format("--freq-start: must be >= 1 Hz (Klipper's limit), got {}", o.freq_start_hz));
    if (o.freq_end_hz > 300.0) throw Error(fmt::format("--freq-end: must be <= 300 Hz (Klipper's limit), got {}", o.freq_end_hz));
    if (o.hz_per_sec > 2.0) throw Error(fmt::format("--hz-per-sec: must be <= 2 (Klipper's limit), got {}", o.hz_per_sec));
    positive(o.accel_per_hz, "--accel-per-hz");
  } else {
    positive(o.accel_mm_s2, "--accel-mm-s2");
  }
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(o.point_mm[i])) throw Error(fmt::format("--point: coordinate {} is not finite", i + 1));
  }
  // Each half period advances f by rate / (2 f) >= rate / (2 f1).
  const double estimate = 2.0 * o.freq_end_hz * (o.freq_end_hz - o.freq_start_hz) / o.hz_per_sec;
  if (estimate > static_cast<double>(kMaxHalfPeriods)) {
    throw Error(fmt::format("--hz-per-sec {} over {}..{} Hz gives about {:.0f} half periods, expected at most {}",
                            o.hz_per_sec, o.freq_start_hz, o.freq_end_hz, estimate, kMaxHalfPeriods));
  }
}

template <class... A>
void append(std::string& s, fmt::format_string<A...> f, A&&... a) {
  fmt::format_to(std::back_inserter(s), f, std::forward<A>(a)...);
}

// Rounds up at the 4th decimal so that the planner's cruise cap never clips the triangle.
double ceil4(double v) { return std::ceil(v * 1e4) * 1e-4; }

}  // namespace

TestGcodeOptions default_test_options(TestStyle style) {
  TestGcodeOptions o;
  o.style = style;
  if (style == TestStyle::marlin) {
    o.freq_end_hz = 80.0;
    o.hz_per_sec = 4.0;
  }
  return o;
}

std::vector<TestHalfPeriod> test_half_periods(const TestGcodeOptions& o) {
  check_options(o);
  std::vector<TestHalfPeriod> out;
  double f = o.freq_start_hz;
  double t = 0.0;
  double dir = 1.0;
  // Same stopping rule as Klipper's generator: while f <= f_end + 1e-6.
  while (f <= o.freq_end_hz + 1e-6) {
    TestHalfPeriod h;
    h.freq_hz = f;
    h.accel_mm_s2 = o.style == TestStyle::klipper ? o.accel_per_hz * f : o.accel_mm_s2;
    h.start_time_s = t;
    h.direction = dir;
    out.push_back(h);
    t += h.duration_s();
    f += o.hz_per_sec * h.duration_s();
    dir = -dir;
  }
  return out;
}

double test_duration_s(const TestGcodeOptions& o) {
  const std::vector<TestHalfPeriod> h = test_half_periods(o);
  if (h.empty()) return 0.0;
  const double f_n = h.back().freq_hz + o.hz_per_sec * h.back().duration_s();
  return (f_n - o.freq_start_hz) / o.hz_per_sec;
}

std::string test_gcode(const TestGcodeOptions& o, const machine::Machine& m) {
  const std::vector<TestHalfPeriod> halves = test_half_periods(o);
  const bool klipper = o.style == TestStyle::klipper;
  double max_a = 0.0, max_v = 0.0, max_d = 0.0;
  for (const TestHalfPeriod& h : halves) {
    max_a = std::max(max_a, h.accel_mm_s2);
    max_v = std::max(max_v, h.peak_velocity_mm_s());
    max_d = std::max(max_d, h.distance_mm());
  }
  const char axis = static_cast<char>(o.axis - 'a' + 'A');
  const int ai = o.axis == 'x' ? 0 : 1;
  std::string s;
  append(s, "; amctl resonance test-gcode: {} style, axis {}\n", klipper ? "klipper" : "marlin", o.axis);
  if (klipper) {
    append(s, "; the move pattern of Klipper's TEST_RESONANCES with SWEEPING_PERIOD=0 (its vibration\n"
        "; generator): accel per Hz {:g} mm/s^2/Hz\n", o.accel_per_hz);
  } else {
    append(s, "; Marlin-style sweep: constant acceleration amplitude {:g} mm/s^2\n", o.accel_mm_s2);
  }
  append(s, "; frequency {:g} -> {:g} Hz at {:g} Hz/s: {} half periods, {:.6f} s\n", o.freq_start_hz,
      o.freq_end_hz, o.hz_per_sec, halves.size(), test_duration_s(o));
  append(s, "; peak acceleration {:.1f} mm/s^2, peak velocity {:.3f} mm/s, longest stroke {:.4f} mm\n", max_a,
      max_v, max_d);
  append(s, "; test point X{:g} Y{:g} Z{:g}{}\n", o.point_mm[0], o.point_mm[1], o.point_mm[2],
      o.point_given ? "" : " (default: the machine's position limits are not known)");
  // The commands follow the machine's firmware; the pattern follows the style.
  const machine::Firmware fw = m.firmware;
  append(s, "; machine {} ({} commands); disable input shaping before running this file\n", m.name,
         fw == machine::Firmware::klipper ? "Klipper" : fw == machine::Firmware::marlin ? "Marlin" : "RepRapFirmware");
  // The dwell brings the toolhead to rest at the point: the first half period starts at rest.
  append(s, "G90\nG1 X{:.4f} Y{:.4f} Z{:.4f} F3000\nG4 P500\n", o.point_mm[0], o.point_mm[1], o.point_mm[2]);
  const double need_a = std::max(m.max_axis_accel_mm_s2[ai], std::ceil(max_a));
  const double need_v = std::max(m.max_feedrate_mm_s[ai], std::ceil(max_v));
  switch (fw) {
    case machine::Firmware::klipper:
      // SQUARE_CORNER_VELOCITY=0: a reversal stops (Klipper's own test forces the junction speed).
      append(s, "SET_VELOCITY_LIMIT VELOCITY={:.0f} ACCEL={:.0f} MINIMUM_CRUISE_RATIO=0 SQUARE_CORNER_VELOCITY=0\n",
             max_v + 0.5, max_a + 0.5);
      break;
    case machine::Firmware::marlin:
      // Raise the axis limits, no classic-jerk reversal speed, no slow-down of short segments.
      append(s, "M201 {}{:.0f}\nM203 {}{:.0f}\nM205 X0 Y0 B0\n", axis, need_a, axis, need_v);
      break;
    case machine::Firmware::reprap:
      // RepRapFirmware: M203 and M566 (jerk) in mm/min.
      append(s, "M201 {}{:.0f}\nM203 {}{:.0f}\nM566 X0 Y0\n", axis, need_a, axis, need_v * 60.0);
      break;
  }
  double pos = o.point_mm[ai];
  for (const TestHalfPeriod& h : halves) {
    switch (fw) {
      case machine::Firmware::klipper: append(s, "SET_VELOCITY_LIMIT ACCEL={:.3f}\n", h.accel_mm_s2); break;
      case machine::Firmware::marlin: append(s, "M204 S{:.3f}\n", h.accel_mm_s2); break;
      case machine::Firmware::reprap: append(s, "M204 P{0:.3f} T{0:.3f}\n", h.accel_mm_s2); break;
    }
    pos += h.direction * h.distance_mm();
    append(s, "G1 {}{:.6f} F{:.4f}\n", axis, pos, ceil4(h.peak_velocity_mm_s() * 60.0));
  }
  append(s, "; restore the machine's limits\n");
  switch (fw) {
    case machine::Firmware::klipper:
      append(s, "SET_VELOCITY_LIMIT VELOCITY={:g} ACCEL={:g} MINIMUM_CRUISE_RATIO={:g} SQUARE_CORNER_VELOCITY={:g}\n",
             m.max_velocity_mm_s, m.max_accel_mm_s2, m.minimum_cruise_ratio, m.square_corner_velocity_mm_s);
      break;
    case machine::Firmware::marlin:
      append(s, "M201 {}{:g}\nM203 {}{:g}\nM204 P{:g} R{:g} T{:g}\nM205 X{:g} Y{:g} B{:.0f}\n", axis,
             m.max_axis_accel_mm_s2[ai], axis, m.max_feedrate_mm_s[ai], m.print_accel_mm_s2,
             m.retract_accel_mm_s2, m.travel_accel_mm_s2, m.jerk_mm_s[0], m.jerk_mm_s[1],
             m.min_segment_time_s * 1e6);
      break;
    case machine::Firmware::reprap:
      append(s, "M201 {}{:g}\nM203 {}{:g}\nM204 P{:g} T{:g}\nM566 X{:g} Y{:g}\n", axis, m.max_axis_accel_mm_s2[ai],
             axis, m.max_feedrate_mm_s[ai] * 60.0, m.print_accel_mm_s2, m.travel_accel_mm_s2,
             m.jerk_mm_s[0] * 60.0, m.jerk_mm_s[1] * 60.0);
      break;
  }
  return s;
}

}  // namespace amctl::resonance
