#pragma once
// The chart of `amctl stepper sweep --svg`: maximum tracking error against speed, one series
// per controller, one panel per axis, logarithmic error axis (docs/closedloop.md, section 4).
#include <span>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/report/line_chart.hpp"

namespace amctl::report {

[[nodiscard]] LineChart stepper_sweep_chart(std::span<const closedloop::SweepRow> rows, bool load);

}  // namespace amctl::report
