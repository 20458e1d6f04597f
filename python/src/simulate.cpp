// amctl.simulate: dynamics::simulate_print (what `amctl simulate` runs) with the GIL released,
// its JSON as a dict and, on request, the samples as numpy arrays filled through
// PrintSimulationOptions::rows and handed to numpy without a copy.
#include <cmath>
#include <optional>

#include <fmt/format.h>
#include <pybind11/stl.h>

#include "amctl/core/input.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/core/error.hpp"
#include "amctl/dynamics/print_simulation.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/simulation/shaped_simulation.hpp"
#include "common.hpp"

namespace amctl::py_bind {
namespace {

namespace dy = amctl::dynamics;

/// The sample columns, as `amctl simulate --csv` writes them (same rows: every
/// decimation-th sample inside the measured range).
struct Samples {
  std::vector<double> t_s, cmd_x_mm, cmd_y_mm, cmd_z_mm, sim_x_mm, sim_y_mm, contour_error_mm,
      vibration_mm;
  std::vector<std::uint64_t> line;
  std::size_t decimation = 1;
  std::size_t k = 0;

  void add(const dy::SimSample& s, double e) {
    if (k++ % decimation != 0 || std::isnan(e)) return;
    t_s.push_back(s.t_s);
    cmd_x_mm.push_back(s.cmd_mm[0]);
    cmd_y_mm.push_back(s.cmd_mm[1]);
    cmd_z_mm.push_back(s.cmd_mm[2]);
    sim_x_mm.push_back(s.sim_mm[0]);
    sim_y_mm.push_back(s.sim_mm[1]);
    contour_error_mm.push_back(e);
    vibration_mm.push_back(std::hypot(s.vibration_mm[0], s.vibration_mm[1]));
    line.push_back(s.line);
  }

