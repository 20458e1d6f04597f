// _amctl: the compiled half of the amctl Python package (docs/python.md). The pure-Python
// modules in python/amctl/ check argument types and call the functions here, which call the
// same library functions as the command line, release the GIL while C++ runs, and convert
// the library's JSON forms to Python values.
#include <chrono>
#include <exception>

#include <fmt/format.h>
#include <pybind11/stl.h>

#include "amctl/bedmesh/config.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/machine/json.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/report_json.hpp"
#include "args.hpp"
#include "common.hpp"

namespace amctl::py_bind {

namespace mc = amctl::machine;

std::string path_arg(py::handle obj, const char* param) {
  if (py::isinstance<py::str>(obj)) return obj.cast<std::string>();
  if (py::hasattr(obj, "__fspath__")) {
    py::object p = py::module_::import("os").attr("fspath")(obj);
    if (py::isinstance<py::str>(p)) return p.cast<std::string>();
    if (py::isinstance<py::bytes>(p)) return p.cast<std::string>();
  }
  throw py::type_error(fmt::format("{} must be a str or os.PathLike, got {}", param,
                                   py::str(py::type::handle_of(obj).attr("__name__")).cast<std::string>()));
}

namespace {

std::string type_name(py::handle obj) {
  return py::str(py::type::handle_of(obj).attr("__name__")).cast<std::string>();
}

std::string value_text(py::handle v, const std::string& where) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::int_>(v)) return py::str(v).cast<std::string>();
  if (py::isinstance<py::float_>(v)) return py::repr(v).cast<std::string>();
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    std::string out = "[";
    bool first = true;
    for (py::handle x : v) {
      if (py::isinstance<py::bool_>(x) || !(py::isinstance<py::int_>(x) || py::isinstance<py::float_>(x))) {
        throw py::type_error(fmt::format("{}: list items must be numbers, got {}", where, type_name(x)));
      }
      if (!first) out += ", ";
      out += value_text(x, where);
      first = false;
    }
    return out + "]";
  }
  throw py::type_error(fmt::format("{} must be a number, bool, str or list of numbers, got {}", where,
                                   type_name(v)));
}

}  // namespace

std::vector<std::string> overrides_arg(py::handle set, const char* param) {
  std::vector<std::string> out;
  if (set.is_none()) return out;
  if (py::isinstance<py::dict>(set)) {
    for (auto [k, v] : py::reinterpret_borrow<py::dict>(set)) {
      if (!py::isinstance<py::str>(k)) {
        throw py::type_error(fmt::format("{}: keys must be 'section.key' strings, got {}", param, type_name(k)));
      }
      const std::string key = k.cast<std::string>();
      out.push_back(key + "=" + value_text(v, fmt::format("{}['{}']", param, key)));
    }
    return out;
  }
  if (py::isinstance<py::list>(set) || py::isinstance<py::tuple>(set)) {
    for (py::handle a : set) {
      if (!py::isinstance<py::str>(a)) {
        throw py::type_error(fmt::format("{}: items must be 'section.key=value' strings, got {}", param,
                                         type_name(a)));
      }
      out.push_back(a.cast<std::string>());
    }
    return out;
  }
  throw py::type_error(fmt::format("{} must be a dict {{'section.key': value}} or None, got {}", param,
                                   type_name(set)));
}

