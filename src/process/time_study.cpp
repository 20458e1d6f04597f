#include "amctl/process/time_study.hpp"
#include "amctl/core/text_input.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/json_file.hpp"

namespace amctl::process {
namespace {

std::vector<double> numbers_at(const JsonFile& f, const std::string& at) {
  const Json& v = f.root().at(Json::json_pointer(at));
  if (!v.is_array()) f.fail(at, fmt::format("'{}' must be an array of numbers", at.substr(at.rfind('/') + 1)));
  std::vector<double> out;
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(f.number(fmt::format("{}/{}", at, i)));
  return out;
}

// "--fix" values: one number.
double fix_value(const std::string& text) {
  double v = 0.0;
  try {
    std::size_t used = 0;
    v = std::stod(text, &used);
    if (used != text.size()) throw std::invalid_argument(text);
  } catch (const std::exception&) {
    throw Error(fmt::format("--fix: expected comma-separated numbers, got '{}'", text));
  }
  return v;
}

Json layer_json(const std::optional<long>& layer) { return layer ? Json(*layer) : Json(nullptr); }

}  // namespace

EmpiricalParams parse_empirical_params(const std::string& text, const std::string& name) {
  const JsonFile f = JsonFile::parse(text, name);
  std::string at;
  if (f.root().is_object() && f.root().contains("model")) at = "/model";
  const Json& j = f.root().at(Json::json_pointer(at));
  if (!j.is_object()) f.fail(at, "expected a JSON object of empirical parameters");
  // Every key must be one amctl reads: a misspelt key silently left at its default would fit
  // or estimate with the wrong parameters.
  static constexpr std::string_view kKeys[] = {
      "raster_speed_mm_s", "contour_speed_mm_s", "link_widths_mm", "link_speeds_mm_s",
      "travel_speed_mm_s", "layer_change_s",     "retract_s",      "wipe_s",
      "fixed_s",           "link_length_widths", "filament_diameter_mm"};
  for (const auto& [key, value] : j.items()) {
    if (std::find(std::begin(kKeys), std::end(kKeys), key) != std::end(kKeys)) continue;
    std::string known;
    for (std::string_view k : kKeys) known += (known.empty() ? "" : ", ") + std::string(k);
    f.fail(at + "/" + key, fmt::format("unknown key '{}', expected one of {}", key, known));
  }
  EmpiricalParams p;
  auto& m = p.model;
  auto num = [&](const char* key, double& v) {
    if (j.contains(key)) v = f.number(at + "/" + key);
  };
  num("raster_speed_mm_s", m.raster_speed_mm_s);
  num("contour_speed_mm_s", m.contour_speed_mm_s);
  if (j.contains("link_widths_mm")) m.link_widths_mm = numbers_at(f, at + "/link_widths_mm");
  if (j.contains("link_speeds_mm_s")) m.link_speeds_mm_s = numbers_at(f, at + "/link_speeds_mm_s");
  num("travel_speed_mm_s", m.travel_speed_mm_s);
  num("layer_change_s", m.layer_change_s);
  num("retract_s", m.retract_s);
  num("wipe_s", m.wipe_s);
  num("fixed_s", m.fixed_s);
  num("link_length_widths", p.scan.link_length_widths);
  num("filament_diameter_mm", p.scan.filament_diameter_mm);
  p.scan.link_widths_mm = m.link_widths_mm;
  try {
    m.validate();
  } catch (const Error& e) {
    f.fail(at, e.detail());
  }
  return p;
}

EmpiricalParams read_empirical_params(const std::string& path) {
  if (path.empty()) {
    EmpiricalParams p;
    p.scan.link_widths_mm = p.model.link_widths_mm;
    return p;
  }
  return parse_empirical_params(read_whole_text(path, InputOptions{"parameters file (JSON)", false, 64ull << 20}), path);
}

Json empirical_params_json(const EmpiricalTimeModel& m, const ScanOptions& so) {
  return {{"raster_speed_mm_s", m.raster_speed_mm_s},
          {"contour_speed_mm_s", m.contour_speed_mm_s},
          {"link_widths_mm", m.link_widths_mm},
          {"link_speeds_mm_s", m.link_speeds_mm_s},
          {"travel_speed_mm_s", m.travel_speed_mm_s},
          {"layer_change_s", m.layer_change_s},
          {"retract_s", m.retract_s},
          {"wipe_s", m.wipe_s},
          {"fixed_s", m.fixed_s},
          {"link_length_widths", so.link_length_widths},
          {"filament_diameter_mm", so.filament_diameter_mm}};
}

EmpiricalEstimate estimate_empirical(const std::string& gcode_path, const std::string& params_path) {
  EmpiricalEstimate e;
  e.file = gcode_path;
  e.params = read_empirical_params(params_path);
  e.scan = scan_gcode_file_for_time(gcode_path, e.params.scan);
  e.total_time_s = e.params.model.estimate_s(e.scan.total);
  e.params_file = params_path;
  if (params_path.empty()) {
    e.caveat = fmt::format(
        "uncalibrated: no --params, so these are the average head speeds measured on a Stratasys FDM "
        "2000 in the UTFPR process-planning study (rasters {:.2f} mm/s), not this printer's; calibrate "
        "on a few timed prints (amctl calibrate-time TIMES.csv --mode empirical --save P.json) and pass "
        "--params P.json, or use the planner (the default mode)",
        e.params.model.raster_speed_mm_s);
  }
  return e;
}

Json empirical_estimate_json(const EmpiricalEstimate& e) {
  const auto& m = e.params.model;
  const auto& f = e.scan.total;
  const auto names = empirical_parameter_names(m);
  const auto row = empirical_row(f, m);
  const auto p = empirical_parameters(m);
  Json terms = Json::object();
  for (std::size_t i = 0; i < names.size(); ++i) terms[names[i]] = row[i] * p[i];
  const Json features{{"raster_mm", f.raster_mm},     {"contour_mm", f.contour_mm},
                      {"link_mm", f.link_mm},         {"link_mm_by_width", f.link_mm_by_width},
                      {"travel_mm", f.travel_mm},     {"layer_changes", f.layer_changes},
                      {"retracts", f.retracts},       {"wipes", f.wipes},
                      {"time_terms_s", terms}};
  return {{"file", e.file},
          {"mode", "empirical"},
          {"params_file", e.params_file.empty() ? Json(nullptr) : Json(e.params_file)},
          {"caveat", e.caveat.empty() ? Json(nullptr) : Json(e.caveat)},
          {"total_time_s", e.total_time_s},
          {"model", empirical_params_json(m, e.params.scan)},
          {"features", features},
          {"layers", e.scan.layers.size()},
          {"mean_raster_width_mm", e.scan.mean_raster_width_mm},
          {"slicer_estimate_s",
           e.scan.slicer_estimate_s ? Json(*e.scan.slicer_estimate_s) : Json(nullptr)}};
}

std::string empirical_estimate_text(const EmpiricalEstimate& e) {
  const double t = e.total_time_s;
  const auto& f = e.scan.total;
  return fmt::format("{}: empirical {:.1f} s ({:.2f} min); raster {:.0f} mm, links {:.0f} mm, "
                     "contour {:.0f} mm, travel {:.0f} mm, {} layers\n{}",
                     e.file, t, t / 60, f.raster_mm, f.link_mm, f.contour_mm, f.travel_mm,
                     e.scan.layers.size(), e.caveat.empty() ? "" : "  caveat: " + e.caveat + "\n");
}

TimeCalibration calibrate_empirical_time(const EmpiricalCalibrationRequest& q) {
  TimeCalibration c;
  c.file = q.timings_csv;
  c.timings = read_print_timings(CsvTable::read(q.timings_csv));
  for (const auto& t : c.timings) c.measured_s.push_back(t.duration_s);
  auto params = read_empirical_params(q.params_path);
  c.scan = params.scan;
  EmpiricalFitOptions fo;
  fo.contour_equals_raster = !q.separate_contour;
  const auto names = empirical_parameter_names(params.model);
  auto values = empirical_parameters(params.model);
  for (const auto& f : q.fix) {
    const auto eq = f.find('=');
    const std::string name = f.substr(0, eq);
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) throw Error(fmt::format("--fix: unknown parameter '{}'", name));
    if (eq != std::string::npos) {
      values[static_cast<std::size_t>(it - names.begin())] = fix_value(f.substr(eq + 1));
    }
    fo.fixed.push_back(name);
  }
  const auto model = with_parameters(params.model, values);
  std::map<std::string, GcodeTimeScan> scans;  // each file scanned once
  std::vector<TimeFeatures> xs;
  for (const auto& t : c.timings) {
    auto it = scans.find(t.gcode_path);
    if (it == scans.end()) {
      it = scans.emplace(t.gcode_path, scan_gcode_file_for_time(t.gcode_path, c.scan)).first;
    }
    if (!t.layer) {
      xs.push_back(it->second.total);
    } else {
      if (*t.layer >= static_cast<long>(it->second.layers.size())) {
        throw Error(fmt::format("{}:{}: {} has no layer {}", q.timings_csv, t.csv_line,
                                t.gcode_path, *t.layer));
      }
      xs.push_back(it->second.layers[static_cast<std::size_t>(*t.layer)]);
    }
  }
  c.empirical = fit_empirical(xs, c.measured_s, model, fo);
  return c;
}

