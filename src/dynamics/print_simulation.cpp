#include "amctl/dynamics/print_simulation.hpp"

#include "amctl/dynamics/sample_csv.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::dynamics {

Mode parse_mode_spec(std::string_view text) {
  const std::string s(text);
  const auto bad = [&] {
    return Error(fmt::format("--mode '{}': expected f_hz,damping_ratio[,participation]", s));
  };
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= s.size()) {
    const std::size_t comma = s.find(',', pos);
    const std::string part = s.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    try {
      std::size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw bad();
    }
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  if (v.size() < 2 || v.size() > 3) throw bad();
  return Mode{v[0], v[1], v.size() == 3 ? v[2] : 1.0};
}

// ------------------------------------------------------------------------------ the sink
SimulationSink::SimulationSink(const AxisModel& model_x, const AxisModel& model_y,
                               const SimulationOptions& simulation, const MetricsOptions& metrics,
                               StreamingSimulation::RowSink rows)
    : stream_(model_x, model_y, simulation, metrics, std::move(rows)) {}

void SimulationSink::consume(const plan::PlanBatch& batch) {
  for (const plan::PlannedMove& m : batch.moves) {
    used_features_.insert(m.feature);
    stream_.push(m);
  }
  moves_ += batch.moves.size();
}

void SimulationSink::finish(const plan::StreamSummary& summary) {
  if (moves_ == 0) throw Error(fmt::format("{}: no moves to simulate", summary.file));
  report_ = stream_.finish();
  // Names by PlannedMove::feature; a move beyond the interpreter's table is "unknown", as
  // in the estimate report.
  feature_names_ = summary.feature_names;
  for (std::uint16_t f : used_features_) {
    if (feature_names_.size() <= f) feature_names_.resize(f + 1u, "unknown");
  }
}

PrintSimulationResult simulate_print(const plan::GcodeInput& input, const machine::Machine& machine,
                                     const AxisModel& model_x, const AxisModel& model_y,
                                     const PrintSimulationOptions& options) {
  const std::string& path = input.path();
  require_above_nyquist(options.simulation.sample_rate_hz, {&model_x, &model_y});
  const MetricsOptions& mo = options.metrics;
  if (mo.t_end_s < mo.t_begin_s) {
    throw Error(fmt::format("empty range: --t-end {} is before --t-begin {}", mo.t_end_s, mo.t_begin_s));
  }
  if (mo.layer_end < mo.layer_begin) {
    throw Error(fmt::format("empty range: --layer-end {} is before --layer-begin {}", mo.layer_end,
                            mo.layer_begin));
  }
  std::unique_ptr<SampleCsvFile> csv;
  if (!options.csv_path.empty()) {
    csv = std::make_unique<SampleCsvFile>(
        options.csv_path, csv_decimation(options.simulation.sample_rate_hz, options.csv_rate_hz),
        OutputOptions{"--csv", {path}, {}});
  }
  StreamingSimulation::RowSink rows;
  if (csv && options.rows) {
    rows = [&csv, &options](const SimSample& s, double e) {
      csv->row(s, e);
      options.rows(s, e);
    };
  } else if (csv) {
    rows = [&csv](const SimSample& s, double e) { csv->row(s, e); };
  } else if (options.rows) {
    rows = options.rows;
  }

  const auto t0 = std::chrono::steady_clock::now();
  plan::PlanSource source(input, machine);
  SimulationSink sim(model_x, model_y, options.simulation, options.metrics, std::move(rows));
  plan::ProfilePeaksSink peaks;
  plan::Sink* sinks[] = {&sim, &peaks};
  plan::run_pipeline(source, sinks);
  if (csv) csv->commit();

  PrintSimulationResult r;
  r.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.file = path;
  r.machine_name = machine.name;
  r.profile = std::string(machine::to_string(machine.profile));
  r.model_x = model_x;
  r.model_y = model_y;
  r.motor_space = options.simulation.motor_space;
  r.sample_rate_hz = options.simulation.sample_rate_hz;
  r.report = sim.report();
  r.stats = sim.stats();
  r.moves = sim.moves();
  r.max_window_moves = sim.max_window_moves();
  r.feature_names = sim.feature_names();
  r.peaks = peaks.peaks();
  return r;
}

