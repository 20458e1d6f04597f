// Closed-loop stepper simulation: the binding calls closedloop::stepper_simulate, the one
// library function `amctl stepper simulate` calls (apps/amctl/cmd_stepper.cpp), with the GIL
// released, and returns its JSON form as a dict.
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/process/atomic_file.hpp"
#include "amctl/report/line_chart.hpp"
#include "amctl/report/stepper_sweep_chart.hpp"
#include "common.hpp"

#include <pybind11/stl.h>

namespace amctl::py_bind {
namespace {

// The numeric overrides by keyword (< 0: default), the fields of SimulateRequest.
std::optional<double>* override_field(closedloop::SimulateRequest& r, const std::string& name) {
  if (name == "kp") return &r.kp;
  if (name == "ki") return &r.ki_per_s;
  if (name == "kd") return &r.kd_s;
  if (name == "alpha") return &r.alpha_per_s;
  if (name == "speed_change_mm_s") return &r.speed_change_mm_s;
  if (name == "drag_n") return &r.drag_force_n;
  if (name == "drag_n_s_per_m") return &r.drag_n_s_per_m;
  if (name == "bump_n") return &r.bump_force_n;
  if (name == "end_load_n_per_mm") return &r.end_load_n_per_mm;
  if (name == "backlash_mm") return &r.backlash_mm;
  if (name == "run_current_a") return &r.run_current_a;
  if (name == "max_current_a") return &r.max_current_a;
  if (name == "drag_gain") return &r.drag_gain_per_s;
  if (name == "load_angle_deg") return &r.load_angle_deg;
  if (name == "model_mass_scale") return &r.model_mass_scale;
  if (name == "model_stiffness_scale") return &r.model_stiffness_scale;
  if (name == "encoder_rate_hz") return &r.encoder_rate_hz;
  if (name == "encoder_resolution_um") return &r.encoder_resolution_um;
  throw Error("stepper_simulate: unknown option '" + name + "'");
}

py::object stepper_simulate(const std::string& path, const MachineValue& mv,
                            const std::string& controller, const std::string& scenario,
                            double speed_mm_s, bool load, const std::string& csv,
                            const std::map<std::string, double>& overrides, double corrupt,
                            bool governor) {
  closedloop::SimulateRequest r;
  r.governor = governor;
  for (const auto& [name, value] : overrides) *override_field(r, name) = value;
  r.file = path;
  r.scenario = scenario;
  r.controller = controller;
  r.speed_mm_s = speed_mm_s;
  r.load = load;
  r.csv_path = csv;
  r.corrupt_probability = corrupt;
  Json j;
  {
    py::gil_scoped_release nogil;
    j = closedloop::to_json(closedloop::stepper_simulate(mv.m, r));
  }
  return to_python(j);
}

py::object stepper_sweep(const MachineValue& mv, bool load, const std::string& csv,
                         const std::string& svg) {
  Json j;
  {
    py::gil_scoped_release nogil;
    const std::vector<closedloop::SweepRow> rows = closedloop::stepper_sweep(mv.m, load);
    // Both outputs are built before either is written (as `amctl stepper sweep`).
    const std::string table = closedloop::sweep_csv(rows);
    const std::string chart =
        svg.empty() ? "" : report::to_svg(report::stepper_sweep_chart(rows, load));
    for (const auto& [path, text] : {std::pair{csv, table}, std::pair{svg, chart}}) {
      if (path.empty()) continue;
      process::AtomicFileWriter w(path);
      w.write(text);
      w.commit();
    }
    j = closedloop::sweep_json(rows);
  }
  return to_python(j);
}

}  // namespace

void register_closedloop(py::module_& m) {
  m.def("_stepper_sweep", &stepper_sweep, py::arg("machine"), py::arg("load"), py::arg("csv"),
        py::arg("svg"), "amctl stepper sweep --json [--csv] [--svg]; see amctl.stepper_sweep.");
  m.def("_stepper_simulate", &stepper_simulate, py::arg("path"), py::arg("machine"),
        py::arg("controller"), py::arg("scenario"), py::arg("speed_mm_s"), py::arg("load"),
        py::arg("csv"), py::arg("overrides"), py::arg("corrupt"), py::arg("governor"),
        "amctl stepper simulate --json (closedloop::stepper_simulate + to_json); see "
        "amctl.stepper_simulate.");
}

}  // namespace amctl::py_bind
