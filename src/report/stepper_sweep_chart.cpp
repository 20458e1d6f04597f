#include "amctl/report/stepper_sweep_chart.hpp"

#include <string>

namespace amctl::report {

LineChart stepper_sweep_chart(std::span<const closedloop::SweepRow> rows, bool load) {
  LineChart c;
  c.title = load ? "reversing strokes under load: maximum tracking error against speed"
                 : "reversing strokes without load: maximum tracking error against speed";
  c.x_label = "speed [mm/s]";
  c.y_label = "max tracking error [mm]";
  c.log_y = true;
  c.panels = {{"X axis", {}}, {"Y axis", {}}};
  for (const closedloop::SweepRow& r : rows) {
    for (int axis = 0; axis < 2; ++axis) {
      std::vector<ChartSeries>& series = c.panels[static_cast<std::size_t>(axis)].series;
      if (series.empty() || series.back().name != r.controller) series.push_back({r.controller, {}, {}});
      series.back().x.push_back(r.speed_mm_s);
      series.back().y.push_back(axis == 0 ? r.x.max_tracking_error_mm : r.y.max_tracking_error_mm);
    }
  }
  return c;
}

}  // namespace amctl::report
