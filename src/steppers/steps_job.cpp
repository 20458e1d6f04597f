// `amctl steps`: G-code and machine to steps, the CSV and the report.
#include <cmath>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/steppers/shaped_steps.hpp"
#include "amctl/steppers/step_filter.hpp"
#include "amctl/steppers/step_rate.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {

using plan::PlannedMove;


std::uint64_t StepsReport::total_steps() const {
  std::uint64_t n = 0;
  for (const StepperStats& s : stats) n += s.steps;
  return n;
}

StepFilter step_filter_from_string(std::string_view name, std::string_view flag) {
  if (name == "none") return StepFilter::none;
  if (name == "klipper") return StepFilter::klipper;
  throw Error(fmt::format("{} '{}': expected none or klipper", flag, name));
}

const char* to_string(StepFilter f) { return f == StepFilter::klipper ? "klipper" : "none"; }

StepsReport generate_steps_file(const std::string& gcode_path, const machine::Machine& m,
                                const std::string& csv_path, StepFilter filter,
                                const LargeCsvCallback& on_large_csv) {
  std::vector<kinematics::Motor> motors = machine::motors(m);
  std::vector<std::string> names;
  for (const kinematics::Motor& c : motors) names.push_back(c.name);
  plan::PlanSource source(gcode_path, m);
  std::unique_ptr<StepsFile> csv;
  if (!csv_path.empty()) csv = std::make_unique<StepsFile>(csv_path, names, OutputOptions{"--csv", {gcode_path}, {}});
  std::uint64_t moves = 0;
  StepDirFilter sds(motors.size());
  std::vector<Step> passed;
  StepRateMeter rates(motors.size());
  bool warned = false;
  auto on_steps = [&](std::span<const Step> steps) {
    rates.push(steps);
    if (filter == StepFilter::klipper) {
      passed.clear();
      sds.push(steps, passed);
      steps = passed;
    }
    if (csv) {
      csv->write(steps);
      if (!warned && on_large_csv && csv->bytes() >= kLargeStepsCsvBytes && !steps.empty()) {
        warned = true;
        on_large_csv(csv->bytes(), steps.back().time_s);
      }
    }
  };
  // With [input_shaper] every motor follows the shaped toolhead and with pressure advance the
  // extruder its advanced, smoothed position (shaped_steps.hpp); without either the plain
  // generator, whose output the shaped one equals then.
  // SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE in the G-code change them as Klipper does.
  const shaping::PressureAdvance pa = pressure_advance(m);
  TunedStepSink tuned(motors, m, on_steps);
  plan::CallbackSink counter([&](const PlannedMove&) { ++moves; });
  plan::Sink* sinks[] = {&tuned, &counter};
  const plan::StreamSummary& summary = plan::run_pipeline(source, sinks);
  if (filter == StepFilter::klipper) {
    passed.clear();
    sds.finish(passed);
    if (csv) csv->write(passed);
  }
  rates.finish();
  if (csv) csv->commit();
  StepsReport r;
  r.rates = rates.figures();
  r.sustained_window_s = rates.window_s();
  r.csv_bytes = csv ? csv->bytes() : 0;
  r.file = gcode_path;
  r.machine_name = m.name;
  r.kinematics = std::string(kinematics::name_of(m.kinematics));
  r.csv_path = csv_path;
  if (m.input_shaper.active()) r.input_shaper = m.input_shaper;
  if (pa.active()) {
    r.pressure_advance_s = pa.advance_s;
    r.pressure_advance_smooth_time_s = pa.smooth_time_s;
  }
  r.print_time_s = summary.end_time_s;
  r.moves = moves;
  r.motors = motors;
  r.step_filter = filter;
  if (filter == StepFilter::klipper) {
    r.stats = sds.stats();
    r.filtered_pairs = sds.pairs_removed();
  } else {
    r.stats = tuned.stats();
    r.filtered_pairs.assign(motors.size(), 0);
  }
  return r;
}

Json to_json(const StepsReport& r) {
  Json steppers = Json::array();
  for (std::size_t i = 0; i < r.motors.size(); ++i) {
    const StepperStats& s = r.stats[i];
    const bool has_pair = std::isfinite(s.min_interval_s);
    steppers.push_back(Json{
        {"name", r.motors[i].name},
        {"step_distance_mm", json_number(r.motors[i].step_distance.value)},
        {"steps", s.steps},
        {"steps_positive", s.steps_positive},
        {"steps_negative", s.steps_negative},
        {"final_position_steps", s.position_steps},
        {"min_interval_s", has_pair ? json_number(s.min_interval_s) : Json(nullptr)},
        {"peak_step_rate_steps_s",
         has_pair ? json_number(s.peak_step_rate_steps_s()) : Json(nullptr)},
        {"peak_time_s", has_pair ? json_number(s.peak_time_s) : Json(nullptr)},
        {"filtered_pairs", i < r.filtered_pairs.size() ? r.filtered_pairs[i] : 0},
    });
    if (i < r.rates.size()) {
      const StepRateFigures& f = r.rates[i];
      const bool has_filtered_pair = std::isfinite(f.filtered_min_interval_s);
      Json& j = steppers.back();
      j["filtered_peak_step_rate_steps_s"] =
          has_filtered_pair ? json_number(f.filtered_peak_step_rate_steps_s()) : Json(nullptr);
      j["filtered_peak_time_s"] =
          has_filtered_pair ? json_number(f.filtered_peak_time_s) : Json(nullptr);
      j["sustained_step_rate_steps_s"] = json_number(f.sustained_step_rate_steps_s);
      j["sustained_time_s"] =
          std::isfinite(f.sustained_time_s) ? json_number(f.sustained_time_s) : Json(nullptr);
    }
  }
  const auto axis_shaper = [&](const std::string& type, double freq, double zeta) {
    if (!(freq > 0.0)) return Json(nullptr);
    return Json{{"type", type}, {"freq_hz", json_number(freq)}, {"damping_ratio", json_number(zeta)}};
  };
  const machine::InputShaper& is = r.input_shaper;
  const Json shaper = is.active() ? Json{{"x", axis_shaper(is.shaper_type_x, is.shaper_freq_x_hz,
                                                          is.damping_ratio_x)},
                                         {"y", axis_shaper(is.shaper_type_y, is.shaper_freq_y_hz,
                                                          is.damping_ratio_y)},
                                         {"z", axis_shaper(is.shaper_type_z, is.shaper_freq_z_hz,
                                                          is.damping_ratio_z)}}
                                  : Json(nullptr);
  const Json advance = r.pressure_advance_s > 0.0
                           ? Json{{"advance_s", json_number(r.pressure_advance_s)},
                                  {"smooth_time_s", json_number(r.pressure_advance_smooth_time_s)}}
                           : Json(nullptr);
  return Json{{"file", r.file},
              {"machine", r.machine_name},
              {"step_filter", to_string(r.step_filter)},
              {"input_shaper", shaper},
              {"pressure_advance", advance},
              {"kinematics", r.kinematics},
              {"csv", r.csv_path.empty() ? Json(nullptr) : Json(r.csv_path)},
              {"print_time_s", json_number(r.print_time_s)},
              {"moves", r.moves},
              {"total_steps", r.total_steps()},
              {"sustained_window_s", json_number(r.sustained_window_s)},
              {"csv_bytes", r.csv_path.empty() ? Json(nullptr) : Json(r.csv_bytes)},
              {"steppers", steppers}};
}

}  // namespace amctl::steppers
