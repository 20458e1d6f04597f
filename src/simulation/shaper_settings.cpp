// Which shapers a simulation runs with: the request, the machine's [input_shaper], M593.
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/simulation/shaped_simulation.hpp"

namespace amctl::simulation {
namespace {

// The shaper of one axis from the machine's [input_shaper] (frequency 0: not shaped).
std::optional<AxisShaperSetting> from_machine(const machine::Machine& m, bool y, ShaperParamNames& names) {
  const machine::InputShaper& in = m.input_shaper;
  const double f = y ? in.shaper_freq_y_hz : in.shaper_freq_x_hz;
  if (f <= 0.0) return std::nullopt;
  const char* ax = y ? "y" : "x";
  names.type = fmt::format("[input_shaper] shaper_type_{}", ax);
  names.freq = fmt::format("[input_shaper] shaper_freq_{}", ax);
  names.damping = fmt::format("[input_shaper] damping_ratio_{}", ax);
  AxisShaperSetting s;
  s.type = y ? in.shaper_type_y : in.shaper_type_x;
  s.freq_hz = f;
  s.damping_ratio = y ? in.damping_ratio_y : in.damping_ratio_x;
  s.source = fmt::format("machine {}", m.name);
  apply_machine_firmware(m, s);
  return s;
}

// The shaper of one axis from the request; nothing when the request does not name the axis.
std::optional<AxisShaperSetting> from_request(const ShaperRequest& r, bool y, ShaperParamNames& names) {
  const auto& type_axis = y ? r.type_y : r.type_x;
  const auto& freq_axis = y ? r.freq_y_hz : r.freq_x_hz;
  const std::optional<std::string> type = type_axis ? type_axis : r.type;
  const std::optional<double> freq = freq_axis ? freq_axis : r.freq_hz;
  if (!type && !freq) return std::nullopt;
  names.type = type_axis ? (y ? r.type_y_name : r.type_x_name) : r.type_name;
  names.freq = freq_axis ? (y ? r.freq_y_name : r.freq_x_name) : r.freq_name;
  names.damping = r.damping_name;
  if (!freq) {
    throw Error(fmt::format("{} needs a frequency: {} or {}", names.type, r.freq_name,
                            y ? r.freq_y_name : r.freq_x_name));
  }
  AxisShaperSetting s;
  s.type = type.value_or("mzv");
  s.freq_hz = *freq;
  s.damping_ratio = r.damping_ratio;
  s.source = "flags";
  return s;
}

}  // namespace

ShaperSettings resolve_shapers(const ShaperRequest& request, const machine::Machine& machine,
                               const plan::GcodeInput& path) {
  ShaperSettings shapers;
  shapers.x = from_request(request, false, shapers.names_x);
  shapers.y = from_request(request, true, shapers.names_y);

  if (shapers.any() && request.none) {
    throw Error(fmt::format("{} and a {} parameter contradict each other", request.none_name,
                            request.type_name));
  }
  if (request.none) {
    if (request.firmware) {
      throw Error(fmt::format("{} and {} contradict each other", request.none_name, request.firmware_name));
    }
    return shapers;
  }
  // Precedence: the request, then the machine's [input_shaper], then M593 before the first move.
  const auto m593 = m593_before_first_move(path, machine);
  const bool from_flags = shapers.any();
  if (!shapers.any()) {
    shapers.x = from_machine(machine, false, shapers.names_x);
    shapers.y = from_machine(machine, true, shapers.names_y);
  }
  if (!m593.empty()) {
    if (shapers.any()) {
      shapers.warnings.push_back(fmt::format(
          "M593 before the first move (line {}) overridden by {}", m593.front().line,
          from_flags ? "the requested shaper" : "the machine's [input_shaper]"));
    } else {
      shapers = shapers_from_m593(m593);
    }
  }
  if (request.firmware) {
    for (auto* axis : {&shapers.x, &shapers.y}) {
      if (*axis) apply_requested_firmware(*request.firmware, **axis);
    }
  }
  return shapers;
}

}  // namespace amctl::simulation
