#pragma once
// Shared pieces of the _amctl extension: JSON -> Python conversion, arrays that own a
// std::vector without a copy, and the registration functions of each source file.
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/file_limits.hpp"

namespace amctl::py_bind {

namespace py = pybind11;

/// amctl.Machine: the machine and the spec it was loaded from (`machine show --json` prints
/// it as "source"). Equality compares the machine only.
struct MachineValue {
  machine::Machine m;
  std::string source = "default";
};

/// nlohmann JSON -> the Python value json.loads(j.dump()) gives (dict, list, int, float, str,
/// bool, None), without the text round trip.
[[nodiscard]] py::object to_python(const Json& j);

/// A 1-D numpy array that takes over `v` (no copy): the array's base is a capsule owning it.
template <class T>
[[nodiscard]] py::array_t<T> adopt(std::vector<T>&& v) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule base(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>({static_cast<py::ssize_t>(owned->size())}, {static_cast<py::ssize_t>(sizeof(T))},
                        owned->data(), base);
}

/// file_limits= "keep", "ignore" or "cap" (amctl::Error otherwise), as `--file-limits`.
[[nodiscard]] plan::FileLimits file_limits_arg(const std::string& value);

void register_plan(py::module_& m);
void register_simulate(py::module_& m);
void register_studies(py::module_& m);
void register_shaping(py::module_& m);
void register_closedloop(py::module_& m);
void register_jobs(py::module_& m);

}  // namespace amctl::py_bind
