#pragma once
// The one JSON convention of amctl: every report that has a JSON form is written with
// nlohmann::json (keys sorted, as std::map orders them) and every double goes through
// json_number(), so that all commands and bindings agree on what a non-finite value becomes.
#include <cmath>

#include <nlohmann/json.hpp>

namespace amctl {

using Json = nlohmann::json;

/// A double as JSON. JSON has neither infinity nor NaN: both are written as null, and the
/// documentation of each key says what null means there (an unbounded jerk, a margin with no
/// finite bound, a wavelength that was not measured).
[[nodiscard]] inline Json json_number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

}  // namespace amctl