  py::dict arrays() {
    py::dict d;
    d["t_s"] = adopt(std::move(t_s));
    d["cmd_x_mm"] = adopt(std::move(cmd_x_mm));
    d["cmd_y_mm"] = adopt(std::move(cmd_y_mm));
    d["cmd_z_mm"] = adopt(std::move(cmd_z_mm));
    d["sim_x_mm"] = adopt(std::move(sim_x_mm));
    d["sim_y_mm"] = adopt(std::move(sim_y_mm));
    d["contour_error_mm"] = adopt(std::move(contour_error_mm));
    d["vibration_mm"] = adopt(std::move(vibration_mm));
    d["line"] = adopt(std::move(line));
    return d;
  }
};

std::size_t decimation(double rate_hz, std::optional<double> samples_rate_hz) {
  const double cr = samples_rate_hz.value_or(rate_hz);
  require_positive("samples_rate_hz", cr);
  const double ratio = rate_hz / cr;
  const auto d = static_cast<std::size_t>(std::llround(ratio));
  if (d < 1 || std::abs(ratio - static_cast<double>(d)) > 1e-9 * ratio) {
    throw Error(fmt::format("samples_rate_hz {} must divide sample_rate_hz {} evenly", cr, rate_hz));
  }
  return d;
}

py::object simulate(const std::string& path, const MachineValue& mach_value, const dy::AxisModel& mx,
                    const dy::AxisModel& my, double sample_rate_hz, bool motor_space, std::size_t worst,
                    double corner_window_s, std::optional<double> t_begin, std::optional<double> t_end,
                    std::optional<std::int32_t> layer_begin, std::optional<std::int32_t> layer_end,
                    bool with_peaks, bool samples, std::optional<double> samples_rate_hz,
                    const simulation::ShaperRequest& shaper_request) {
  const machine::Machine& mach = mach_value.m;
  dy::PrintSimulationOptions o;
  o.simulation.sample_rate_hz = sample_rate_hz;
  o.simulation.motor_space = motor_space;
  if (motor_space) o.simulation.motor_rows = machine::motor_space(mach).rows;
  o.simulation.vibration_per_sample = samples;
  o.metrics.worst_count = worst;
  o.metrics.corner_window_s = corner_window_s;
  o.metrics.keep_per_move = false;  // bounded memory, as the CLI
  if (t_begin) o.metrics.t_begin_s = *t_begin;
  if (t_end) o.metrics.t_end_s = *t_end;
  if (layer_begin) o.metrics.layer_begin = *layer_begin;
  if (layer_end) o.metrics.layer_end = *layer_end;
  Samples rows;
  if (samples) {
    rows.decimation = decimation(sample_rate_hz, samples_rate_hz);
    o.rows = [&rows](const dy::SimSample& s, double e) { rows.add(s, e); };
  }
  Json j;
  {
    py::gil_scoped_release nogil;
    // The shapers as `amctl simulate` resolves them: requested, else the machine's
    // [input_shaper], else M593 before the first move.
    // Two passes over one rewindable input (standard input and a FIFO are read once).
    InputFile input(path, gcode::gcode_input_options(true));
    const simulation::ShaperSettings shapers = simulation::resolve_shapers(shaper_request, mach, input);
    if (shapers.any()) {
      j = simulation::to_json(simulation::simulate_shaped_print(input, mach, mx, my, o, shapers), with_peaks);
    } else {
      const dy::PrintSimulationResult r = dy::simulate_print(input, mach, mx, my, o);
      j = dy::to_json(r, with_peaks);
    }
  }
  py::dict out(to_python(j));
  if (samples) out["trace"] = rows.arrays();  // "samples" is the count of the metrics
  return out;
}

py::list modes_list(const dy::AxisModel& a) {
  py::list l;
  for (const auto& md : a.modes()) {
    py::dict d;
    d["natural_frequency_hz"] = md.natural_frequency_hz;
    d["damping_ratio"] = md.damping_ratio;
    d["participation"] = md.participation;
    l.append(d);
  }
  return l;
}

}  // namespace

void register_simulate(py::module_& m) {
  py::class_<dy::AxisModel>(m, "AxisModel", R"(The dynamics of one axis (or motor): a sum of damped modes
driven by the commanded acceleration (docs/dynamics.md). An immutable value.)")
      .def_static("belt", py::overload_cast<double, double>(&dy::AxisModel::belt),
                  py::arg("natural_frequency_hz"), py::arg("damping_ratio") = 0.1,
                  "A belt-driven carriage: one mode, f [Hz] > 0, damping ratio zeta >= 0 (dimensionless).")
      .def_static("from_belt",
                  [](double mass_kg, double stiffness_n_per_m, double damping_n_s_per_m) {
                    return dy::AxisModel::belt(dy::BeltParameters{mass_kg, stiffness_n_per_m, damping_n_s_per_m});
                  },
                  py::arg("mass_kg"), py::arg("stiffness_n_per_m"), py::arg("damping_n_s_per_m") = 0.0,
                  "A belt from its physics: moving mass [kg], belt stiffness [N/m], damping [N s/m].")
      .def_static("from_modes",
                  [](const std::vector<std::tuple<double, double, double>>& modes) {
                    std::vector<dy::Mode> v;
                    for (const auto& [f, z, g] : modes) v.push_back(dy::Mode{f, z, g});
                    return dy::AxisModel::from_modes(std::move(v));
                  },
                  py::arg("modes"),
                  "Several modes: [(natural_frequency_hz, damping_ratio, participation), ...].")
      .def_static("rigid", &dy::AxisModel::rigid, "No dynamics: the nozzle follows the command exactly.")
      .def_property_readonly("modes", &modes_list,
                             "list of {natural_frequency_hz [Hz], damping_ratio, participation}")
      .def("__repr__", [](const dy::AxisModel& a) {
        std::string s = "amctl.AxisModel.from_modes([";
        for (std::size_t i = 0; i < a.modes().size(); ++i) {
          const auto& md = a.modes()[i];
          s += fmt::format("{}({}, {}, {})", i ? ", " : "", md.natural_frequency_hz, md.damping_ratio,
                           md.participation);
        }
        return s + "])";
      });

  m.def("_simulate", &simulate, py::arg("path"), py::arg("machine"), py::arg("model_x"), py::arg("model_y"),
        py::arg("sample_rate_hz"), py::arg("motor_space"), py::arg("worst"), py::arg("corner_window_s"),
        py::arg("t_begin"), py::arg("t_end"), py::arg("layer_begin"), py::arg("layer_end"),
        py::arg("with_peaks"), py::arg("samples"), py::arg("samples_rate_hz"), py::arg("shaper"),
        "amctl simulate --json (dynamics::simulate_print, or simulation::simulate_shaped_print "
        "with a shaper, + to_json); see amctl.simulate.");
  m.def("_shaper_request",
        [](std::optional<std::string> type, std::optional<std::string> type_x, std::optional<std::string> type_y,
           std::optional<double> freq_hz, std::optional<double> freq_x_hz, std::optional<double> freq_y_hz,
           double damping_ratio, bool none, const std::string& firmware) {
          simulation::ShaperRequest r;
          if (!firmware.empty()) {
            try {
              r.firmware = shaping::parse_firmware(firmware);
            } catch (const Error& e) {
              throw Error(std::string("shaper_firmware: ") + e.what());
            }
          }
          r.firmware_name = "shaper_firmware";
          r.type = std::move(type);
          r.type_x = std::move(type_x);
          r.type_y = std::move(type_y);
          r.freq_hz = freq_hz;
          r.freq_x_hz = freq_x_hz;
          r.freq_y_hz = freq_y_hz;
          r.damping_ratio = damping_ratio;
          r.none = none;
          // The Python spelling of each parameter, for messages.
          r.type_name = "shaper";
          r.type_x_name = "shaper_x";
          r.type_y_name = "shaper_y";
          r.freq_name = "shaper_freq_hz";
          r.freq_x_name = "shaper_freq_x_hz";
          r.freq_y_name = "shaper_freq_y_hz";
          r.damping_name = "shaper_damping_ratio";
          r.none_name = "no_shaper";
          return r;
        },
        py::arg("type"), py::arg("type_x"), py::arg("type_y"), py::arg("freq_hz"), py::arg("freq_x_hz"),
        py::arg("freq_y_hz"), py::arg("damping_ratio"), py::arg("none"), py::arg("firmware") = "");
  py::class_<simulation::ShaperRequest>(m, "_ShaperRequest");
}

}  // namespace amctl::py_bind
