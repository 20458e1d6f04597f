#include "amctl/comparison/compare.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "amctl/compensation/compensate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/dynamics/model.hpp"
#include "amctl/dynamics/metrics.hpp"
#include "amctl/dynamics/print_simulation.hpp"
#include "amctl/plan/profile_peaks.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/shaper.hpp"
#include "amctl/simulation/shaped_simulation.hpp"

namespace amctl::comparison {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool is_compensation(const std::string& m) {
  return m == "invert" || m == "fbf" || m == "lpfbf" || m == "rfbf" || m == "collocation";
}
bool is_shaper(const std::string& m) { return m == "zv" || m == "mzv" || m == "ei"; }

double rate_factor(double motion_time_s, double compute_time_s) {
  return compute_time_s > 0.0 ? motion_time_s / compute_time_s : kNaN;
}

dynamics::PrintSimulationOptions simulation_options(const machine::Machine& machine, double rate_hz) {
  dynamics::PrintSimulationOptions o;
  o.simulation.sample_rate_hz = rate_hz;
  o.metrics.keep_per_move = false;
  return o;
}

ComparisonRow uncompensated_row(const plan::GcodeInput& path, const machine::Machine& machine,
                                const dynamics::AxisModel& plant, double rate_hz) {
  const dynamics::PrintSimulationResult r =
      dynamics::simulate_print(path, machine, plant, plant, simulation_options(machine, rate_hz));
  ComparisonRow row;
  row.method = "uncompensated";
  row.kind = "uncompensated";
  row.max_contour_error_mm = r.report.max_contour_error_mm;
  row.rms_contour_error_mm = r.report.rms_contour_error_mm;
  row.max_tracking_error_mm = kNaN;
  row.rms_tracking_error_mm = kNaN;
  row.max_residual_vibration_mm = r.report.max_residual_vibration_mm;
  row.smoothing_mm = 0.0;
  row.lead_in_s = 0.0;
  row.peak_command_accel_mm_s2 = r.peaks.peak_accel_mm_s2;
  row.motion_time_s = r.report.motion_time_s;
  row.compute_time_s = r.compute_time_s;
  row.real_time_factor = rate_factor(row.motion_time_s, row.compute_time_s);
  return row;
}

ComparisonRow from_compensation(const compensation::CompensationResult& r);

ComparisonRow compensation_row(const plan::GcodeInput& path, const machine::Machine& machine,
                               const std::string& method, const dynamics::AxisModel& model,
                               const dynamics::AxisModel& plant, double rate_hz, double max_base_accel_mm_s2) {
  compensation::CompensationOptions o;
  o.method = compensation::parse_method(method);
  o.model_x = o.model_y = model;
  o.plant_x = o.plant_y = plant;
  o.sample_rate_hz = rate_hz;
  o.max_base_accel_mm_s2 = max_base_accel_mm_s2;
  return from_compensation(compensation::compensate_file(path, machine, o));
}

ComparisonRow from_compensation(const compensation::CompensationResult& r) {
  ComparisonRow row;
  row.method = r.method;
  row.kind = "compensation";
  row.status = std::string(compensation::to_string(r.status));
  row.max_contour_error_mm = r.max_contour_error_mm;
  row.rms_contour_error_mm = kNaN;
  row.max_tracking_error_mm = r.max_tracking_error_mm;
  row.rms_tracking_error_mm = r.rms_tracking_error_mm;
  row.max_residual_vibration_mm = kNaN;
  row.smoothing_mm = kNaN;
  row.lead_in_s = r.lead_in_s;
  row.peak_command_accel_mm_s2 = r.peak_command_accel_mm_s2;
  row.motion_time_s = r.motion_time_s;
  row.compute_time_s = r.compute_time_s;
  row.real_time_factor = r.real_time_factor;
  if (r.t_s.empty() && r.samples == 0) {  // no command (an infeasible bound): no figures
    row.max_contour_error_mm = row.max_tracking_error_mm = row.rms_tracking_error_mm = kNaN;
    row.peak_command_accel_mm_s2 = kNaN;
  }
  return row;
}

ComparisonRow shaper_row(const plan::GcodeInput& path, const machine::Machine& machine,
                         const std::string& type, const ComparisonOptions& options,
                         const dynamics::AxisModel& plant) {
  simulation::AxisShaperSetting s;
  s.type = type;
  s.freq_hz = options.natural_frequency_hz;
  s.damping_ratio = options.damping_ratio;
  s.source = "compare";
  simulation::ShaperSettings settings;
  settings.x = s;
  settings.y = s;
  settings.names_x = settings.names_y = {"--methods", "--natural-frequency-hz", "--damping-ratio"};
  const simulation::ShapedPrintResult r = simulation::simulate_shaped_print(
      path, machine, plant, plant, simulation_options(machine, options.sample_rate_hz), settings);
  ComparisonRow row;
  row.method = type;
  row.kind = "shaper";
  row.max_contour_error_mm = r.shaped.report.max_contour_error_mm;
  row.rms_contour_error_mm = r.shaped.report.rms_contour_error_mm;
  row.max_tracking_error_mm = kNaN;
  row.rms_tracking_error_mm = kNaN;
  row.max_residual_vibration_mm = r.shaped.report.max_residual_vibration_mm;
  row.smoothing_mm = r.smoothing.max_mm;
  row.lead_in_s = 0.0;
  row.peak_command_accel_mm_s2 = r.shaped.peaks.peak_accel_mm_s2;
  row.motion_time_s = r.shaped.report.motion_time_s;
  row.compute_time_s = r.shaped.compute_time_s;
  row.real_time_factor = rate_factor(row.motion_time_s, row.compute_time_s);
  return row;
}

// ------------------------------------------------------------------ one layer (a move span)

std::vector<plan::PlannedMove> layer_moves(const plan::GcodeInput& path, const machine::Machine& machine, int layer) {
  plan::PlanSource source(path, machine);
  plan::CollectSink collect;
  std::vector<plan::Sink*> sinks{&collect};
  plan::run_pipeline(source, sinks);
  std::vector<plan::PlannedMove> out;
  for (const auto& m : collect.moves)
    if (m.layer == layer) out.push_back(m);
  if (out.empty()) throw Error(fmt::format("--layer {}: the file has no moves in this layer", layer));
  return out;
}

/// The uncompensated run (no shaper: dynamics::StreamingSimulation, as `simulate`) or the
/// shaped run (simulation::ShapedStreamingSimulation, as `simulate --shaper`) on a move span.
ComparisonRow span_simulation_row(std::span<const plan::PlannedMove> moves, const machine::Machine& machine,
                                  const std::optional<shaping::Shaper>& shaper, const dynamics::AxisModel& plant,
                                  double rate_hz) {
  const auto t0 = std::chrono::steady_clock::now();
  const dynamics::PrintSimulationOptions o = simulation_options(machine, rate_hz);
  plan::ProfilePeaks peaks;
  for (const auto& m : moves) peaks.add(m);
  ComparisonRow row;
  dynamics::QualityReport rep;
  if (shaper) {
    simulation::ShapedStreamingSimulation sim(plant, plant, o.simulation, o.metrics,
                                              shaper, shaper);
    for (const auto& m : moves) sim.push(m);
    rep = sim.finish();
    row.kind = "shaper";
    row.smoothing_mm = sim.smoothing().max_mm;
  } else {
    dynamics::StreamingSimulation sim(plant, plant, o.simulation, o.metrics);
    for (const auto& m : moves) sim.push(m);
    rep = sim.finish();
    row.method = row.kind = "uncompensated";
    row.smoothing_mm = 0.0;
  }
  row.max_contour_error_mm = rep.max_contour_error_mm;
  row.rms_contour_error_mm = rep.rms_contour_error_mm;
  row.max_tracking_error_mm = kNaN;
  row.rms_tracking_error_mm = kNaN;
  row.max_residual_vibration_mm = rep.max_residual_vibration_mm;
  row.lead_in_s = 0.0;
  row.peak_command_accel_mm_s2 = peaks.peak_accel_mm_s2;
  row.motion_time_s = rep.motion_time_s;
  row.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  row.real_time_factor = rate_factor(row.motion_time_s, row.compute_time_s);
  return row;
}

ComparisonRow span_compensation_row(std::span<const plan::PlannedMove> moves, const std::string& method,
                                    const dynamics::AxisModel& model, const dynamics::AxisModel& plant,
                                    double rate_hz, double max_base_accel_mm_s2) {
  compensation::CompensationOptions o;
  o.method = compensation::parse_method(method);
  o.model_x = o.model_y = model;
  o.plant_x = o.plant_y = plant;
  o.sample_rate_hz = rate_hz;
  o.max_base_accel_mm_s2 = max_base_accel_mm_s2;
  return from_compensation(compensation::compensate(moves, o));
}

}  // namespace

