// Input shapers, resonance calibration and the HTML report: each binding calls the one library function the
// matching command calls (apps/amctl/cmd_shaper.cpp, cmd_resonance.cpp, cmd_report.cpp) with the GIL released
// and returns its JSON form as a dict.
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "amctl/core/output.hpp"
#include "amctl/comparison/compare.hpp"
#include "amctl/compensation/compensate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/report/html_report.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/sweep.hpp"
#include "amctl/shaping/report.hpp"
#include "amctl/steppers/steps.hpp"
#include "common.hpp"

namespace amctl::py_bind {
namespace {

py::object shaper_show(const std::string& type, double freq_hz, double damping_ratio,
                       const std::vector<double>& residual_at_hz,
                       std::optional<double> test_damping_ratio, const std::string& firmware,
                       double marlin_sample_rate_hz) {
  shaping::ShaperReportOptions o;
  if (!firmware.empty()) {
    try {
      o.firmware = shaping::parse_firmware(firmware);
    } catch (const Error& e) {
      throw Error(std::string("firmware: ") + e.what());
    }
  }
  o.marlin_sample_rate_hz = marlin_sample_rate_hz;
  o.type = type;
  o.freq_hz = freq_hz;
  o.damping_ratio = damping_ratio;
  o.residual_at_hz = residual_at_hz;
  o.test_damping_ratio = test_damping_ratio;
  // The checks of `amctl shaper show`, named by keyword.
  shaping::check_report_options(o, [](std::string_view k) { return std::string(k); });
  Json j;
  {
    py::gil_scoped_release nogil;
    j = shaping::to_json(shaping::shaper_report(o));
  }
  return to_python(j);
}

py::object resonance_calibrate(const std::vector<std::string>& paths, const std::string& axis,
                               const std::string& sweep) {
  resonance::CalibrateOptions o;
  if (axis != "x" && axis != "y" && axis != "X" && axis != "Y" && !axis.empty()) {
    throw Error("axis must be 'x', 'y' or None, got '" + axis + "'");
  }
  o.axis = axis.empty() ? '\0' : static_cast<char>(axis[0] | 0x20);
  if (!sweep.empty()) o.sweep = resonance::parse_sweep(sweep);
  Json j;
  {
    py::gil_scoped_release nogil;
    j = resonance::to_json(resonance::calibrate_files(paths, o));
  }
  return to_python(j);
}

py::object write_report(const std::string& path, const MachineValue& mv, const std::string& output,
                        std::optional<double> natural_frequency_hz, double damping_ratio,
                        double sample_rate_hz, bool strict, const std::string& accel,
                        const std::string& accel_axis, const std::string& thermal,
                        const std::string& file_limits) {
  report::ReportOptions o;
  o.file_limits = file_limits_arg(file_limits);
  o.thermal = thermal;
  o.accel_path = accel;
  if (accel_axis != "x" && accel_axis != "y") {
    throw Error("accel_axis must be 'x' or 'y', got '" + accel_axis + "'");
  }
  o.accel_axis = accel_axis[0];
  if (natural_frequency_hz) o.belt = report::BeltModelOptions{*natural_frequency_hz, damping_ratio};
  o.sample_rate_hz = sample_rate_hz;
  o.strict = strict;
  Json j;
  {
    py::gil_scoped_release nogil;
    j = report::to_json(report::write_report(path, mv.m, output, o));
  }
  return to_python(j);
}

py::object steps(const std::string& path, const MachineValue& mv, const std::string& csv,
                 const std::string& step_filter) {
  const steppers::StepFilter filter = steppers::step_filter_from_string(step_filter, "step_filter");
  Json j;
  {
    py::gil_scoped_release nogil;
    j = steppers::to_json(steppers::generate_steps_file(path, mv.m, csv, filter));
  }
  return to_python(j);
}

py::object compensate(const std::string& path, const MachineValue& mv, const std::string& method,
                      const dynamics::AxisModel& model_x, const dynamics::AxisModel& model_y,
                      const dynamics::AxisModel& plant_x, const dynamics::AxisModel& plant_y,
                      double sample_rate_hz, double lead_in_s, double tail_s, double knot_spacing_s,
                      int degree, double window_s, double overlap_s, double max_base_accel_mm_s2,
                      double effort_weight_s2, int max_iterations, const std::string& csv,
                      const std::string& gcode, bool ignore_machine_limits) {
  compensation::CompensationOptions o;
  o.judge_machine_accel = !ignore_machine_limits;
  o.method = compensation::parse_method(method);
  o.model_x = model_x;
  o.model_y = model_y;
  o.plant_x = plant_x;
  o.plant_y = plant_y;
  o.sample_rate_hz = sample_rate_hz;
  o.lead_in_s = lead_in_s;
  o.tail_s = tail_s;
  o.knot_spacing_s = knot_spacing_s;
  o.degree = degree;
  o.window_s = window_s;
  o.overlap_s = overlap_s;
  o.max_base_accel_mm_s2 = max_base_accel_mm_s2;
  o.effort_weight_s2 = effort_weight_s2;
  o.max_solver_iterations = max_iterations;
  o.sample_z_e = !gcode.empty();
  std::optional<compensation::CompensationResult> r;
  Json j;
  {
    py::gil_scoped_release nogil;
    // The outputs opened first (as `amctl compensate`): one that is the input, or cannot be
    // written, fails before the work.
    require_distinct_outputs(csv, "csv", gcode, "gcode");
    std::optional<compensation::CommandTable> csv_out;
    std::optional<OutputFile> gcode_out;
    if (!csv.empty()) csv_out.emplace(csv, OutputOptions{"csv", {path}, {}});
    if (!gcode.empty()) gcode_out.emplace(gcode, OutputOptions{"gcode", {path}, {}});
    r = compensation::compensate_file(path, mv.m, o);
    // No command (collocation: an infeasible bound): the status says so, no CSV.
    if (!r->t_s.empty()) {
      if (gcode_out) compensation::write_gcode(*r, *gcode_out);
      if (csv_out) compensation::write_table(*r, *csv_out);
      if (gcode_out) gcode_out->commit();
      if (csv_out) csv_out->commit();
    }
    j = compensation::to_json(*r);
  }
  py::dict out(to_python(j));
  py::dict trace;
  trace["t_s"] = adopt(std::move(r->t_s));
  trace["x_cmd_mm"] = adopt(std::move(r->x_cmd_mm));
  trace["y_cmd_mm"] = adopt(std::move(r->y_cmd_mm));
  trace["x_des_mm"] = adopt(std::move(r->x_des_mm));
  trace["y_des_mm"] = adopt(std::move(r->y_des_mm));
  trace["x_sim_mm"] = adopt(std::move(r->x_sim_mm));
  trace["y_sim_mm"] = adopt(std::move(r->y_sim_mm));
  if (!r->x_cmd_accel_mm_s2.empty()) {  // collocation: the command's acceleration (linear between samples)
    trace["x_cmd_accel_mm_s2"] = adopt(std::move(r->x_cmd_accel_mm_s2));
    trace["y_cmd_accel_mm_s2"] = adopt(std::move(r->y_cmd_accel_mm_s2));
  }
  out["trace"] = trace;
  return out;
}

py::object compare(const std::string& path, const MachineValue& mv, double natural_frequency_hz,
                   double damping_ratio, const std::vector<std::string>& methods,
                   const std::vector<double>& plant_offsets_pct, double sample_rate_hz,
                   std::optional<int> layer, double max_base_accel_mm_s2) {
  comparison::ComparisonOptions o;
  o.max_base_accel_mm_s2 = max_base_accel_mm_s2;
  o.natural_frequency_hz = natural_frequency_hz;
  o.damping_ratio = damping_ratio;
  if (!methods.empty()) o.methods = methods;
  if (!plant_offsets_pct.empty()) o.plant_offsets_pct = plant_offsets_pct;
  o.sample_rate_hz = sample_rate_hz;
  o.layer = layer;
  Json j;
  {
    py::gil_scoped_release nogil;
    j = comparison::to_json(comparison::compare_file(path, mv.m, o));
  }
  return to_python(j);
}

}  // namespace

void register_shaping(py::module_& m) {
  m.def("_compare", &compare, py::arg("path"), py::arg("machine"), py::arg("natural_frequency_hz"),
        py::arg("damping_ratio"), py::arg("methods"), py::arg("plant_offsets_pct"),
        py::arg("sample_rate_hz"), py::arg("layer"), py::arg("max_base_accel_mm_s2"),
        "amctl compare --json (comparison::compare_file + to_json); see amctl.compare.");
  m.def("_compensate", &compensate, py::arg("path"), py::arg("machine"), py::arg("method"),
        py::arg("model_x"), py::arg("model_y"), py::arg("plant_x"), py::arg("plant_y"),
        py::arg("sample_rate_hz"), py::arg("lead_in_s"), py::arg("tail_s"), py::arg("knot_spacing_s"),
        py::arg("degree"), py::arg("window_s"), py::arg("overlap_s"), py::arg("max_base_accel_mm_s2"),
        py::arg("effort_weight_s2"), py::arg("max_iterations"), py::arg("csv"), py::arg("gcode"),
        py::arg("ignore_machine_limits") = false,
        "amctl compensate --json (compensation::compensate_file + to_json) plus the command as "
        "arrays; see amctl.compensate.");
  m.def("_steps", &steps, py::arg("path"), py::arg("machine"), py::arg("csv"), py::arg("step_filter"),
        "amctl steps --json (steppers::generate_steps_file + to_json); see amctl.steps.");
  m.def("_report", &write_report, py::arg("path"), py::arg("machine"), py::arg("output"),
        py::arg("natural_frequency_hz"), py::arg("damping_ratio"), py::arg("sample_rate_hz"),
        py::arg("strict"), py::arg("accel"), py::arg("accel_axis"), py::arg("thermal"),
        py::arg("file_limits") = "keep", "amctl report --json (report::write_report + to_json); see amctl.report.");
  m.def("_shaper_show", &shaper_show, py::arg("type"), py::arg("freq_hz"), py::arg("damping_ratio"),
        py::arg("residual_at_hz"), py::arg("test_damping_ratio"), py::arg("firmware") = "",
        py::arg("marlin_sample_rate_hz") = shaping::kMarlinFtmSampleRateHz,
        "amctl shaper show --json (shaping::shaper_report + to_json); see amctl.shaper_show.");
  m.def("_resonance_calibrate", &resonance_calibrate, py::arg("paths"), py::arg("axis"), py::arg("sweep"),
        "amctl resonance calibrate --json (resonance::calibrate_file + to_json); see "
        "amctl.resonance_calibrate.");
}

}  // namespace amctl::py_bind
