#include "amctl/dynamics/seed000_sweep.hpp"

#include <algorithm>
#include <chrono>

#include <fmt/format.h>

#include "amctl/dynamics/metrics.hpp"
#include "amctl/dynamics/model.hpp"
#include "amctl/dynamics/simulate.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/trajectory/sampling.hpp"

namespace amctl::dynamics {

std::vector<Seed000Case> seed000_cases() {
  std::vector<Seed000Case> c{{"base"}};
  for (double w : {50.0, 200.0, 500.0}) c.push_back({fmt::format("1 w={:g}", w), w});
  for (double z : {0.0, 1.0, 2.0}) c.push_back({fmt::format("2 z={:g}", z), 100, z});
  for (double a : {1000.0, 10000.0}) c.push_back({fmt::format("3 a={:g}", a), 100, 0.5, a});
  for (double v : {50.0, 200.0}) c.push_back({fmt::format("4 v={:g}", v), 100, 0.5, 5000, v});
  for (double h : {0.01, 0.001, 0.0002}) {
    c.push_back({fmt::format("5 h={:g}", h), 100, 0.5, 5000, 100, h});
  }
  return c;
}

namespace {

Seed000Row run_case(const Seed000Case& c, bool lookahead, double scv) {
  machine::Machine m = machine::preset("default");
  m.firmware = machine::Firmware::klipper;
  m.junction = machine::JunctionPolicy::square_corner_velocity;
  m.max_accel_mm_s2 = c.accel_mm_s2;
  m.max_velocity_mm_s = std::max(m.max_velocity_mm_s, c.v_mm_s);
  m.minimum_cruise_ratio = 0.0;  // the thesis's trapezoid has no cruise smoothing
  m.square_corner_velocity_mm_s = lookahead ? scv : 0.0;
  const std::string gcode =
      fmt::format("G90\nG1 X0 Y0 F{0:g}\nG1 X10 Y0 F{0:g}\nG1 X10 Y10 F{0:g}\n", c.v_mm_s * 60.0);
  plan::PlanSource source(gcode, "seed000", m);
  plan::CollectSink all;
  plan::Sink* sinks[] = {&all};
  plan::run_pipeline(source, sinks);
  std::vector<plan::PlannedMove> moves;
  std::copy_if(all.moves.begin(), all.moves.end(), std::back_inserter(moves),
               [](const plan::PlannedMove& mv) { return mv.distance_mm > 0.0; });

  const auto t0 = std::chrono::steady_clock::now();
  const AxisModel model = AxisModel::belt_rad_s(c.w_rad_s, c.zeta);
  SimulationOptions so;
  so.sample_rate_hz = 1.0 / c.h_s;
  so.settle_s = 0.5;
  MetricsOptions mo;
  mo.corner_window_s = 0.5;
  QualityMeter meter(moves, mo);
  (void)simulate(
      moves, model, model, so, [&](const SimSample& s) { (void)meter.add(s); },
      [&](std::size_t i, double t, const std::array<double, 2>& v) { meter.on_move_end(i, t, v); });
  const QualityReport q = meter.finish();

  Seed000Row row;
  row.c = c;
  row.lookahead = lookahead;
  row.junction_speed_mm_s = moves.empty() ? 0.0 : moves.front().end_v_mm_s;
  row.motion_time_s = q.motion_time_s;
  row.samples = trajectory::sample_seed000(moves, c.h_s).size();
  row.max_contour_error_mm = q.max_contour_error_mm;
  row.rms_contour_error_mm = q.rms_contour_error_mm;
  row.max_corner_overshoot_mm = q.max_corner_overshoot_mm;
  row.final_residual_vibration_mm = q.final_residual_vibration_mm;
  row.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return row;
}

}  // namespace

std::vector<Seed000Row> seed000_sweep(double square_corner_velocity_mm_s) {
  std::vector<Seed000Row> rows;
  for (const Seed000Case& c : seed000_cases()) {
    for (const bool lookahead : {true, false}) {
      rows.push_back(run_case(c, lookahead, square_corner_velocity_mm_s));
    }
  }
  return rows;
}

Json to_json(const std::vector<Seed000Row>& rows, double scv) {
  Json arr = Json::array();
  for (const Seed000Row& r : rows) {
    arr.push_back({{"case", r.c.name}, {"junction", r.lookahead ? "lookahead" : "zero"},
                   {"w_rad_s", r.c.w_rad_s}, {"damping_ratio", r.c.zeta},
                   {"accel_mm_s2", r.c.accel_mm_s2}, {"v_mm_s", r.c.v_mm_s}, {"h_s", r.c.h_s},
                   {"junction_speed_mm_s", r.junction_speed_mm_s},
                   {"motion_time_s", r.motion_time_s}, {"samples", r.samples},
                   {"max_contour_error_mm", r.max_contour_error_mm},
                   {"rms_contour_error_mm", r.rms_contour_error_mm},
                   {"max_corner_overshoot_mm", r.max_corner_overshoot_mm},
                   {"final_residual_vibration_mm", r.final_residual_vibration_mm},
                   {"compute_time_s", r.compute_time_s}});
  }
  // "seed": the key of earlier versions, kept for scripts that read it.
  return Json{{"study", "feedforward study (Tables 3.2 and 3.3 of the UFLA thesis)"},
              {"seed", "000"},
              {"square_corner_velocity_mm_s", scv},
              {"cases", arr}};
}

}  // namespace amctl::dynamics
