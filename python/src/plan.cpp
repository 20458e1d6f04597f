// The planned moves as numpy structured arrays, batch by batch from plan::PlanSource (the
// columns of `amctl plan`, docs/planner.md). The GIL is released while the source plans a
// batch; the rows are then written straight into a numpy array (no intermediate copy).
#include <array>
#include <cstring>
#include <memory>
#include <optional>

#include <fmt/format.h>
#include <pybind11/stl.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/select_stage.hpp"
#include "amctl/plan/stream.hpp"
#include "common.hpp"

namespace amctl::py_bind {
namespace {

/// Field names and numpy types, in the CSV's column order.
const std::vector<std::pair<const char*, const char*>>& move_fields() {
  static const std::vector<std::pair<const char*, const char*>> f = {
      {"line", "<u8"},         {"layer", "<i4"},         {"feature", "O"},
      {"start_time_s", "<f8"}, {"duration_s", "<f8"},    {"x0_mm", "<f8"},
      {"y0_mm", "<f8"},        {"z0_mm", "<f8"},         {"e0_mm", "<f8"},
      {"x1_mm", "<f8"},        {"y1_mm", "<f8"},         {"z1_mm", "<f8"},
      {"e1_mm", "<f8"},        {"distance_mm", "<f8"},   {"start_v_mm_s", "<f8"},
      {"cruise_v_mm_s", "<f8"}, {"end_v_mm_s", "<f8"},   {"accel_mm_s2", "<f8"},
      {"jerk_mm_s3", "<f8"},   {"accel_t_s", "<f8"},     {"cruise_t_s", "<f8"},
      {"decel_t_s", "<f8"},    {"profile", "O"},         {"extrude_only", "?"}};
  return f;
}

struct Layout {
  py::dtype dtype;
  std::size_t itemsize = 0;
  std::vector<std::size_t> offset;  // by field, in move_fields() order
};

const Layout& layout() {
  static const Layout* l = [] {
    py::list spec;
    for (const auto& [name, type] : move_fields()) spec.append(py::make_tuple(name, type));
    // Aligned (C struct layout): numpy reads every double field without an unaligned copy.
    py::dtype dt = py::module_::import("numpy").attr("dtype")(spec, py::arg("align") = true);
    auto* out = new Layout{dt, 0, {}};
    py::dict fields = out->dtype.attr("fields");
    for (const auto& [name, type] : move_fields()) {
      out->offset.push_back(py::cast<std::size_t>(py::tuple(fields[name])[1]));
    }
    out->itemsize = py::cast<std::size_t>(out->dtype.attr("itemsize"));
    return out;
  }();
  return *l;
}

const char* profile_name(machine::VelocityProfile p) {
  switch (p) {
    case machine::VelocityProfile::trapezoid: return "trapezoid";
    case machine::VelocityProfile::scurve7: return "scurve7";
    case machine::VelocityProfile::bezier5: return "bezier5";
  }
  return "unknown";
}

template <class T>
void put(char* row, std::size_t offset, T v) {
  std::memcpy(row + offset, &v, sizeof v);
}

void put_object(char* row, std::size_t offset, const py::object& v) {
  PyObject* old = nullptr;
  std::memcpy(&old, row + offset, sizeof old);
  PyObject* p = v.ptr();
  Py_INCREF(p);
  std::memcpy(row + offset, &p, sizeof p);
  Py_XDECREF(old);
}

/// Pull-based reader behind amctl.iter_plan / amctl.plan.
class PlanReader {
 public:
  PlanReader(const std::string& path, const machine::Machine& m, bool strict, std::size_t batch_moves,
             const plan::SelectOptions& select, bool use_select, plan::FileLimits file_limits) {
    if (batch_moves == 0) throw Error("batch_moves must be >= 1, got 0");
    plan::SourceOptions so;
    so.strict = strict;
    so.planner.file_limits = file_limits;
    so.batch_moves = batch_moves;
    if (use_select) select_ = std::make_unique<plan::SelectStage>(select);
    py::gil_scoped_release nogil;
    source_ = std::make_unique<plan::PlanSource>(path, m, so);
  }

  /// The next batch as a structured array, or None once the stream has ended.
  py::object next() {
    if (ended_) return py::none();
    {
      py::gil_scoped_release nogil;
      for (;;) {
        if (!source_->next(batch_)) {
          ended_ = true;
          batch_.clear();
          if (select_) select_->finish(batch_);
          break;
        }
        if (select_) select_->process(batch_);
        if (!batch_.moves.empty()) break;
      }
    }
    if (batch_.moves.empty()) return py::none();
    return to_array(batch_);
  }

