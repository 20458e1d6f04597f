// A Marlin machine from the M503 settings report (include/amctl/machine/marlin.hpp).
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <optional>
#include <set>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/machine/marlin.hpp"
#include "marlin_common.hpp"
#include "schema.hpp"

namespace amctl::machine {
namespace {

using detail::Bound;
using detail::MarlinLine;

/// One report line: the command and its letter parameters, each with its column.
struct Report {
  char letter = 0;  // 'M' or 'G'
  int number = -1;
  struct Param {
    char letter = 0;
    std::optional<double> value;
    std::uint32_t column = 0;
  };
  std::vector<Param> params;
  std::uint32_t column = 0;

  [[nodiscard]] const Param* find(char c) const {
    for (const auto& p : params) {
      if (p.letter == c) return &p;
    }
    return nullptr;
  }
};

/// The report's text of a line once terminal-log prefixes are gone, with the column where it
/// starts (1-based), or nothing for a line that is not part of the report.
std::optional<std::pair<std::string_view, std::uint32_t>> report_text(std::string_view line) {
  std::size_t at = 0;
  if (line.find("Send:") != std::string_view::npos) return std::nullopt;  // a command sent
  if (const std::size_t recv = line.find("Recv:"); recv != std::string_view::npos) at = recv + 5;
  auto skip_blanks = [&] {
    while (at < line.size() && (line[at] == ' ' || line[at] == '\t')) ++at;
  };
  skip_blanks();
  if (line.substr(at).starts_with(">>>") || line.substr(at).starts_with("SENDING:")) {
    return std::nullopt;  // Pronterface echoing what it sent
  }
  while (line.substr(at).starts_with("echo:")) {
    at += 5;
    skip_blanks();
  }
  std::string_view rest = line.substr(at);
  if (const std::size_t semi = rest.find(';'); semi != std::string_view::npos) rest = rest.substr(0, semi);
  while (!rest.empty() && (rest.back() == ' ' || rest.back() == '\t' || rest.back() == '\r')) {
    rest.remove_suffix(1);
  }
  return std::make_pair(rest, static_cast<std::uint32_t>(at + 1));
}

/// "M92 X80.00 Y80.00" -> Report; nothing if the text is not a command (a heading, "ok").
std::optional<Report> parse_report(std::string_view text, std::uint32_t column,
                                   const std::string& source, std::uint64_t line_no) {
  if (text.size() < 2 || (text[0] != 'M' && text[0] != 'G') || text[1] < '0' || text[1] > '9') {
    return std::nullopt;
  }
  Report r;
  r.letter = text[0];
  r.column = column;
  std::size_t i = 1;
  int n = 0;
  while (i < text.size() && text[i] >= '0' && text[i] <= '9') {
    if (n < 100000) n = n * 10 + (text[i] - '0');  // no Marlin code is that long: ignored below
    ++i;
  }
  if (i < text.size() && text[i] != ' ' && text[i] != '\t') return std::nullopt;  // "M92X" is no report
  r.number = n;
  while (i < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    if (i >= text.size()) break;
    Report::Param p;
    p.letter = text[i];
    p.column = column + static_cast<std::uint32_t>(i);
    if (!std::isalpha(static_cast<unsigned char>(p.letter))) {
      throw Error(SourceLocation{source, line_no, p.column},
                  fmt::format("{}{}: found '{}', expected a parameter letter and its number",
                              r.letter, r.number, text.substr(i, 1)));
    }
    ++i;
    const std::size_t start = i;
    while (i < text.size() && text[i] != ' ' && text[i] != '\t') ++i;
    if (i > start) {
      const std::string_view num = text.substr(start, i - start);
      p.value = detail::parse_marlin_number(num, SourceLocation{source, line_no, p.column + 1},
                                            fmt::format("{}{} {}", r.letter, r.number, p.letter));
    }
    r.params.push_back(p);
  }
  return r;
}

}  // namespace

bool looks_like_m503(std::string_view text) {
  std::set<int> seen;
  for (const MarlinLine& l : detail::split_lines(text)) {
    // An INI or TOML section: a configuration (a Klipper macro may hold M204 lines).
    const std::size_t first = l.text.find_first_not_of(" \t");
    if (first != std::string_view::npos && l.text[first] == '[') return false;
    const auto rt = report_text(l.text);
    if (!rt) continue;
    const std::string_view t = rt->first;
    for (int code : {92, 201, 203, 204, 205}) {
      const std::string word = fmt::format("M{}", code);
      if (t.starts_with(word) && (t.size() == word.size() || t[word.size()] == ' ')) {
        seen.insert(code);
      }
    }
    if (seen.size() >= 2) return true;
  }
  return false;
}

Machine parse_marlin_m503(std::string_view text, const std::string& source_name) {
  Machine m = detail::marlin_base_machine(source_name);
  std::set<int> seen;
  std::optional<char> junction;  // 'J' or 'X' from M205
  for (const MarlinLine& l : detail::split_lines(text)) {
    const auto rt = report_text(l.text);
    if (!rt) continue;
    const auto parsed = parse_report(rt->first, rt->second, source_name, l.number);
    if (!parsed || parsed->letter != 'M') continue;
    const Report& r = *parsed;
    const SourceLocation at{source_name, l.number, r.column};
    auto value = [&](const Report::Param& p, Bound b, std::string_view unit) {
      if (!p.value) {
        throw Error(SourceLocation{source_name, l.number, p.column},
                    fmt::format("M{} {}: found no number, expected one in {}", r.number, p.letter, unit));
      }
      detail::check_bound(b, *p.value, SourceLocation{source_name, l.number, p.column + 1},
                          fmt::format("M{} {}", r.number, p.letter), unit);
      return *p.value;
    };
    // Per-extruder lines ("M92 T1 E93") set the other extruders: only T0's are read.
    if (const auto* t = r.find('T'); t != nullptr && t->value && *t->value != 0 &&
                                     (r.number == 92 || r.number == 200 || r.number == 201 ||
                                      r.number == 203 || r.number == 906)) {
      continue;
    }
    auto axes = [&](std::array<double, 4>& out, Bound b, std::string_view unit, bool all) {
      static constexpr char kAxes[4] = {'X', 'Y', 'Z', 'E'};
      for (int a = 0; a < 4; ++a) {
        const auto* p = r.find(kAxes[a]);
        if (p != nullptr) {
          out[static_cast<std::size_t>(a)] = value(*p, b, unit);
        } else if (all) {
          throw Error(at, fmt::format("M{}: found no {}, expected X, Y, Z and E as M503 reports them",
                                      r.number, kAxes[a]));
        }
      }
    };
    seen.insert(r.number);
    switch (r.number) {
      case 92: {
        std::array<double, 4> steps{0, 0, 0, 0};
        axes(steps, Bound::positive, "steps/mm", false);
        static constexpr const char* kNames[4] = {"x", "y", "z", "e"};
        for (std::size_t a = 0; a < 4; ++a) {
          if (steps[a] > 0) detail::set_steps_per_mm(m, kNames[a], steps[a], 16);
        }
        break;
      }
      case 201: axes(m.max_axis_accel_mm_s2, Bound::positive, "mm/s^2", true); break;
      case 203: axes(m.max_feedrate_mm_s, Bound::positive, "mm/s", true); break;
      case 204: {
        const auto* p = r.find('P');
        const auto* s = r.find('S');
        if (p != nullptr) {
          m.print_accel_mm_s2 = value(*p, Bound::positive, "mm/s^2");
        } else if (s != nullptr) {  // older firmware: S is print and travel
          m.print_accel_mm_s2 = m.travel_accel_mm_s2 = value(*s, Bound::positive, "mm/s^2");
        } else {
          throw Error(at, "M204: found neither P nor S, expected the print acceleration");
        }
        if (const auto* q = r.find('R')) m.retract_accel_mm_s2 = value(*q, Bound::positive, "mm/s^2");
        if (const auto* q = r.find('T')) m.travel_accel_mm_s2 = value(*q, Bound::positive, "mm/s^2");
        break;
      }
      case 205: {
        if (const auto* q = r.find('B')) m.min_segment_time_s = value(*q, Bound::non_negative, "us") * 1e-6;
        if (const auto* q = r.find('S')) m.min_feedrate_mm_s = value(*q, Bound::non_negative, "mm/s");
        if (const auto* q = r.find('T')) m.min_travel_feedrate_mm_s = value(*q, Bound::non_negative, "mm/s");
        std::array<double, 4> jerk = m.jerk_mm_s;
        axes(jerk, Bound::non_negative, "mm/s", false);
        m.jerk_mm_s = jerk;
        if (const auto* q = r.find('J')) {
          m.junction_deviation_mm = value(*q, Bound::positive, "mm");
          junction = 'J';
        } else if (r.find('X') != nullptr || r.find('Y') != nullptr) {
          junction = 'X';
        }
        break;
      }
      case 200:
        if (const auto* q = r.find('D'); q != nullptr && q->value && *q->value > 0) {
          m.extruder.filament_diameter_mm = value(*q, Bound::positive, "mm");
        }
        break;
      case 207:
        if (const auto* q = r.find('S')) m.firmware_retraction.retract_length_mm = value(*q, Bound::non_negative, "mm");
        if (const auto* q = r.find('F')) m.firmware_retraction.retract_speed_mm_s = value(*q, Bound::positive, "mm/min") / 60.0;
        if (const auto* q = r.find('Z')) m.firmware_retraction.lift_z_mm = value(*q, Bound::non_negative, "mm");
        break;
      case 208:
        if (const auto* q = r.find('S')) m.firmware_retraction.unretract_extra_length_mm = value(*q, Bound::non_negative, "mm");
        if (const auto* q = r.find('F')) m.firmware_retraction.unretract_speed_mm_s = value(*q, Bound::positive, "mm/min") / 60.0;
        break;
      case 593: {
        // Marlin's input shaper is ZV. "M593 X F40 D0.15" sets X, "M593 F40 D0.15" both axes.
        const bool x = r.find('X') != nullptr, y = r.find('Y') != nullptr;
        const auto* f = r.find('F');
        const auto* d = r.find('D');
        for (int axis = 0; axis < 2; ++axis) {
          if ((axis == 0 && (x || !y)) || (axis == 1 && (y || !x))) {
            auto& type = axis == 0 ? m.input_shaper.shaper_type_x : m.input_shaper.shaper_type_y;
            auto& freq = axis == 0 ? m.input_shaper.shaper_freq_x_hz : m.input_shaper.shaper_freq_y_hz;
            auto& zeta = axis == 0 ? m.input_shaper.damping_ratio_x : m.input_shaper.damping_ratio_y;
            type = "zv";
            if (f != nullptr) freq = value(*f, Bound::non_negative, "Hz");
            if (d != nullptr) zeta = value(*d, Bound::ratio, "");
          }
        }
        break;
      }
      case 906: {
        static constexpr std::pair<char, const char*> kMotors[] = {{'X', "x"}, {'Y', "y"}, {'Z', "z"}, {'E', "e"}};
        for (const auto& [letter, name] : kMotors) {
          if (const auto* q = r.find(letter)) {
            m.steppers[name].run_current_a = value(*q, Bound::positive, "mA") / 1000.0;
          }
        }
        break;
      }
      case 665:
        throw Error(at, "found M665 (delta geometry), expected a cartesian or CoreXY printer: "
                        "describe a delta in a machine .toml or a Klipper printer.cfg");
      default:
        break;  // M851, M900, M420, M145, M301, ... : not part of the motion plan
    }
  }
  for (int code : {201, 203, 204, 205}) {
    if (!seen.contains(code)) {
      throw Error(SourceLocation{source_name, 0, 0},
                  fmt::format("found no M{} line, expected the M503 report's M201, M203, M204 "
                              "and M205 (maximum acceleration, feedrate, acceleration, jerk)",
                              code));
    }
  }
  if (!junction) {
    throw Error(SourceLocation{source_name, 0, 0},
                "found neither J (junction deviation) nor X/Y (classic jerk) on M205, expected "
                "one of them");
  }
  m.junction = *junction == 'J' ? JunctionPolicy::junction_deviation : JunctionPolicy::classic_jerk;
  detail::finish_marlin_machine(m, source_name);
  return m;
}

}  // namespace amctl::machine