namespace {

// The exception classes live in amctl/_errors.py (documented there); kept alive for the
// interpreter's lifetime.
PyObject* g_error = nullptr;
PyObject* g_internal_error = nullptr;

void raise_error(const Error& e) {
  py::object cls = py::reinterpret_borrow<py::object>(g_error);
  const SourceLocation& w = e.where();
  py::object file = w.file.empty() ? py::object(py::none()) : py::object(py::str(w.file));
  py::object line = w.line == 0 ? py::object(py::none()) : py::object(py::int_(w.line));
  py::object column = w.column == 0 ? py::object(py::none()) : py::object(py::int_(w.column));
  py::object exc = cls(py::str(e.what()), py::arg("file") = file, py::arg("line") = line,
                       py::arg("column") = column, py::arg("detail") = py::str(e.detail()));
  PyErr_SetObject(g_error, exc.ptr());
}

MachineValue load(py::handle spec, py::handle set) {
  const std::string s = spec.is_none() ? std::string() : path_arg(spec, "spec");
  const std::vector<std::string> ov = overrides_arg(set, "set");
  py::gil_scoped_release nogil;
  return MachineValue{mc::load_machine(s, ov), s.empty() ? "default" : s};
}

MachineValue with_set(const MachineValue& v, py::handle set) {
  const std::vector<std::string> ov = overrides_arg(set, "set");
  MachineValue out = v;
  for (const auto& a : ov) mc::apply_override(out.m, a);
  mc::validate(out.m);
  return out;
}

py::object to_dict(const MachineValue& v) {
  Json j = mc::to_json(v.m);
  j["source"] = v.source;
  return to_python(j);
}

py::tuple tuple4(const std::array<double, 4>& a) { return py::make_tuple(a[0], a[1], a[2], a[3]); }

py::object estimate(const std::string& path, const MachineValue& mv, bool strict,
                    const std::string& file_limits) {
  const mc::Machine& m = mv.m;
  plan::EstimateOptions opt;
  opt.strict = strict;
  opt.planner.file_limits = file_limits_arg(file_limits);
  Json j;
  {
    py::gil_scoped_release nogil;
    const auto t0 = std::chrono::steady_clock::now();
    const plan::EstimateReport r = plan::estimate_file(path, m, opt);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    j = plan::to_json(r, m, s);
  }
  return to_python(j);
}

const char* kMachineDoc = R"(A printer description: limits, firmware semantics, kinematics (docs/machine.md).

An immutable value. Build one with Machine.load(spec, set={...}); derive a variant with
m.with_set({...}). Units are in the attribute names: mm, s, mm/s, mm/s^2, mm/s^3.
to_dict() is the JSON of `amctl machine show --json`.)";

}  // namespace

}  // namespace amctl::py_bind