TimeCalibration calibrate_planner_time(const PlannerCalibrationRequest& q) {
  TimeCalibration c;
  c.file = q.timings_csv;
  c.timings = read_print_timings(CsvTable::read(q.timings_csv));
  for (const auto& t : c.timings) c.measured_s.push_back(t.duration_s);
  const auto names = q.limits.empty() ? default_limits_for(q.machine) : q.limits;
  c.start = limit_parameters(q.machine, names);
  const auto est = planner_duration_estimator(q.machine, names, c.timings, q.file_limits);
  // Repeated timings of one print are one equation: as many different prints (or layers) as
  // parameters are needed, however often each was timed.
  std::set<std::pair<std::string, long>> distinct;
  for (const auto& t : c.timings) distinct.emplace(t.gcode_path, t.layer.value_or(-1));
  if (c.timings.size() >= c.start.size() && distinct.size() < c.start.size()) {
    throw Error(SourceLocation{q.timings_csv, 0, 0},
                fmt::format("found {} timing(s) of {} different print(s), expected at least {} different "
                            "prints (one per fitted parameter: {}); time more prints or fit fewer parameters",
                            c.timings.size(), distinct.size(), c.start.size(), fmt::join(names, ", ")));
  }
  CalibrationOptions co;
  co.relative = !q.absolute;
  c.planner = calibrate_durations(est, c.measured_s, c.start, co);
  c.calibrated = q.machine;
  for (std::size_t i = 0; i < names.size(); ++i) set_limit(c.calibrated, names[i], c.planner->values[i]);
  // What the files' own limits commands were (they override the fitted limits under keep).
  c.file_limits = q.file_limits;
  std::set<std::string> seen;
  plan::EstimateOptions eo;
  eo.planner.file_limits = q.file_limits;
  for (const auto& t : c.timings) {
    if (!seen.insert(t.gcode_path).second) continue;
    const auto n = plan::estimate_file(t.gcode_path, c.calibrated, eo).diagnostics.file_limits.commands;
    c.file_limit_commands += n;
    if (n > 0) ++c.files_setting_limits;
  }
  c.files = seen.size();
  return c;
}