void validate(const ComparisonOptions& o) {
  if (o.methods.empty()) throw Error("--methods: give at least one method");
  std::set<std::string> seen;
  for (const auto& m : o.methods) {
    if (!is_compensation(m) && !is_shaper(m))
      throw Error(fmt::format("--methods: '{}' is not a method; expected invert, fbf, lpfbf, rfbf, collocation, zv, mzv or ei", m));
    if (!seen.insert(m).second) throw Error(fmt::format("--methods: '{}' is given twice", m));
  }
  if (o.plant_offsets_pct.empty()) throw Error("--plant-offsets: give at least one offset");
  for (double p : o.plant_offsets_pct) {
    if (!std::isfinite(p) || !(p > -100.0))
      throw Error(fmt::format("--plant-offsets: {} % must be > -100 (the plant frequency must stay > 0)", p));
  }
  if (!(o.max_base_accel_mm_s2 > 0.0))
    throw Error(fmt::format("--max-base-accel-mm-s2: must be > 0, got {}", o.max_base_accel_mm_s2));
  if (!(o.natural_frequency_hz > 0.0) || !std::isfinite(o.natural_frequency_hz))
    throw Error(fmt::format("--natural-frequency-hz: must be > 0, got {}", o.natural_frequency_hz));
  if (!(o.damping_ratio >= 0.0) || !std::isfinite(o.damping_ratio))
    throw Error(fmt::format("--damping-ratio: must be >= 0, got {}", o.damping_ratio));
  const bool shapers = std::any_of(o.methods.begin(), o.methods.end(), is_shaper);
  if (shapers && !(o.damping_ratio < 1.0))
    throw Error(fmt::format("--damping-ratio: must be < 1 for the shapers (zv, mzv, ei), got {}", o.damping_ratio));
}

