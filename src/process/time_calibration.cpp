#include "amctl/process/time_calibration.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::process {
namespace {

bool starts_with_ci(std::string_view s, std::string_view p) {
  if (s.size() < p.size()) return false;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (std::toupper(static_cast<unsigned char>(s[i])) != p[i]) return false;
  }
  return true;
}

}  // namespace

std::vector<PrintTiming> read_print_timings(const CsvTable& t) {
  const std::size_t gc = t.require("gcode");
  std::optional<std::size_t> dc;
  double scale = 1.0;
  for (const auto& [name, s] : {std::pair<const char*, double>{"duration_s", 1.0},
                                {"duration_min", 60.0}, {"duration_h", 3600.0}}) {
    if (auto c = t.find(name)) {
      if (dc) throw Error(SourceLocation{t.file(), t.header_line(), 0}, "give exactly one duration column");
      dc = c;
      scale = s;
    }
  }
  if (!dc) {
    throw Error(SourceLocation{t.file(), t.header_line(), 0},
                "missing duration column: expected duration_s, duration_min or duration_h");
  }
  const auto lc = t.find("layer");
  const std::filesystem::path base = std::filesystem::path(t.file()).parent_path();
  std::vector<PrintTiming> out;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    PrintTiming p;
    p.csv_line = t.where(r, 0).line;
    std::filesystem::path g(t.text(r, gc));
    if (g.empty()) throw Error(t.where(r, gc), "empty G-code path");
    if (g.is_relative()) g = base / g;
    p.gcode_path = g.string();
    const double d = t.number(r, *dc);
    // A print of 1 ms to 116 days (the duration range): 1e-300 s or 1e308 s is a typo, not
    // a timing the fit should bend to.
    if (!(d * scale >= 1e-3 && d * scale <= kDurationRange.max)) {
      throw Error(t.where(r, *dc), fmt::format("measured duration must be in [0.001, {:g}] s, got {}",
                                               kDurationRange.max, d * scale));
    }
    p.duration_s = d * scale;
    if (lc) {
      const double l = t.number(r, *lc);
      // Range first: converting a double beyond long's range is undefined behaviour.
      if (!(l >= 0 && l <= 1e9) || l != std::floor(l)) {
        throw Error(t.where(r, *lc),
                    fmt::format("layer must be a whole number in [0, 1e9], got {}", l));
      }
      p.layer = static_cast<long>(l);
    }
    out.push_back(std::move(p));
  }
  if (out.empty()) throw Error(SourceLocation{t.file(), 0, 0}, "no timed prints");
  return out;
}

std::string strip_limit_commands(std::string_view g) {
  std::string out;
  out.reserve(g.size());
  std::size_t pos = 0;
  while (pos < g.size()) {
    std::size_t eol = g.find('\n', pos);
    if (eol == std::string_view::npos) eol = g.size();
    std::string_view line = g.substr(pos, eol - pos);
    std::size_t i = 0;
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::string_view body = line.substr(i);
    if (starts_with_ci(body, "N")) {
      // Skip a line number.
      std::size_t j = 1;
      while (j < body.size() && std::isdigit(static_cast<unsigned char>(body[j]))) ++j;
      while (j < body.size() && body[j] == ' ') ++j;
      body = body.substr(j);
    }
    bool drop = starts_with_ci(body, "SET_VELOCITY_LIMIT");
    for (const char* c : {"M201", "M203", "M204", "M205", "M566"}) {
      if (starts_with_ci(body, c) &&
          (body.size() == 4 || !std::isdigit(static_cast<unsigned char>(body[4])))) {
        drop = true;
      }
    }
    if (!drop) out += line;
    if (eol < g.size()) out += '\n';
    pos = eol + 1;
  }
  return out;
}

std::vector<std::string> calibratable_limits() {
  return {"accel", "scv", "jd", "jerk", "max_velocity"};
}

std::vector<std::string> default_limits_for(const machine::Machine& m) {
  switch (m.junction) {
    case machine::JunctionPolicy::square_corner_velocity: return {"accel", "scv", "max_velocity"};
    case machine::JunctionPolicy::junction_deviation: return {"accel", "jd", "max_velocity"};
    case machine::JunctionPolicy::classic_jerk: return {"accel", "jerk", "max_velocity"};
  }
  return {"accel", "max_velocity"};
}