Json time_calibration_json(const TimeCalibration& c) {
  Json j;
  j["file"] = c.file;
  j["mode"] = c.empirical ? "empirical" : "planner";
  j["parameters"] = Json::array();
  j["samples"] = Json::array();
  if (c.empirical) {
    const auto& fit = *c.empirical;
    for (std::size_t i = 0; i < fit.names.size(); ++i) {
      j["parameters"].push_back({{"name", fit.names[i]}, {"value", fit.values[i]},
                                 {"std_error", json_number(fit.std_errors[i])},
                                 {"free", static_cast<bool>(fit.free[i])}});
    }
    j["not_identified"] = fit.not_identified;
    j["model"] = empirical_params_json(fit.model, c.scan);
    for (std::size_t i = 0; i < c.timings.size(); ++i) {
      j["samples"].push_back({{"gcode", c.timings[i].gcode_path},
                              {"layer", layer_json(c.timings[i].layer)},
                              {"measured_s", c.measured_s[i]}, {"predicted_s", fit.predicted_s[i]},
                              {"residual_s", fit.residual_s[i]}});
    }
    j["rms_s"] = fit.rms_s;
    j["dof"] = fit.dof;
    return j;
  }
  const auto& r = *c.planner;
  j["machine"] = c.calibrated.name;
  for (std::size_t i = 0; i < r.names.size(); ++i) {
    j["parameters"].push_back({{"name", r.names[i]}, {"start", c.start[i].initial},
                               {"value", r.values[i]}, {"std_error", json_number(r.std_errors[i])},
                               {"ci", {json_number(r.ci_lo[i]), json_number(r.ci_hi[i])}},
                               {"identifiable", static_cast<bool>(r.identifiable[i])}});
  }
  j["correlation"] = r.correlation;
  j["file_limits"] = {{"policy", std::string(plan::to_string(c.file_limits))},
                      {"commands", c.file_limit_commands},
                      {"files_setting_limits", c.files_setting_limits},
                      {"files", c.files}};
  for (std::size_t i = 0; i < c.timings.size(); ++i) {
    j["samples"].push_back({{"gcode", c.timings[i].gcode_path},
                            {"layer", layer_json(c.timings[i].layer)},
                            {"measured_s", r.measured_s[i]}, {"predicted_s", r.predicted_s[i]},
                            {"residual_s", r.residual_s[i]},
                            {"relative_residual", r.relative_residual[i]}});
  }
  j["rms_s"] = r.rms_s;
  j["rms_relative"] = r.rms_relative;
  j["iterations"] = r.iterations;
  j["evaluations"] = r.evaluations;
  j["converged"] = r.converged;
  j["dof"] = r.dof;
  return j;
}

