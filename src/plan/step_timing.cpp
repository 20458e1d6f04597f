// Klipper's step-generation restart delay (step_timing.hpp).
#include "step_timing.hpp"

#include <algorithm>
#include <cstdlib>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::plan::detail {

namespace {

/// kin_shaper.c init_shaper: at most 10 impulses.
constexpr std::size_t kKlipperMaxImpulses = 10;

/// Klipper's pressure_advance / pressure_advance_smooth_time of a printer.cfg section.
double cfg_number(const ConfigSection& s, const std::string& key, double def) {
  const ConfigValue* v = s.find(key);
  if (v == nullptr) return def;
  char* end = nullptr;
  const std::string text(v->text);
  const double d = std::strtod(text.c_str(), &end);
  return end != text.c_str() ? d : def;
}

}  // namespace

double shaper_reach_s(const gcode::AxisShaperSetting& s) {
  if (!(s.freq_hz > 0.0)) return 0.0;
  const shaping::Shaper sh = shaping::make_shaper(s.type, s.freq_hz, s.damping_ratio);
  const double centre = sh.time_shift_s();
  return std::max(centre - sh.times_s.front(), sh.times_s.back() - centre);
}

std::optional<gcode::InterpreterOptions::StepTuning> step_tuning_of(const machine::Machine& m) {
  if (m.firmware != machine::Firmware::klipper) return std::nullopt;
  gcode::InterpreterOptions::StepTuning t;
  const machine::InputShaper& is = m.input_shaper;
  t.shapers[0] = {is.shaper_type_x, is.shaper_freq_x_hz, is.damping_ratio_x};
  t.shapers[1] = {is.shaper_type_y, is.shaper_freq_y_hz, is.damping_ratio_y};
  t.shapers[2] = {is.shaper_type_z, is.shaper_freq_z_hz, is.damping_ratio_z};
  for (auto& s : t.shapers) {
    for (char& c : s.type) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  t.input_shaper = is.active();
  if (m.extruder.present) {
    t.extruders.push_back({"extruder", m.extruder.pressure_advance_s,
                           m.extruder.pressure_advance_smooth_time_s});
  }
  for (const ConfigSection& s : m.klipper_config) {
    if (s.name == "input_shaper") t.input_shaper = true;
    // extruder.py: every [extruderN] and [extruder_stepper NAME] registers its name.
    std::string name;
    if (s.name.rfind("extruder_stepper ", 0) == 0) {
      name = s.name.substr(17);
    } else if (s.name.size() > 8 && s.name.rfind("extruder", 0) == 0 &&
               std::all_of(s.name.begin() + 8, s.name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      name = s.name;
    }
    while (!name.empty() && name.front() == ' ') name.erase(name.begin());
    if (name.empty()) continue;
    t.extruders.push_back({name, cfg_number(s, "pressure_advance", 0.0),
                           cfg_number(s, "pressure_advance_smooth_time", 0.040)});
  }
  return t;
}

StepTiming::StepTiming(const machine::Machine& m) {
  const bool none = std::holds_alternative<kinematics::None>(m.kinematics);
  axis_stepped_ = {!none, !none, !none};
  const auto t = step_tuning_of(m);
  if (!t) return;
  for (std::size_t a = 0; a < 3; ++a) shaper_reach_s_[a] = shaper_reach_s(t->shapers[a]);
  for (const auto& e : t->extruders) {
    half_smooth_s_.emplace_back(e.name, e.pressure_advance_s > 0.0 ? 0.5 * e.smooth_time_s : 0.0);
  }
}

double StepTiming::flush_delay_s() const {
  double d = kSdsCheckTimeS;
  for (std::size_t a = 0; a < 3; ++a) {
    if (axis_stepped_[a]) d = std::max(d, shaper_reach_s_[a]);
  }
  for (const auto& e : half_smooth_s_) d = std::max(d, e.second);
  return d;
}

void StepTiming::apply(const gcode::StepTuningCommand& c) {
  if (c.kind == gcode::StepTuningCommand::Kind::pressure_advance) {
    const double h = c.pressure_advance_s > 0.0 ? 0.5 * c.smooth_time_s : 0.0;
    for (auto& e : half_smooth_s_) {
      if (e.first == c.extruder) e.second = h;
    }
    return;
  }
  for (std::size_t a = 0; a < 3; ++a) {
    const gcode::AxisShaperSetting& s = c.shapers[a];
    const char axis = "xyz"[a];
    const SourceLocation at{"", c.line, c.type_column[a]};
    // input_shaper.py: shaper_defs.get_shaper_cfg knows Klipper's six types only.
    shaping::ShaperSpec spec;
    std::optional<double> max_zeta;
    try {
      spec = shaping::parse_shaper_spec(s.type);
      max_zeta = shaping::klipper_max_damping_ratio(spec.type);
    } catch (const Error&) {
    }
    if (!max_zeta) {
      throw Error(at, fmt::format("SET_INPUT_SHAPER shaper type of {}: found '{}', expected one of "
                                  "Klipper's zv, mzv, zvd, ei, 2hump_ei, 3hump_ei, optionally with "
                                  "parameters as mzv(n=4, t=0.9) (Klipper: \"Unsupported shaper "
                                  "type: {}\")", axis, s.type, s.type));
    }
    if (s.damping_ratio > *max_zeta) {
      throw Error(SourceLocation{"", c.line, c.damping_column[a] ? c.damping_column[a] : c.type_column[a]},
                  fmt::format("SET_INPUT_SHAPER damping ratio of {} must be at most {:g} for {} "
                              "(Klipper's limit: \"Too high value of damping_ratio\"), found {:g}",
                              axis, *max_zeta, s.type, s.damping_ratio));
    }
    if (!(s.freq_hz > 0.0)) {
      shaper_reach_s_[a] = 0.0;
      continue;
    }
    shaping::Shaper sh;
    try {
      sh = shaping::make_shaper(spec, s.freq_hz, s.damping_ratio);
    } catch (const Error& e) {
      throw Error(at, fmt::format("SET_INPUT_SHAPER: shaper of {}: {}", axis, e.what()));
    }
    if (sh.times_s.size() > kKlipperMaxImpulses) {
      throw Error(at, fmt::format("SET_INPUT_SHAPER: shaper of {} '{}' has {} impulses; Klipper's "
                                  "step generator takes at most {} (\"Failed to configure shaper\")",
                                  axis, s.type, sh.times_s.size(), kKlipperMaxImpulses));
    }
    const double centre = sh.time_shift_s();
    shaper_reach_s_[a] = std::max(centre - sh.times_s.front(), sh.times_s.back() - centre);
  }
}

}  // namespace amctl::plan::detail