// ------------------------------------------------------------------------------ JSON
Json to_json(const QualityReport& r, const std::vector<std::string>& feature_names) {
  auto feature = [&](std::size_t k) {
    return k < feature_names.size() ? Json(feature_names[k]) : Json(k);
  };
  Json j;
  j["motion_time_s"] = r.motion_time_s;
  j["samples"] = r.samples;
  j["max_contour_error_mm"] = r.max_contour_error_mm;
  j["rms_contour_error_mm"] = r.rms_contour_error_mm;
  j["max_contour_error_printing_mm"] = r.max_contour_error_printing_mm;
  j["rms_contour_error_printing_mm"] = r.rms_contour_error_printing_mm;
  j["max_corner_overshoot_mm"] = r.max_corner_overshoot_mm;
  j["max_residual_vibration_mm"] = r.max_residual_vibration_mm;
  j["final_residual_vibration_mm"] = r.final_residual_vibration_mm;
  j["ringing_wavelength_mm"] = json_number(r.ringing_wavelength_mm);
  j["ringing_amplitude_mm"] = r.ringing_amplitude_mm;
  j["corners"] = r.corner_count;
  Json corners = Json::array();
  for (const auto& c : r.corners) {
    corners.push_back({{"line", c.line}, {"angle_deg", c.angle_deg},
                       {"junction_speed_mm_s", c.junction_speed_mm_s},
                       {"overshoot_mm", c.overshoot_mm},
                       {"ringing_wavelength_mm", json_number(c.ringing_wavelength_mm)},
                       {"ringing_amplitude_mm", c.ringing_amplitude_mm}});
  }
  j["worst_corners"] = corners;
  Json worst = Json::array();
  for (const auto& w : r.worst) {
    worst.push_back({{"line", w.line}, {"layer", w.layer}, {"feature", feature(w.feature)},
                     {"t_s", w.t_s}, {"x_mm", w.x_mm}, {"y_mm", w.y_mm},
                     {"contour_error_mm", w.contour_error_mm}});
  }
  j["worst"] = worst;
  Json layers = Json::array();
  for (const auto& [k, g] : r.per_layer) {
    layers.push_back({{"layer", k}, {"max_contour_error_mm", g.max_contour_error_mm},
                      {"rms_contour_error_mm", g.rms_contour_error_mm}, {"samples", g.samples}});
  }
  j["layers"] = layers;
  Json feats = Json::array();
  for (const auto& [k, g] : r.per_feature) {
    feats.push_back({{"feature", feature(k)},
                     {"max_contour_error_mm", g.max_contour_error_mm},
                     {"rms_contour_error_mm", g.rms_contour_error_mm}, {"samples", g.samples}});
  }
  j["features"] = feats;
  return j;
}

Json to_json(const PrintSimulationResult& r, bool with_peaks) {
  Json j = to_json(r.report, r.feature_names);
  j["file"] = r.file;
  j["machine"] = r.machine_name;
  j["profile"] = r.profile;
  auto modes_json = [](const AxisModel& m) {
    Json arr = Json::array();
    for (const auto& md : m.modes()) {
      arr.push_back({{"natural_frequency_hz", md.natural_frequency_hz},
                     {"damping_ratio", md.damping_ratio}, {"participation", md.participation}});
    }
    return arr;
  };
  j["model"] = {{"x", modes_json(r.model_x)}, {"y", modes_json(r.model_y)},
                {"space", r.motor_space ? "motor" : "cartesian"}};
  j["sample_rate_hz"] = r.sample_rate_hz;
  j["moves"] = r.moves;
  j["max_window_moves"] = r.max_window_moves;
  j["simulated_time_s"] = r.stats.end_time_s - r.stats.start_time_s;
  j["axis_state_updates"] = r.stats.axis_state_updates;
  j["compute_time_s"] = r.compute_time_s;
  if (with_peaks) {
    j["peak_accel_mm_s2"] = r.peaks.peak_accel_mm_s2;
    j["peak_jerk_mm_s3"] = json_number(r.peaks.peak_jerk_mm_s3);
  }
  return j;
}

}  // namespace amctl::dynamics