  py::dict summary() const {
    const plan::StreamSummary& s = source_->summary();
    py::dict d;
    d["file"] = s.file;
    d["machine"] = s.machine_name;
    d["end_time_s"] = s.end_time_s;
    d["lines"] = s.lines;
    d["feature_names"] = s.feature_names;
    d["done"] = source_->done();
    return d;
  }

 private:
  py::object feature(const plan::PlanBatch& b, std::uint16_t idx) {
    std::string_view name;
    if (b.feature_names != nullptr && idx < b.feature_names->size()) name = (*b.feature_names)[idx];
    if (idx >= features_.size()) features_.resize(idx + 1u);
    py::object& f = features_[idx];
    if (!f) f = py::str(name.data(), name.size());  // an index names one feature for the whole run
    return f;
  }

  py::array to_array(const plan::PlanBatch& b) {
    const Layout& L = layout();
    py::array a(L.dtype, std::vector<py::ssize_t>{static_cast<py::ssize_t>(b.moves.size())}, std::vector<py::ssize_t>{});
    char* base = static_cast<char*>(a.mutable_data());
    // Leaked on purpose: a static py::object would be released after the interpreter is gone.
    static const auto* profiles = new std::array<py::object, 3>{py::str("trapezoid"), py::str("scurve7"),
                                                                 py::str("bezier5")};
    for (std::size_t i = 0; i < b.moves.size(); ++i) {
      const plan::PlannedMove& m = b.moves[i];
      char* row = base + i * L.itemsize;
      const auto& o = L.offset;
      put<std::uint64_t>(row, o[0], m.line);
      put<std::int32_t>(row, o[1], m.layer);
      put_object(row, o[2], feature(b, m.feature));
      put<double>(row, o[3], m.start_time_s);
      put<double>(row, o[4], m.duration_s());
      for (std::size_t k = 0; k < 4; ++k) {
        put<double>(row, o[5 + k], m.start_mm[k]);
        put<double>(row, o[9 + k], m.start_mm[k] + m.axes_r[k] * m.distance_mm);  // as the CSV
      }
      put<double>(row, o[13], m.distance_mm);
      put<double>(row, o[14], m.start_v_mm_s);
      put<double>(row, o[15], m.cruise_v_mm_s);
      put<double>(row, o[16], m.end_v_mm_s);
      put<double>(row, o[17], m.accel_mm_s2);
      put<double>(row, o[18], m.jerk_mm_s3);
      put<double>(row, o[19], m.accel_t_s);
      put<double>(row, o[20], m.cruise_t_s);
      put<double>(row, o[21], m.decel_t_s);
      const auto p = static_cast<std::size_t>(m.profile);
      put_object(row, o[22], p < 3 ? (*profiles)[p] : py::object(py::str(profile_name(m.profile))));
      put<bool>(row, o[23], m.extrude_only);
    }
    return a;
  }

  std::unique_ptr<plan::PlanSource> source_;
  std::unique_ptr<plan::SelectStage> select_;
  plan::PlanBatch batch_;
  std::vector<py::object> features_;
  bool ended_ = false;
};

}  // namespace

void register_plan(py::module_& m) {
  m.attr("MOVE_DTYPE") = layout().dtype;
  py::class_<PlanReader>(m, "_PlanReader")
      .def(py::init([](const std::string& path, const MachineValue& mach_value, bool strict, std::size_t batch_moves,
                       std::optional<double> t_begin, std::optional<double> t_end,
                       std::optional<std::int32_t> layer_begin, std::optional<std::int32_t> layer_end,
                       const std::string& file_limits) {
             plan::SelectOptions sel;
             if (t_begin) sel.t_begin_s = *t_begin;
             if (t_end) sel.t_end_s = *t_end;
             if (layer_begin) sel.layer_begin = *layer_begin;
             if (layer_end) sel.layer_end = *layer_end;
             const bool use = t_begin || t_end || layer_begin || layer_end;
             return std::make_unique<PlanReader>(path, mach_value.m, strict, batch_moves, sel, use,
                                                 file_limits_arg(file_limits));
           }),
           py::arg("path"), py::arg("machine"), py::arg("strict"), py::arg("batch_moves"),
           py::arg("t_begin"), py::arg("t_end"), py::arg("layer_begin"), py::arg("layer_end"),
           py::arg("file_limits") = "keep")
      .def("next", &PlanReader::next, "The next batch of moves (MOVE_DTYPE array), or None at the end.")
      .def("summary", &PlanReader::summary, "What the source knows: file, end_time_s, lines, feature_names.");
}

}  // namespace amctl::py_bind
