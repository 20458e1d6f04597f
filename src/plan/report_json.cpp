#include "amctl/plan/report_json.hpp"

#include <cctype>

#include "amctl/machine/loader.hpp"
#include "amctl/plan/profile_peaks.hpp"

namespace amctl::plan {

std::string explain_unknown_command(const std::string& name) {
  if (name == "G2" || name == "G3" || name == "G17" || name == "G18" || name == "G19") {
    return "an arc command, but the machine has no arcs (Klipper without [gcode_arcs] answers "
           "\"Unknown command\"); skipped, no motion";
  }
  if (!name.empty() && (name[0] == 'G' || name[0] == 'M') && name.size() > 1 &&
      std::isdigit(static_cast<unsigned char>(name[1]))) {
    return "not a command amctl models; skipped (no motion assumed)";
  }
  return "not a built-in command (a printer macro?); skipped, its time is not counted";
}

Json to_json(const EstimateReport& r, const machine::Machine& m, double compute_s) {
  Json j;
  j["file"] = r.file;
  j["machine"] = {{"name", m.name},
                  {"firmware", std::string(machine::to_string(m.firmware))},
                  {"kinematics", std::string(kinematics::name_of(m.kinematics))},
                  {"junction", std::string(machine::to_string(m.junction))}};
  j["total_time_s"] = r.total_time_s;
  j["motion_time_s"] = r.motion_time_s;
  j["dwell_time_s"] = r.dwell_time_s;
  j["extrude_time_s"] = r.extrude_time_s;
  j["travel_time_s"] = r.travel_time_s;
  j["extrude_only_time_s"] = r.extrude_only_time_s;
  j["extrude_path_mm"] = r.extrude_path_mm;
  j["travel_mm"] = r.travel_mm;
  j["filament_mm"] = r.filament_mm;
  j["filament_volume_mm3"] = r.filament_volume_mm3;
  j["max_speed_mm_s"] = r.max_speed_mm_s;
  j["moves"] = r.moves;
  j["lines"] = r.lines;
  j["bytes"] = r.bytes;
  j["slicer"] = r.slicer_name;
  j["slicer_estimate_s"] = r.slicer_estimate_s ? Json(*r.slicer_estimate_s) : Json(nullptr);
  if (r.slicer_estimate_s && r.total_time_s > 0) {
    j["slicer_vs_amctl_ratio"] = *r.slicer_estimate_s / r.total_time_s;
  }
  Json feats = Json::array();
  for (const auto& f : r.features) {
    feats.push_back({{"name", f.name}, {"time_s", f.time_s}, {"extrude_time_s", f.extrude_time_s},
                     {"path_mm", f.path_mm}, {"filament_mm", f.filament_mm}, {"moves", f.moves}});
  }
  j["features"] = std::move(feats);
  Json layers = Json::array();
  for (const auto& l : r.layers) {
    layers.push_back({{"layer", l.layer}, {"start_s", l.start_s}, {"time_s", l.time_s},
                      {"z_mm", l.z_mm}, {"line", l.first_line}});
  }
  j["layers"] = std::move(layers);  // no copy: one row per layer, thousands on big prints
  auto events = [](const std::vector<TimedEvent>& v) {
    Json a = Json::array();
    for (const auto& e : v) a.push_back({{"at_s", e.at_s}, {"what", e.what}, {"line", e.line}});
    return a;
  };
  j["heater_waits"] = events(r.heater_waits);
  j["heater_sets"] = events(r.heater_sets);
  j["untimed_commands"] = events(r.untimed);
  j["pauses"] = events(r.pauses);
  if (r.range_error) {
    const RangeError& e = *r.range_error;
    j["range_error"] = {{"line", e.line}, {"axis", std::string(1, e.axis)},
                        {"position_mm", e.position_mm}, {"limit_mm", e.limit_mm}, {"at_s", e.at_s}};
  } else {
    j["range_error"] = nullptr;
  }
  j["clamped_moves"] = r.diagnostics.clamped_moves;
  Json excluded = Json::array();
  for (const auto& o : r.excluded_objects) excluded.push_back({{"name", o.name}, {"first_line", o.first_line}});
  j["excluded_objects"] = std::move(excluded);
  j["excluded_moves"] = r.excluded_moves;
  j["exclusion_time_saved_s"] =
      r.exclusion_time_saved_s ? json_number(*r.exclusion_time_saved_s) : Json(nullptr);
  Json unk = Json::array();
  for (const auto& u : r.unknown_commands) {
    unk.push_back({{"name", u.name}, {"first_line", u.first_line}, {"count", u.count},
                   {"explanation", explain_unknown_command(u.name)}});
  }
  j["unknown_commands"] = unk;
  j["ignored_commands"] = r.ignored_commands;
  Json macros = Json::array();
  for (const auto& m : r.macros) {
    macros.push_back({{"name", m.name},
                      {"description", m.description},
                      {"defined_at", m.defined_at.to_string()},
                      {"calls", m.calls},
                      {"expanded", m.expanded},
                      {"skipped", m.skipped},
                      {"first_line", m.first_line},
                      {"skip_reason", m.skip_reason.empty() ? Json(nullptr) : Json(m.skip_reason)},
                      {"first_skipped_line", m.skipped > 0 ? Json(m.first_skipped_line) : Json(nullptr)}});
  }
  j["macros"] = std::move(macros);
  j["warnings"] = r.diagnostics.warnings;
  if (r.ended_without_newline) {
    j["warnings"].push_back("the file does not end with a newline: it may be truncated");
  }
  j["planner"] = {{"full_stops", r.diagnostics.full_stops},
                  {"speed_limited_moves", r.diagnostics.speed_limited_moves},
                  {"extrude_only_moves", r.diagnostics.extrude_only_moves},
                  {"zero_length_moves", r.diagnostics.zero_length_moves},
                  {"forced_flushes", r.diagnostics.forced_flushes}};
  j["file_limits"] = to_json(r.diagnostics.file_limits);
  j["skipped_lines"] = r.skipped_lines;
  j["compute_time_s"] = compute_s;
  return j;
}

Json to_json(const FileLimitsReport& f) {
  Json cmds = Json::array();
  for (const auto& c : f.by_command) {
    cmds.push_back({{"command", c.command}, {"lines", c.lines}, {"first_line", c.first_line},
                    {"firmware_acts", c.firmware_acts}});
  }
  Json values = Json::array();
  for (const auto& v : f.values) {
    values.push_back({{"command", v.command}, {"parameter", v.parameter}, {"unit", v.unit},
                      {"count", v.count}, {"first_line", v.first_line}, {"min", v.min},
                      {"max", v.max}, {"values", v.values}, {"more_values", v.more_values}});
  }
  return {{"policy", std::string(to_string(f.policy))},
          {"commands", f.commands},
          {"other_firmware_commands", f.other_firmware_commands},
          {"capped", f.capped},
          {"ignored", f.ignored},
          {"by_command", std::move(cmds)},
          {"values", std::move(values)}};
}

std::vector<ProfileRun> compare_profiles(const GcodeInput& input, const machine::Machine& machine,
                                         bool strict) {
  RewindableGcode path(input);
  std::vector<ProfileRun> runs;
  for (auto p : {machine::VelocityProfile::trapezoid, machine::VelocityProfile::bezier5,
                 machine::VelocityProfile::scurve7}) {
    machine::Machine m = machine;
    m.profile = p;
    SourceOptions so;
    so.strict = strict;
    PlanSource source(path, m, so);
    EstimateSink estimate(m);
    ProfilePeaksSink peaks;
    Sink* sinks[] = {&estimate, &peaks};
    run_pipeline(source, sinks);
    ProfileRun run;
    run.profile = p;
    run.jerk_limit_mm_s3 = p == machine::VelocityProfile::scurve7 ? m.max_jerk_mm_s3 : 0.0;
    run.total_time_s = estimate.report().total_time_s;
    run.moves = estimate.report().moves;
    run.peak_accel_mm_s2 = peaks.peaks().peak_accel_mm_s2;
    run.peak_jerk_mm_s3 = peaks.peaks().peak_jerk_mm_s3;
    runs.push_back(run);
  }
  return runs;
}

Json to_json(const std::vector<ProfileRun>& runs, const std::string& file,
             const machine::Machine& m) {
  const double base = runs.empty() ? 0.0 : runs.front().total_time_s;
  Json j;
  j["file"] = file;
  j["machine"] = m.name;
  j["max_jerk_mm_s3"] = m.max_jerk_mm_s3;
  Json arr = Json::array();
  for (const auto& r : runs) {
    arr.push_back({{"profile", std::string(machine::to_string(r.profile))},
                   {"total_time_s", r.total_time_s},
                   {"peak_accel_mm_s2", r.peak_accel_mm_s2},
                   // The trapezoid's jerk is a step (unbounded): null.
                   {"peak_jerk_mm_s3", json_number(r.peak_jerk_mm_s3)},
                   {"jerk_limit_mm_s3", r.jerk_limit_mm_s3 > 0 ? Json(r.jerk_limit_mm_s3) : Json(nullptr)},
                   {"time_vs_trapezoid", base > 0 ? r.total_time_s / base : 0.0},
                   {"moves", r.moves}});
  }
  j["profiles"] = arr;
  return j;
}

Json to_json(const std::vector<EstimateRow>& rows, const machine::Machine& machine) {
  Json files = Json::array();
  for (const EstimateRow& r : rows) {
    if (r.report) {
      Json j = to_json(*r.report, machine, r.compute_time_s);
      j["no_moves"] = r.no_moves();
      files.push_back(std::move(j));
    } else {
      files.push_back(Json{{"file", r.file}, {"error", r.error}});
    }
  }
  return Json{{"machine", machine.name}, {"files", std::move(files)}};
}

}  // namespace amctl::plan
