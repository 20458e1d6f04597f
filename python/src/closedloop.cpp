// Closed-loop stepper simulation: the binding calls closedloop::stepper_simulate, the one
// library function `amctl stepper simulate` calls (apps/amctl/cmd_stepper.cpp), with the GIL
// released, and returns its JSON form as a dict.
#include <string>

#include "amctl/closedloop/simulate.hpp"
#include "common.hpp"

namespace amctl::py_bind {
namespace {

py::object stepper_simulate(const std::string& path, const MachineValue& mv,
                            const std::string& controller, const std::string& scenario,
                            double speed_mm_s, bool load, const std::string& csv, double kp,
                            double ki, double kd, double alpha, double corrupt) {
  closedloop::SimulateRequest r;
  r.file = path;
  r.scenario = scenario;
  r.controller = controller;
  r.speed_mm_s = speed_mm_s;
  r.load = load;
  r.csv_path = csv;
  r.kp = kp;
  r.ki_per_s = ki;
  r.kd_s = kd;
  r.alpha_per_s = alpha;
  r.corrupt_probability = corrupt;
  Json j;
  {
    py::gil_scoped_release nogil;
    j = closedloop::to_json(closedloop::stepper_simulate(mv.m, r));
  }
  return to_python(j);
}

}  // namespace

void register_closedloop(py::module_& m) {
  m.def("_stepper_simulate", &stepper_simulate, py::arg("path"), py::arg("machine"),
        py::arg("controller"), py::arg("scenario"), py::arg("speed_mm_s"), py::arg("load"),
        py::arg("csv"), py::arg("kp"), py::arg("ki"), py::arg("kd"), py::arg("alpha"),
        py::arg("corrupt"),
        "amctl stepper simulate --json (closedloop::stepper_simulate + to_json); see "
        "amctl.stepper_simulate.");
}

}  // namespace amctl::py_bind
