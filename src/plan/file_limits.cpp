// The file's own limits commands: the report of what they were, and FileLimits::cap.
#include "amctl/plan/file_limits.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "planner_core.hpp"

namespace amctl::plan {

std::string_view to_string(FileLimits f) {
  switch (f) {
    case FileLimits::keep: return "keep";
    case FileLimits::ignore: return "ignore";
    case FileLimits::cap: return "cap";
  }
  return "keep";
}

std::optional<FileLimits> parse_file_limits(std::string_view text) {
  for (FileLimits f : {FileLimits::keep, FileLimits::ignore, FileLimits::cap}) {
    if (text == to_string(f)) return f;
  }
  return std::nullopt;
}

std::vector<std::string> describe_file_limits(const FileLimitsReport& r) {
  std::vector<std::string> out;
  if (r.by_command.empty()) return out;
  for (const FileLimitCommand& c : r.by_command) {
    std::string params;
    for (const FileLimitValues& v : r.values) {
      if (v.command != c.command) continue;
      std::string list;
      for (double x : v.values) list += fmt::format("{}{:g}", list.empty() ? "" : ", ", x);
      if (v.more_values) list += ", ...";
      const std::string unit = v.unit.empty() ? "" : " " + v.unit;
      params += params.empty() ? "" : "; ";
      params += v.min == v.max ? fmt::format("{} {:g}{}", v.parameter, v.min, unit)
                               : fmt::format("{} {:g}-{:g}{} ({})", v.parameter, v.min, v.max, unit, list);
    }
    out.push_back(fmt::format("{} {} line{} from line {}: {}{}", c.lines, c.command,
                              c.lines == 1 ? "" : "s", c.first_line, params,
                              c.firmware_acts ? "" : " (another firmware's command: ignored)"));
  }
  if (r.commands == 0) return out;
  switch (r.policy) {
    case FileLimits::keep:
      out.push_back("kept, as the firmware does: they override the machine's limits while they "
                    "last (--file-limits cap or ignore for a what-if on the machine's limits)");
      break;
    case FileLimits::ignore:
      out.push_back(fmt::format("ignored (--file-limits ignore): {} commands not applied, the "
                                "machine's limits hold throughout", r.ignored));
      break;
    case FileLimits::cap:
      out.push_back(fmt::format("capped at the machine's limits (--file-limits cap): {} of {} "
                                "commands lowered", r.capped, r.commands));
      break;
  }
  return out;
}

namespace detail {
namespace {

using Source = gcode::LimitsCommand::Source;

const char* command_name(Source s) {
  switch (s) {
    case Source::m201: return "M201";
    case Source::m203: return "M203";
    case Source::m204: return "M204";
    case Source::m205: return "M205";
    case Source::m566: return "M566";
    case Source::set_velocity_limit: return "SET_VELOCITY_LIMIT";
  }
  return "?";
}

const char* letter_unit(Source s, char letter, bool reprap) {
  switch (s) {
    case Source::m201:
    case Source::m204: return "mm/s^2";
    case Source::m203: return reprap ? "mm/min" : "mm/s";
    case Source::m566: return "mm/min";
    case Source::m205:
      if (letter == 'J') return "mm";
      if (letter == 'B') return "us";
      return "mm/s";
    case Source::set_velocity_limit: break;
  }
  return "";
}

void add_value(FileLimitsReport& report, const char* command, std::string parameter,
               const char* unit, double v, std::uint64_t line) {
  auto it = std::find_if(report.values.begin(), report.values.end(), [&](const FileLimitValues& x) {
    return x.command == command && x.parameter == parameter;
  });
  if (it == report.values.end()) {
    FileLimitValues x;
    x.command = command;
    x.parameter = std::move(parameter);
    x.unit = unit;
    x.first_line = line;
    x.min = x.max = v;
    report.values.push_back(std::move(x));
    it = report.values.end() - 1;
  }
  ++it->count;
  it->min = std::min(it->min, v);
  it->max = std::max(it->max, v);
  const auto pos = std::lower_bound(it->values.begin(), it->values.end(), v);
  if (pos != it->values.end() && *pos == v) return;
  if (it->values.size() < FileLimitValues::kMaxDistinct) {
    it->values.insert(pos, v);
  } else {
    it->more_values = true;
  }
}

bool lower_to(double& v, double ceiling) {
  if (v > ceiling) {
    v = ceiling;
    return true;
  }
  return false;
}

}  // namespace

void tally_file_limits(const gcode::LimitsCommand& c, bool acts, bool reprap, FileLimitsReport& report) {
  if (acts) ++report.commands;
  else ++report.other_firmware_commands;
  const char* name = command_name(c.source);
  auto cmd = std::find_if(report.by_command.begin(), report.by_command.end(),
                          [&](const FileLimitCommand& x) { return x.command == name; });
  if (cmd == report.by_command.end()) {
    report.by_command.push_back({name, 0, c.line, acts});
    cmd = report.by_command.end() - 1;
  }
  ++cmd->lines;
  if (c.source == Source::set_velocity_limit) {
    const struct { const char* key; const std::optional<double>& v; const char* unit; } keys[] = {
        {"VELOCITY", c.velocity, "mm/s"},
        {"ACCEL", c.accel, "mm/s^2"},
        {"SQUARE_CORNER_VELOCITY", c.square_corner_velocity, "mm/s"},
        {"MINIMUM_CRUISE_RATIO", c.minimum_cruise_ratio, ""},
        {"ACCEL_TO_DECEL", c.accel_to_decel, "mm/s^2"}};
    for (const auto& k : keys) {
      if (k.v) add_value(report, name, k.key, k.unit, *k.v, c.line);
    }
    return;
  }
  for (char l = 'A'; l <= 'Z'; ++l) {
    if (c.params.has(l)) add_value(report, name, std::string(1, l), letter_unit(c.source, l, reprap), c.params.get(l), c.line);
  }
}

bool cap_limits(Planner::Limits& lim, const Planner::Limits& m) {
  bool changed = false;
  changed |= lower_to(lim.max_velocity_mm_s, m.max_velocity_mm_s);
  changed |= lower_to(lim.accel_mm_s2, m.accel_mm_s2);
  changed |= lower_to(lim.travel_accel_mm_s2, m.travel_accel_mm_s2);
  changed |= lower_to(lim.retract_accel_mm_s2, m.retract_accel_mm_s2);
  changed |= lower_to(lim.square_corner_velocity_mm_s, m.square_corner_velocity_mm_s);
  if (lim.minimum_cruise_ratio < m.minimum_cruise_ratio) {
    lim.minimum_cruise_ratio = m.minimum_cruise_ratio;
    changed = true;
  }
  if (lim.accel_to_decel_mm_s2) {
    // The machine's smoothed-pass acceleration (toolhead.py): accel_to_decel when it has one,
    // else max_accel (1 - minimum_cruise_ratio).
    const double machine_smoothed = m.accel_to_decel_mm_s2
                                        ? std::min(*m.accel_to_decel_mm_s2, m.accel_mm_s2)
                                        : m.accel_mm_s2 * (1.0 - m.minimum_cruise_ratio);
    changed |= lower_to(*lim.accel_to_decel_mm_s2, machine_smoothed);
  }
  for (std::size_t a = 0; a < 4; ++a) {
    changed |= lower_to(lim.max_feedrate_mm_s[a], m.max_feedrate_mm_s[a]);
    changed |= lower_to(lim.max_axis_accel_mm_s2[a], m.max_axis_accel_mm_s2[a]);
    changed |= lower_to(lim.jerk_mm_s[a], m.jerk_mm_s[a]);
  }
  changed |= lower_to(lim.junction_deviation_mm, m.junction_deviation_mm);
  return changed;
}

}  // namespace detail
}  // namespace amctl::plan
