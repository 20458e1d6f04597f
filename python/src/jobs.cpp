// The command-line jobs that had no Python function yet, each the library call of its command
// (apps/amctl/cmd_*.cpp), with the GIL released while it runs: estimate --write-m73, estimate
// --compare-profiles, calibrate-time, shrink slicing, shrink apply, resonance recommend,
// resonance test-gcode and sweep.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "amctl/core/error.hpp"
#include "amctl/core/input.hpp"
#include "amctl/core/output.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/dynamics/seed000_sweep.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/report_json.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/shrink_apply.hpp"
#include "amctl/process/shrink_model.hpp"
#include "amctl/process/slicing_study.hpp"
#include "amctl/process/time_study.hpp"
#include "amctl/resonance/test_gcode.hpp"
#include "amctl/tuning/recommend.hpp"
#include "common.hpp"

namespace amctl::py_bind {
namespace {

namespace pr = amctl::process;

py::object write_m73(const std::string& path, const MachineValue& mv, const std::string& output,
                     double interval_s, bool strict, const std::string& file_limits) {
  if (!(interval_s > 0.0)) throw Error("interval_s: must be a number > 0, got " + std::to_string(interval_s));
  plan::EstimateOptions o;
  o.strict = strict;
  o.checkpoint_interval_s = interval_s;
  o.planner.file_limits = file_limits_arg(file_limits);
  Json j;
  {
    py::gil_scoped_release nogil;
    // One rewindable input for both passes, as the command line reads it (standard input and
    // a FIFO once; a plate of a 3MF opened again from the archive); the output checked first.
    plan::RewindableGcode input{plan::GcodeInput(path)};
    {
      const plan::GcodeInput in = input;
      OutputOptions oo{"output", {path}, {}};
      if (in.file() != nullptr && in.file()->identity()) oo.input_ids.push_back(*in.file()->identity());
      check_output(output, oo);
    }
    const plan::EstimateReport r = plan::estimate_file(input, mv.m, o);
    const std::size_t lines = plan::write_m73(input, output, r);
    j = Json{{"file", path}, {"output", output}, {"lines", lines}, {"total_time_s", r.total_time_s}};
  }
  return to_python(j);
}

py::object compare_profiles(const std::string& path, const MachineValue& mv, bool strict) {
  Json j;
  {
    py::gil_scoped_release nogil;
    j = plan::to_json(plan::compare_profiles(path, mv.m, strict), path, mv.m);
  }
  return to_python(j);
}

py::object calibrate_time(const std::string& timings_csv, const std::string& mode, const MachineValue& mv,
                          const std::vector<std::string>& fit, const std::string& file_limits, bool absolute,
                          const std::string& params, const std::vector<std::string>& fix,
                          bool separate_contour, const std::string& save) {
  if (mode != "planner" && mode != "empirical") {
    throw Error("mode: found '" + mode + "', expected planner or empirical");
  }
  Json j;
  {
    py::gil_scoped_release nogil;
    pr::TimeCalibration c;
    if (mode == "empirical") {
      c = pr::calibrate_empirical_time({timings_csv, params, fix, separate_contour});
    } else {
      pr::PlannerCalibrationRequest q;
      q.timings_csv = timings_csv;
      q.machine = mv.m;
      q.limits = fit;
      q.file_limits = file_limits_arg(file_limits);
      q.absolute = absolute;
      c = pr::calibrate_planner_time(q);
    }
    if (!save.empty()) pr::write_file_atomic(save, pr::time_calibration_file(c));
    j = pr::time_calibration_json(c);
  }
  return to_python(j);
}

py::object shrink_slicing(const std::string& csv_path, const std::string& measured_column,
                          const std::string& observed_slicing_column, const std::string& factors,
                          const std::string& scaling, double layer_mm, std::optional<double> first_layer_mm,
                          std::optional<double> plane_fraction) {
  pr::SlicingStudyRequest q;
  q.csv_path = csv_path;
  q.measured_column = measured_column;
  q.observed_slicing_column = observed_slicing_column;
  if (!factors.empty()) q.z_map = pr::parse_factor_spec(factors)[2];
  if (scaling == "none") q.scaling = pr::HeightScaling::none;
  else if (scaling == "position") q.scaling = pr::HeightScaling::position;
  else if (scaling == "dimension") q.scaling = pr::HeightScaling::dimension;
  else throw Error("scaling: found '" + scaling + "', expected dimension, position or none");
  q.layer_mm = layer_mm;
  q.first_layer_mm = first_layer_mm;
  q.plane_fraction = plane_fraction;
  Json j;
  {
    py::gil_scoped_release nogil;
    j = pr::slicing_study_json(pr::slicing_study(q));
  }
  return to_python(j);
}

py::object shrink_apply(const std::string& model, const std::string& gcode, const std::string& factors,
                        const std::string& output, std::optional<std::array<double, 3>> origin_mm,
                        const std::string& stl_format, std::optional<double> layer_mm,
                        std::optional<double> first_layer_mm, double plane_fraction, bool scale_e) {
  if (model.empty() == gcode.empty()) throw Error("shrink_apply needs exactly one of model= or gcode=");
  pr::ShrinkApplyRequest q;
  q.model_path = model;
  q.gcode_path = gcode;
  q.output_path = output;
  q.factors = pr::load_factor_maps(factors);
  q.origin_mm = origin_mm;
  if (!stl_format.empty()) {
    if (stl_format != "ascii" && stl_format != "binary") {
      throw Error("stl_format: found '" + stl_format + "', expected binary or ascii");
    }
    q.stl_format = stl_format == "ascii" ? pr::StlFormat::ascii : pr::StlFormat::binary;
  }
  if (layer_mm) q.layers = pr::SlicingModel{*layer_mm, first_layer_mm.value_or(*layer_mm), plane_fraction};
  q.scale_extrusion = scale_e;
  Json j;
  {
    py::gil_scoped_release nogil;
    j = pr::shrink_apply_json(pr::shrink_apply(q));
  }
  return to_python(j);
}

py::object resonance_recommend(double natural_frequency_hz, double damping_ratio, const MachineValue& mv,
                               std::optional<double> max_smoothing_mm) {
  Json j;
  {
    py::gil_scoped_release nogil;
    tuning::RecommendOptions o;
    if (max_smoothing_mm) o.max_smoothing_mm = *max_smoothing_mm;
    const tuning::ModalModel model{natural_frequency_hz, damping_ratio};
    j = tuning::to_json(tuning::recommend(model, mv.m, o, tuning::klipper_pick_for_model(model, max_smoothing_mm)));
  }
  return to_python(j);
}

std::string resonance_test_gcode(const MachineValue& mv, const std::string& axis, const std::string& style,
                                 std::optional<double> freq_start_hz, std::optional<double> freq_end_hz,
                                 std::optional<double> accel_per_hz, std::optional<double> accel_mm_s2,
                                 std::optional<double> hz_per_sec, std::optional<std::array<double, 3>> point_mm,
                                 bool home, const std::string& output) {
  if (axis != "x" && axis != "y") throw Error("axis: found '" + axis + "', expected x or y");
  if (style != "klipper" && style != "marlin") throw Error("style: found '" + style + "', expected klipper or marlin");
  const bool marlin = style == "marlin";
  if (marlin && accel_per_hz) throw Error("accel_per_hz applies to style='klipper'; use accel_mm_s2");
  if (!marlin && accel_mm_s2) throw Error("accel_mm_s2 applies to style='marlin'; use accel_per_hz");
  resonance::TestGcodeOptions o = resonance::machine_test_options(
      marlin ? resonance::TestStyle::marlin : resonance::TestStyle::klipper, axis[0], mv.m);
  o.home = home;
  if (freq_start_hz) o.freq_start_hz = *freq_start_hz;
  if (freq_end_hz) o.freq_end_hz = *freq_end_hz;
  if (accel_per_hz) o.accel_per_hz = *accel_per_hz;
  if (accel_mm_s2) o.accel_mm_s2 = *accel_mm_s2;
  if (hz_per_sec) o.hz_per_sec = *hz_per_sec;
  if (point_mm) {
    for (int i = 0; i < 3; ++i) o.point_mm[i] = (*point_mm)[static_cast<std::size_t>(i)];
    o.point_given = true;
    o.probe_points.clear();
    o.probe_point_locations.clear();
    o.point_source = "--point";
  }
  std::string text;
  {
    py::gil_scoped_release nogil;
    text = resonance::test_gcode(o, mv.m);  // whole text first: all or nothing
    if (!output.empty()) pr::write_file_atomic(output, text);
  }
  return text;
}

py::object sweep(double square_corner_velocity_mm_s) {
  Json j;
  {
    py::gil_scoped_release nogil;
    j = dynamics::to_json(dynamics::seed000_sweep(square_corner_velocity_mm_s), square_corner_velocity_mm_s);
  }
  return to_python(j);
}

}  // namespace

void register_jobs(py::module_& m) {
  m.def("_write_m73", &write_m73, py::arg("path"), py::arg("machine"), py::arg("output"), py::arg("interval_s"),
        py::arg("strict"), py::arg("file_limits"), "amctl estimate --write-m73 (plan::write_m73).");
  m.def("_compare_profiles", &compare_profiles, py::arg("path"), py::arg("machine"), py::arg("strict"),
        "amctl estimate --compare-profiles --json (plan::compare_profiles + to_json).");
  m.def("_calibrate_time", &calibrate_time, py::arg("timings_csv"), py::arg("mode"), py::arg("machine"),
        py::arg("fit"), py::arg("file_limits"), py::arg("absolute"), py::arg("params"), py::arg("fix"),
        py::arg("separate_contour"), py::arg("save"), "amctl calibrate-time --json.");
  m.def("_shrink_slicing", &shrink_slicing, py::arg("csv_path"), py::arg("measured_column"),
        py::arg("observed_slicing_column"), py::arg("factors"), py::arg("scaling"), py::arg("layer_mm"),
        py::arg("first_layer_mm"), py::arg("plane_fraction"), "amctl shrink slicing --json.");
  m.def("_shrink_apply", &shrink_apply, py::arg("model"), py::arg("gcode"), py::arg("factors"), py::arg("output"),
        py::arg("origin_mm"), py::arg("stl_format"), py::arg("layer_mm"), py::arg("first_layer_mm"),
        py::arg("plane_fraction"), py::arg("scale_e"), "amctl shrink apply --json.");
  m.def("_resonance_recommend", &resonance_recommend, py::arg("natural_frequency_hz"), py::arg("damping_ratio"),
        py::arg("machine"), py::arg("max_smoothing_mm"), "amctl resonance recommend --json.");
  m.def("_resonance_test_gcode", &resonance_test_gcode, py::arg("machine"), py::arg("axis"), py::arg("style"),
        py::arg("freq_start_hz"), py::arg("freq_end_hz"), py::arg("accel_per_hz"), py::arg("accel_mm_s2"),
        py::arg("hz_per_sec"), py::arg("point_mm"), py::arg("home"), py::arg("output"),
        "amctl resonance test-gcode: the program's text.");
  m.def("_sweep", &sweep, py::arg("square_corner_velocity_mm_s"), "amctl sweep --json.");
}

}  // namespace amctl::py_bind