double get_limit(const machine::Machine& m, const std::string& name) {
  const bool klipper = m.firmware == machine::Firmware::klipper;
  if (name == "accel") return klipper ? m.max_accel_mm_s2 : m.print_accel_mm_s2;
  if (name == "scv") return m.square_corner_velocity_mm_s;
  if (name == "jd") return m.junction_deviation_mm;
  if (name == "jerk") return m.jerk_mm_s[0];
  if (name == "max_velocity") return klipper ? m.max_velocity_mm_s : m.max_feedrate_mm_s[0];
  std::string all;
  for (const auto& s : calibratable_limits()) all += (all.empty() ? "" : ", ") + s;
  throw Error(fmt::format("unknown machine limit '{}' (can fit: {})", name, all));
}

void set_limit(machine::Machine& m, const std::string& name, double v) {
  require_positive(name, v);
  if (name == "accel") {
    m.max_accel_mm_s2 = v;
    m.print_accel_mm_s2 = m.travel_accel_mm_s2 = m.retract_accel_mm_s2 = v;
    // Marlin caps each axis by M201 too; let the fitted value govern X and Y.
    m.max_axis_accel_mm_s2[0] = std::max(m.max_axis_accel_mm_s2[0], v);
    m.max_axis_accel_mm_s2[1] = std::max(m.max_axis_accel_mm_s2[1], v);
  } else if (name == "scv") {
    m.square_corner_velocity_mm_s = v;
  } else if (name == "jd") {
    m.junction_deviation_mm = v;
  } else if (name == "jerk") {
    m.jerk_mm_s[0] = m.jerk_mm_s[1] = v;
  } else if (name == "max_velocity") {
    m.max_velocity_mm_s = v;
    m.max_feedrate_mm_s[0] = m.max_feedrate_mm_s[1] = v;
  } else {
    (void)get_limit(m, name);  // throws the "unknown limit" error
  }
}

std::vector<CalibrationParameter> limit_parameters(const machine::Machine& m,
                                                   const std::vector<std::string>& names) {
  std::vector<CalibrationParameter> out;
  for (const auto& n : names) {
    CalibrationParameter p;
    p.name = n;
    p.initial = get_limit(m, n);
    if (n == "accel") { p.lower = 10; p.upper = 1e6; }
    else if (n == "scv") { p.lower = 0.01; p.upper = 1000; }
    else if (n == "jd") { p.lower = 1e-5; p.upper = 10; }
    else if (n == "jerk") { p.lower = 0.01; p.upper = 1000; }
    else { p.lower = 1; p.upper = 5000; }
    p.initial = std::clamp(p.initial, p.lower, p.upper);
    out.push_back(p);
  }
  return out;
}

DurationEstimator planner_duration_estimator(const machine::Machine& base,
                                             const std::vector<std::string>& names,
                                             const std::vector<PrintTiming>& timings,
                                             plan::FileLimits file_limits) {
  for (const auto& n : names) (void)get_limit(base, n);
  // Load each distinct file once.
  auto texts = std::make_shared<std::map<std::string, std::string>>();
  for (const auto& t : timings) {
    if (texts->count(t.gcode_path)) continue;
    (*texts)[t.gcode_path] = read_file_bytes(t.gcode_path, "G-code file", 1ull << 30);
  }
  plan::EstimateOptions options;
  options.planner.file_limits = file_limits;
  return [base, names, timings, texts, options](const std::vector<double>& p) {
    machine::Machine m = base;
    for (std::size_t i = 0; i < names.size(); ++i) set_limit(m, names[i], p[i]);
    std::map<std::string, plan::EstimateReport> reports;
    std::vector<double> out;
    for (const auto& t : timings) {
      auto it = reports.find(t.gcode_path);
      if (it == reports.end()) {
        it = reports.emplace(t.gcode_path,
                             plan::estimate_text(texts->at(t.gcode_path), t.gcode_path, m, options)).first;
      }
      const auto& r = it->second;
      if (!t.layer) {
        out.push_back(r.total_time_s);
        continue;
      }
      const auto lt = std::find_if(r.layers.begin(), r.layers.end(),
                                   [&](const plan::LayerTime& l) { return l.layer == *t.layer; });
      if (lt == r.layers.end()) {
        throw Error(fmt::format("{}: no layer {} in the G-code ({} layers)", t.gcode_path,
                                *t.layer, r.layers.size()));
      }
      out.push_back(lt->time_s);
    }
    return out;
  };
}

}  // namespace amctl::process
