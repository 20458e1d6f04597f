#pragma once
// Argument conversion shared by the bindings: paths (str or os.PathLike) and machine
// overrides ({"section.key": value}), with TypeError messages that name the parameter.
#include <string>
#include <vector>

#include "common.hpp"

namespace amctl::py_bind {

/// str or os.PathLike -> std::string; TypeError naming `param` otherwise.
[[nodiscard]] std::string path_arg(py::handle obj, const char* param);

/// None, {"section.key": value} or ["section.key=value", ...] -> the `--set` assignments, in
/// order. Values: bool -> true/false, int, float, str (as written after `--set k=`), or a
/// list/tuple of numbers ("[a, b, c, d]"). TypeError naming `param` otherwise.
[[nodiscard]] std::vector<std::string> overrides_arg(py::handle set, const char* param);

}  // namespace amctl::py_bind