ComparisonResult compare_file(const plan::GcodeInput& input, const machine::Machine& machine,
                              const ComparisonOptions& options) {
  validate(options);
  // Every run plans the file again: one rewindable input (standard input and a FIFO are read
  // once; the later runs read the reader's copy).
  plan::RewindableGcode rewindable(input);
  const plan::GcodeInput path = rewindable;
  ComparisonResult result;
  result.file = input.path();
  result.natural_frequency_hz = options.natural_frequency_hz;
  result.damping_ratio = options.damping_ratio;
  result.sample_rate_hz = options.sample_rate_hz;
  result.max_base_accel_mm_s2 = options.max_base_accel_mm_s2;
  result.layer = options.layer;
  std::vector<plan::PlannedMove> span;
  if (options.layer) span = layer_moves(path, machine, *options.layer);
  const dynamics::AxisModel model = dynamics::AxisModel::belt(options.natural_frequency_hz, options.damping_ratio);
  for (double offset_pct : options.plant_offsets_pct) {
    const double plant_f_hz = options.natural_frequency_hz * (1.0 + offset_pct / 100.0);
    const dynamics::AxisModel plant = dynamics::AxisModel::belt(plant_f_hz, options.damping_ratio);
    auto add = [&](ComparisonRow row) {
      row.plant_offset_pct = offset_pct;
      row.plant_natural_frequency_hz = plant_f_hz;
      result.rows.push_back(std::move(row));
    };
    if (options.layer) {
      add(span_simulation_row(span, machine, std::nullopt, plant, options.sample_rate_hz));
      for (const auto& m : options.methods) {
        if (is_compensation(m)) {
          add(span_compensation_row(span, m, model, plant, options.sample_rate_hz, options.max_base_accel_mm_s2));
        } else {
          const shaping::Shaper shaper = simulation::make_axis_shaper(
              {m, options.natural_frequency_hz, options.damping_ratio, "compare"}, options.sample_rate_hz,
              {"--methods", "--natural-frequency-hz", "--damping-ratio"});
          ComparisonRow row = span_simulation_row(span, machine, shaper, plant, options.sample_rate_hz);
          row.method = m;
          add(std::move(row));
        }
      }
      continue;
    }
    add(uncompensated_row(path, machine, plant, options.sample_rate_hz));
    for (const auto& m : options.methods) {
      if (is_compensation(m))
        add(compensation_row(path, machine, m, model, plant, options.sample_rate_hz, options.max_base_accel_mm_s2));
      else
        add(shaper_row(path, machine, m, options, plant));
    }
  }
  return result;
}

Json to_json(const ComparisonResult& r) {
  Json j;
  j["file"] = r.file;
  j["layer"] = r.layer ? Json(*r.layer) : Json(nullptr);
  j["model"] = {{"natural_frequency_hz", json_number(r.natural_frequency_hz)},
                {"damping_ratio", json_number(r.damping_ratio)},
                {"sample_rate_hz", json_number(r.sample_rate_hz)}};
  j["max_base_accel_mm_s2"] = json_number(r.max_base_accel_mm_s2);
  Json rows = Json::array();
  for (const auto& row : r.rows) {
    rows.push_back({{"method", row.method},
                    {"kind", row.kind},
                    {"status", row.status},
                    {"plant_offset_pct", json_number(row.plant_offset_pct)},
                    {"plant_natural_frequency_hz", json_number(row.plant_natural_frequency_hz)},
                    {"max_contour_error_mm", json_number(row.max_contour_error_mm)},
                    {"rms_contour_error_mm", json_number(row.rms_contour_error_mm)},
                    {"max_tracking_error_mm", json_number(row.max_tracking_error_mm)},
                    {"rms_tracking_error_mm", json_number(row.rms_tracking_error_mm)},
                    {"max_residual_vibration_mm", json_number(row.max_residual_vibration_mm)},
                    {"smoothing_mm", json_number(row.smoothing_mm)},
                    {"lead_in_s", json_number(row.lead_in_s)},
                    {"peak_command_accel_mm_s2", json_number(row.peak_command_accel_mm_s2)},
                    {"motion_time_s", json_number(row.motion_time_s)},
                    {"compute_time_s", json_number(row.compute_time_s)},
                    {"real_time_factor", json_number(row.real_time_factor)}});
  }
  j["rows"] = std::move(rows);
  return j;
}

}  // namespace amctl::comparison