std::string time_calibration_text(const TimeCalibration& c) {
  std::string s;
  if (c.empirical) {
    const auto& fit = *c.empirical;
    for (std::size_t i = 0; i < fit.names.size(); ++i) {
      s += fmt::format("  {:<18} {:12.6g} {}\n", fit.names[i], fit.values[i],
                       fit.free[i] ? fmt::format("+- {:.3g}", fit.std_errors[i])
                                   : std::string("(fixed)"));
    }
    s += fmt::format("  speeds: raster {:.2f} mm/s, travel {:.2f} mm/s; rms residual {:.2f} s\n",
                     fit.model.raster_speed_mm_s, fit.model.travel_speed_mm_s, fit.rms_s);
    return s;
  }
  const auto& r = *c.planner;
  s += fmt::format("calibrated {} from {} timing(s), {} iteration(s){}\n", c.calibrated.name,
                   c.timings.size(), r.iterations, r.converged ? "" : " (not converged)");
  for (std::size_t i = 0; i < r.names.size(); ++i) {
    s += fmt::format("  {:<13} {:10.4g}  +- {:<9.3g} 95% CI [{:.4g}, {:.4g}]{}\n", r.names[i],
                     r.values[i], r.std_errors[i], r.ci_lo[i], r.ci_hi[i],
                     r.identifiable[i] ? "" : "  (no effect on these prints: not fitted)");
  }
  if (c.file_limit_commands > 0) {
    switch (c.file_limits) {
      case plan::FileLimits::keep:
        s += fmt::format("  the files set limits of their own ({} commands in {} of {} files): kept, "
                         "as the firmware does, they override the fitted limits while they last "
                         "(--file-limits cap or ignore to fit the machine's ceiling)\n",
                         c.file_limit_commands, c.files_setting_limits, c.files);
        break;
      case plan::FileLimits::ignore:
        s += fmt::format("  the files' own limits ({} commands in {} of {} files) ignored "
                         "(--file-limits ignore)\n", c.file_limit_commands, c.files_setting_limits, c.files);
        break;
      case plan::FileLimits::cap:
        s += fmt::format("  the files' own limits ({} commands in {} of {} files) capped at the "
                         "fitted ones (--file-limits cap)\n", c.file_limit_commands, c.files_setting_limits, c.files);
        break;
    }
  }
  for (std::size_t i = 0; i < c.timings.size(); ++i) {
    const auto& t = c.timings[i];
    s += fmt::format("  {:<40} measured {:9.1f} s  planned {:9.1f} s  residual {:+8.2f} s "
                     "({:+.2f} %)\n",
                     t.gcode_path + (t.layer ? fmt::format("#{}", *t.layer) : ""),
                     r.measured_s[i], r.predicted_s[i], r.residual_s[i],
                     100 * r.relative_residual[i]);
  }
  return s;
}

std::string time_calibration_file(const TimeCalibration& c) {
  if (c.empirical) return empirical_params_json(c.empirical->model, c.scan).dump(2) + "\n";
  return machine::to_toml(c.calibrated);
}

}  // namespace amctl::process
