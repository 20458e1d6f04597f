// Resonance-test G-code (resonance/test_gcode.hpp; docs/resonance.md).
#include "amctl/resonance/test_gcode.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <optional>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/config_section.hpp"
#include "amctl/core/error.hpp"
#include "amctl/machine/kinematics.hpp"

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

namespace {

double config_number(const ConfigSection& sec, const char* key, double fallback, double lo, double hi) {
  const ConfigValue* v = sec.find(key);
  if (!v) return fallback;
  std::size_t used = 0;
  double x = 0.0;
  try {
    x = std::stod(v->text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != v->text.size() || !std::isfinite(x)) {
    throw Error(v->where, fmt::format("[{}] {}: found '{}', expected a number", sec.name, key, v->text));
  }
  if (x < lo || x > hi) {
    throw Error(v->where, fmt::format("[{}] {}: found {}, expected a number in [{:g}, {:g}] (Klipper's range)",
                                      sec.name, key, x, lo, hi));
  }
  return x;
}

// Klipper's getlists(seps=(',', '\n'), parser=float, count=3): one "x, y, z" per line.
std::vector<std::array<double, 3>> probe_points_of(const ConfigSection& sec, const ConfigValue& v,
                                                   std::vector<SourceLocation>& where_out) {
  std::vector<std::array<double, 3>> out;
  // The value's text is trimmed as a whole: an empty first line ("probe_points:" alone) has a
  // file line but no piece, so the pieces are the last ones of v.lines.
  const std::size_t pieces = static_cast<std::size_t>(std::count(v.text.begin(), v.text.end(), '\n')) + 1;
  std::size_t line_index = v.lines.size() > pieces ? v.lines.size() - pieces : 0, pos = 0;
  while (pos <= v.text.size()) {
    std::size_t eol = v.text.find('\n', pos);
    if (eol == std::string::npos) eol = v.text.size();
    const std::string line = v.text.substr(pos, eol - pos);
    SourceLocation where = v.where;
    if (line_index < v.lines.size()) where.line = v.lines[line_index];
    if (line.find_first_not_of(" \t") != std::string::npos) {
      std::array<double, 3> p{};
      std::size_t start = 0;
      for (int i = 0; i < 3; ++i) {
        const std::size_t comma = line.find(',', start);
        if ((i < 2) != (comma != std::string::npos)) {
          throw Error(where, fmt::format("[{}] probe_points: found '{}', expected X, Y, Z", sec.name, line));
        }
        std::string field = line.substr(start, i < 2 ? comma - start : std::string::npos);
        field.erase(0, field.find_first_not_of(" \t"));
        field.erase(field.find_last_not_of(" \t") + 1);
        std::size_t used = 0;
        try {
          p[static_cast<std::size_t>(i)] = std::stod(field, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (field.empty() || used != field.size() || !std::isfinite(p[static_cast<std::size_t>(i)])) {
          throw Error(where, fmt::format("[{}] probe_points: found '{}' in '{}', expected a number",
                                         sec.name, field, line));
        }
        start = comma + 1;
      }
      out.push_back(p);
      // On the option's own line: the value's column; a continuation line: the line (its
      // indentation is not kept).
      SourceLocation at = where;
      at.column = 0;
      where_out.push_back(line_index == 0 && v.lines.size() <= pieces ? v.where : at);
    }
    ++line_index;
    pos = eol + 1;
  }
  if (out.empty()) throw Error(v.where, fmt::format("[{}] probe_points: empty, expected X, Y, Z lines", sec.name));
  return out;
}

std::optional<std::pair<double, double>> axis_range(const machine::Machine& m, int axis) {
  // The kinematics' range of the axis (its rail's position_min / position_max).
  const kinematics::MoveRules rules = machine::make_kinematics(m)->move_rules();
  const auto& min = rules.range_min_mm[static_cast<std::size_t>(axis)];
  const auto& max = rules.range_max_mm[static_cast<std::size_t>(axis)];
  if (min && max) return std::make_pair(*min, *max);
  const auto& lo = m.soft_min_position_mm[static_cast<std::size_t>(axis)];
  const auto& hi = m.soft_max_position_mm[static_cast<std::size_t>(axis)];
  if (lo && hi) return std::make_pair(*lo, *hi);
  return std::nullopt;
}

std::string where_of(const ConfigValue& v) { return v.where.to_string(); }

}  // namespace

TestGcodeOptions machine_test_options(TestStyle style, char axis, const machine::Machine& m) {
  TestGcodeOptions o = default_test_options(style);
  o.axis = axis;
  const ConfigSection* rt = nullptr;
  for (const ConfigSection& sec : m.klipper_config) {
    if (sec.name == "resonance_tester") rt = &sec;
  }
  if (rt) {
    if (style == TestStyle::klipper) {
      // resonance_tester.py VibrationPulseTestGenerator: the same defaults and ranges.
      o.freq_start_hz = config_number(*rt, "min_freq", o.freq_start_hz, 1.0, 300.0);
      o.freq_end_hz = config_number(*rt, "max_freq", o.freq_end_hz, o.freq_start_hz, 300.0);
      o.accel_per_hz = config_number(*rt, "accel_per_hz", o.accel_per_hz, 1e-9, 1e9);
      o.hz_per_sec = config_number(*rt, "hz_per_sec", o.hz_per_sec, 0.1, 2.0);
      o.parameter_source = fmt::format("[resonance_tester] of {} (Klipper's defaults where it is silent)",
                                       rt->where.file);
    }
    o.move_speed_mm_s = config_number(*rt, "move_speed", o.move_speed_mm_s, 1e-9, 1e9);
    const ConfigValue* chip = nullptr;
    if (const ConfigValue* cx = rt->find("accel_chip_x")) {
      chip = axis == 'x' ? cx : rt->find("accel_chip_y");
    } else {
      chip = rt->find("accel_chip");
    }
    if (chip) o.accel_chip = chip->text;
    if (const ConfigValue* pp = rt->find("probe_points")) {
      o.probe_points = probe_points_of(*rt, *pp, o.probe_point_locations);
      for (int i = 0; i < 3; ++i) o.point_mm[i] = o.probe_points.front()[static_cast<std::size_t>(i)];
      o.point_given = true;
      o.point_source = fmt::format("[resonance_tester] probe_points, {}", where_of(*pp));

      return o;
    }
  }
  const auto rx = axis_range(m, 0), ry = axis_range(m, 1), rz = axis_range(m, 2);
  if (rx && ry) {
    o.point_mm[0] = 0.5 * (rx->first + rx->second);
    o.point_mm[1] = 0.5 * (ry->first + ry->second);
    o.point_mm[2] = rz ? std::min(20.0, 0.5 * (std::max(rz->first, 0.0) + rz->second)) : 20.0;
    o.point_given = true;
    o.point_source = "the middle of the machine's X and Y position limits, 20 mm up; no [resonance_tester] probe_points";
  }
  return o;
}

TestExcursion test_excursion(const TestGcodeOptions& o) {
  TestExcursion e;
  double pos = 0.0;
  for (const TestHalfPeriod& h : test_half_periods(o)) {
    pos += h.direction * h.distance_mm();
    e.min_mm = std::min(e.min_mm, pos);
    e.max_mm = std::max(e.max_mm, pos);
  }
  return e;
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
  std::vector<std::array<double, 3>> points = o.probe_points;
  if (points.empty()) points.push_back({o.point_mm[0], o.point_mm[1], o.point_mm[2]});
  // Every point and every stroke around it inside the machine's position limits.
  const TestExcursion ex = test_excursion(o);
  for (std::size_t k = 0; k < points.size(); ++k) {
    const auto& p = points[k];
    for (int a = 0; a < 3; ++a) {
      const auto r = axis_range(m, a);
      if (!r) continue;
      const double lo = p[static_cast<std::size_t>(a)] + (a == ai ? ex.min_mm : 0.0);
      const double hi = p[static_cast<std::size_t>(a)] + (a == ai ? ex.max_mm : 0.0);
      if (lo < r->first - 1e-9 || hi > r->second + 1e-9) {
        const std::string what = fmt::format(
            "found test point {:g},{:g},{:g}, whose test moves {} from {:.4f} to {:.4f} mm, expected one "
            "within the machine's position limits {:g} to {:g} mm",
            p[0], p[1], p[2], static_cast<char>('X' + a), lo, hi, r->first, r->second);
        if (k < o.probe_point_locations.size()) {
          throw Error(o.probe_point_locations[k], "[resonance_tester] probe_points: " + what);
        }
        throw Error((o.point_source == "--point" ? "--point: " : "test point: ") + what);
      }
    }
  }
  const machine::Firmware fw = m.firmware;
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
  if (!o.parameter_source.empty()) append(s, "; test parameters from {}\n", o.parameter_source);
  if (points.size() == 1) {
    append(s, "; test point X{:g} Y{:g} Z{:g}{}\n", points[0][0], points[0][1], points[0][2],
           !o.point_source.empty() ? " (" + o.point_source + ")"
           : o.point_given         ? std::string()
                                   : std::string(" (default: the machine's position limits are not known)"));
  } else {
    append(s, "; {} test points, one record each ({}):", points.size(), o.point_source);
    for (const auto& p : points) append(s, " X{:g} Y{:g} Z{:g};", p[0], p[1], p[2]);
    s.back() = '\n';
  }
  append(s, "; {} moves from {:.4f} to {:.4f} mm around each point\n", axis, ex.min_mm, ex.max_mm);
  append(s, "; machine {} ({} commands)\n", m.name,
         fw == machine::Firmware::klipper ? "Klipper" : fw == machine::Firmware::marlin ? "Marlin" : "RepRapFirmware");
  // Klipper: ACCELEROMETER_MEASURE takes the chip's name (the section's last word; plain
  // [adxl345] also answers without CHIP) and writes /tmp/<type>-<name>-<NAME>.csv, or
  // /tmp/<type>-<NAME>.csv when the section has no name of its own (adxl345.py).
  const std::string chip_section = o.accel_chip.empty() ? std::string("adxl345") : o.accel_chip;
  const std::string chip_type = chip_section.substr(0, chip_section.find(' '));
  const std::string chip_name = chip_section.substr(chip_section.find_last_of(' ') + 1);
  if (fw == machine::Firmware::klipper) {
    append(s, "; accelerometer [{}]{}: each test is recorded to /tmp/{}-resonances_{}_N.csv (N = the point's number)\n",
           chip_section, o.accel_chip.empty() ? " (Klipper's default; set [resonance_tester] accel_chip)" : "",
           chip_type == chip_name ? chip_type : chip_type + "-" + chip_name, o.axis);
  } else {
    append(s, "; {} has no accelerometer command: start your recorder at each 'record' comment\n",
           fw == machine::Firmware::marlin ? "Marlin" : "RepRapFirmware");
  }
  if (o.home) append(s, "G28\n");
  append(s, "G90\n");
  const machine::InputShaper& is = m.input_shaper;
  if (is.active()) {
    if (fw == machine::Firmware::klipper) {
      // TEST_RESONANCES disables [input_shaper] for the test and enables it again after.
      append(s, "SET_INPUT_SHAPER SHAPER_FREQ_X=0 SHAPER_FREQ_Y=0\n");
    } else if (fw == machine::Firmware::marlin) {
      append(s, "M593 F0\n");
    }
  }
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
  for (std::size_t k = 0; k < points.size(); ++k) {
    const auto& p = points[k];
    // As TEST_RESONANCES: move to the point, wait for the moves, dwell 0.5 s, record.
    append(s, "G1 X{:.4f} Y{:.4f} Z{:.4f} F{:g}\nM400\nG4 P500\n", p[0], p[1], p[2], o.move_speed_mm_s * 60.0);
    const std::string record = fmt::format("resonances_{}_{}", o.axis, k + 1);
    if (fw == machine::Firmware::klipper) {
      append(s, "ACCELEROMETER_MEASURE CHIP={} NAME={}\n", chip_name, record);
    } else {
      append(s, "; record {}: start\n", record);
    }
    double pos = p[static_cast<std::size_t>(ai)];
    for (const TestHalfPeriod& h : halves) {
      switch (fw) {
        case machine::Firmware::klipper: append(s, "SET_VELOCITY_LIMIT ACCEL={:.3f}\n", h.accel_mm_s2); break;
        case machine::Firmware::marlin: append(s, "M204 S{:.3f}\n", h.accel_mm_s2); break;
        case machine::Firmware::reprap: append(s, "M204 P{0:.3f} T{0:.3f}\n", h.accel_mm_s2); break;
      }
      pos += h.direction * h.distance_mm();
      append(s, "G1 {}{:.6f} F{:.4f}\n", axis, pos, ceil4(h.peak_velocity_mm_s() * 60.0));
    }
    append(s, "M400\n");
    if (fw == machine::Firmware::klipper) {
      append(s, "ACCELEROMETER_MEASURE CHIP={} NAME={}\n", chip_name, record);
    } else {
      append(s, "; record {}: stop\n", record);
    }
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
  if (is.active()) {
    if (fw == machine::Firmware::klipper) {
      append(s, "SET_INPUT_SHAPER SHAPER_FREQ_X={:g} SHAPER_FREQ_Y={:g}\n", is.shaper_freq_x_hz, is.shaper_freq_y_hz);
    } else if (fw == machine::Firmware::marlin) {
      if (is.shaper_freq_x_hz > 0) append(s, "M593 X F{:g} D{:g}\n", is.shaper_freq_x_hz, is.damping_ratio_x);
      if (is.shaper_freq_y_hz > 0) append(s, "M593 Y F{:g} D{:g}\n", is.shaper_freq_y_hz, is.damping_ratio_y);
    }
  }
  return s;
}

}  // namespace amctl::resonance