PYBIND11_MODULE(_amctl, m) {
  using namespace amctl::py_bind;
  namespace mc = amctl::machine;
  m.doc() = "amctl's compiled core; use the package `amctl` (docs/python.md).";
  m.attr("__version__") = AMCTL_VERSION;

  py::module_ errors = py::module_::import("amctl._errors");
  g_error = py::object(errors.attr("Error")).release().ptr();
  g_internal_error = py::object(errors.attr("InternalError")).release().ptr();
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const amctl::Error& e) {
      raise_error(e);
    } catch (const amctl::InternalError& e) {
      PyErr_SetString(g_internal_error, e.what());
    }
  });

  py::class_<MachineValue>(m, "Machine", kMachineDoc)
      .def_static("load", &load, py::arg("spec") = py::none(), py::kw_only(), py::arg("set") = py::none(),
                  R"(Loads a printer.

spec: a preset name (Machine.presets()), a machine .toml or a Klipper printer.cfg
      (str or os.PathLike); None or "" is the 'default' preset.
set:  {"section.key": value} applied in order as `amctl --set section.key=value`
      (units of each key in docs/machine.md, e.g. {"printer.max_accel": 5000} in mm/s^2),
      then the machine is validated.
Raises amctl.Error for an unknown preset, a bad file (with file, line, column) or a bad value.)")
      .def("with_set", &with_set, py::arg("set"),
           "A copy with the `--set` assignments {\"section.key\": value} applied, validated.")
      .def_static("presets", &mc::preset_names, "Names of the presets compiled into amctl.")
      .def_static("keys", [] { return to_python(mc::schema_json()["keys"]); },
                  "Every machine key: list of {section, key, type, unit, description}.")
      .def("to_dict", &to_dict,
           "The JSON of `amctl machine show SPEC --json` as a dict: sections as in the TOML file, "
           "'effective' (the limits Klipper derives) and 'source' (the spec it was loaded from).")
      .def("to_toml", [](const MachineValue& v) { return mc::to_toml(v.m); },
           "TOML text that Machine.load() reads back to an equal machine.")
      .def("__eq__", [](const MachineValue& a, const MachineValue& b) { return a.m == b.m; })
      .def("__copy__", [](const MachineValue& a) { return a; })
      .def("__deepcopy__", [](const MachineValue& a, py::handle) { return a; })
      .def(py::pickle(  // as its TOML text (to_toml reads back to an equal machine) and source
          [](const MachineValue& v) { return py::make_tuple(mc::to_toml(v.m), v.source); },
          [](const py::tuple& t) {
            if (t.size() != 2) throw std::runtime_error("amctl.Machine: bad pickle state");
            return MachineValue{mc::parse_machine_toml(t[0].cast<std::string>(), "<pickled machine>"),
                                t[1].cast<std::string>()};
          }))
      .def_property_readonly("source", [](const MachineValue& v) { return v.source; },
                             "the spec the machine was loaded from ('default' when none was given)")
      .def("__repr__", [](const MachineValue& v) {
        const mc::Machine& x = v.m;
        return fmt::format("amctl.Machine('{}', firmware='{}', kinematics='{}', max_velocity_mm_s={}, "
                           "max_accel_mm_s2={})",
                           x.name, mc::to_string(x.firmware), amctl::kinematics::name_of(x.kinematics),
                           x.max_velocity_mm_s, x.max_accel_mm_s2);
      })
      .def_property_readonly("name", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.name; })
      .def_property_readonly("firmware", [](const MachineValue& v) { const mc::Machine& x = v.m; return std::string(mc::to_string(x.firmware)); },
                             "'klipper', 'marlin' or 'reprap': whose G-code semantics apply")
      .def_property_readonly("kinematics", [](const MachineValue& v) { const mc::Machine& x = v.m; return std::string(amctl::kinematics::name_of(x.kinematics)); },
                             "'cartesian' or 'corexy'")
      .def_property_readonly("junction", [](const MachineValue& v) { const mc::Machine& x = v.m; return std::string(mc::to_string(x.junction)); },
                             "corner speed limit: 'square_corner_velocity', 'junction_deviation' or 'classic_jerk'")
      .def_property_readonly("profile", [](const MachineValue& v) { const mc::Machine& x = v.m; return std::string(mc::to_string(x.profile)); },
                             "ramp shape: 'trapezoid', 'scurve7' or 'bezier5'")
      .def_property_readonly("max_velocity_mm_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.max_velocity_mm_s; }, "[mm/s]")
      .def_property_readonly("max_accel_mm_s2", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.max_accel_mm_s2; }, "[mm/s^2]")
      .def_property_readonly("square_corner_velocity_mm_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.square_corner_velocity_mm_s; }, "[mm/s]")
      .def_property_readonly("minimum_cruise_ratio", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.minimum_cruise_ratio; }, "Klipper minimum_cruise_ratio, 0 <= r < 1")
      .def_property_readonly("max_z_velocity_mm_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.max_z_velocity_mm_s; }, "[mm/s], 0 = max_velocity")
      .def_property_readonly("max_z_accel_mm_s2", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.max_z_accel_mm_s2; }, "[mm/s^2], 0 = max_accel")
      .def_property_readonly("max_feedrate_mm_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return tuple4(x.max_feedrate_mm_s); }, "Marlin M203 (X, Y, Z, E) [mm/s]")
      .def_property_readonly("max_axis_accel_mm_s2", [](const MachineValue& v) { const mc::Machine& x = v.m; return tuple4(x.max_axis_accel_mm_s2); }, "Marlin M201 (X, Y, Z, E) [mm/s^2]")
      .def_property_readonly("print_accel_mm_s2", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.print_accel_mm_s2; }, "Marlin M204 P [mm/s^2]")
      .def_property_readonly("retract_accel_mm_s2", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.retract_accel_mm_s2; }, "Marlin M204 R [mm/s^2]")
      .def_property_readonly("travel_accel_mm_s2", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.travel_accel_mm_s2; }, "Marlin M204 T [mm/s^2]")
      .def_property_readonly("jerk_mm_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return tuple4(x.jerk_mm_s); }, "classic jerk M205 (X, Y, Z, E) [mm/s]")
      .def_property_readonly("junction_deviation_mm", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.junction_deviation_mm; }, "Marlin M205 J [mm]")
      .def_property_readonly("min_feedrate_mm_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.min_feedrate_mm_s; }, "M205 S [mm/s]")
      .def_property_readonly("min_travel_feedrate_mm_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.min_travel_feedrate_mm_s; }, "M205 T [mm/s]")
      .def_property_readonly("min_segment_time_s", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.min_segment_time_s; }, "M205 B [s]")
      .def_property_readonly("block_buffer_size", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.block_buffer_size; }, "Marlin planner buffer [moves]")
      .def_property_readonly("max_jerk_mm_s3", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.max_jerk_mm_s3; }, "jerk of the scurve7 profile [mm/s^3]")
      .def_property_readonly("nozzle_diameter_mm", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.extruder.nozzle_diameter_mm; }, "[mm]")
      .def_property_readonly("filament_diameter_mm", [](const MachineValue& v) { const mc::Machine& x = v.m; return x.extruder.filament_diameter_mm; }, "[mm]")
      .def_property_readonly("extruder", [](const MachineValue& v) { const mc::Machine& x = v.m; return to_python(mc::to_json(x)["extruder"]); }, "the [extruder] section as a dict (units in the key names)")
      .def_property_readonly("arcs", [](const MachineValue& v) { const mc::Machine& x = v.m; return to_python(mc::to_json(x)["arcs"]); }, "the [arcs] section as a dict")
      .def_property_readonly("firmware_retraction", [](const MachineValue& v) { const mc::Machine& x = v.m; return to_python(mc::to_json(x)["firmware_retraction"]); }, "the [firmware_retraction] section as a dict")
      .def_property_readonly("steppers", [](const MachineValue& v) { const mc::Machine& x = v.m; return to_python(mc::to_json(x)["steppers"]); }, "the steppers as a dict")
      .def_property_readonly("effective", [](const MachineValue& v) { const mc::Machine& x = v.m; return to_python(mc::to_json(x)["effective"]); }, "the limits Klipper derives, as a dict")
      .def_property_readonly("bed_mesh", [](const MachineValue& v) -> py::object {
        // Klipper's [bed_mesh] (docs/bedmesh.md): what `amctl machine show --json` lists.
        const mc::Machine& x = v.m;
        if (x.klipper_config.empty()) return py::none();
        const auto s = amctl::bedmesh::read_klipper(x.klipper_config, amctl::SourceLocation{x.name, 0, 0});
        if (!s) return py::none();
        return to_python(amctl::bedmesh::to_json(*s));
      }, "Klipper's [bed_mesh] as a dict (profiles, counts, z range), None without one");

  m.def("_estimate", &estimate, py::arg("path"), py::arg("machine"), py::arg("strict"),
        py::arg("file_limits") = "keep",
        "amctl estimate --json (plan::estimate_file + plan::to_json); see amctl.estimate.");
  m.def(
      "_write_output",
      [](const std::string& path, const std::string& text, const std::string& flag) {
        py::gil_scoped_release nogil;
        amctl::write_output(path, text, amctl::OutputOptions{flag, {}, {}});
      },
      py::arg("path"), py::arg("text"), py::arg("flag") = "",
      "amctl's one output writer (core/output.hpp): a regular file whole or not at all, '-', a "
      "device or a FIFO streamed; amctl.Error naming the path when it cannot be written.");
  m.def(
      "_check_output",
      [](const std::string& path, const std::string& flag) {
        amctl::check_output(path, amctl::OutputOptions{flag, {}, {}});
      },
      py::arg("path"), py::arg("flag") = "",
      "The checks of _write_output without writing (amctl.Error when the path cannot be written).");
  m.def("_gcode_inputs",
        [](const std::vector<std::string>& inputs) { return amctl::formats::expand_gcode_inputs(inputs); },
        py::arg("inputs"), "formats::expand_gcode_inputs; see amctl.gcode_inputs.");

  register_plan(m);
  register_simulate(m);
  register_studies(m);
  register_shaping(m);
  register_closedloop(m);
  register_jobs(m);
}
