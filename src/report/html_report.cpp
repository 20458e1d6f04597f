#include "amctl/thermal/studies.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/shaper.hpp"
#include "amctl/report/html_report.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/dynamics/print_simulation.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/report_json.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/report/speed_lod.hpp"
#include "amctl/simulation/shaped_simulation.hpp"
#include "page.hpp"

namespace amctl::report {
namespace {

/// The simulation, skipped for a stream without moves (the page then says there are none).
class OptionalSimulation final : public plan::Sink {
 public:
  OptionalSimulation(const dynamics::AxisModel& mx, const dynamics::AxisModel& my,
                     const dynamics::SimulationOptions& so, const dynamics::MetricsOptions& mo,
                     dynamics::StreamingSimulation::RowSink rows)
      : sim_(mx, my, so, mo, std::move(rows)) {}
  void consume(const plan::PlanBatch& batch) override {
    if (!batch.moves.empty()) any_ = true;
    sim_.consume(batch);
  }
  void finish(const plan::StreamSummary& summary) override {
    if (any_) sim_.finish(summary);
  }
  [[nodiscard]] bool ran() const { return any_; }
  [[nodiscard]] const dynamics::SimulationSink& sim() const { return sim_; }

 private:
  dynamics::SimulationSink sim_;
  bool any_ = false;
};

std::int64_t round_to(double v, double unit) {
  return std::isfinite(v) ? std::llround(v / unit) : 0;
}

Json speed_json(const SpeedLodSink& lod) {
  Json vmin = Json::array(), vmax = Json::array(), vmean = Json::array(), feat = Json::array();
  for (const SpeedBucket& b : lod.buckets()) {
    vmin.push_back(round_to(b.min_speed_mm_s, 0.1));
    vmax.push_back(round_to(b.max_speed_mm_s, 0.1));
    vmean.push_back(round_to(b.distance_mm / lod.bucket_s(), 0.1));
    feat.push_back(b.dominant_feature());
  }
  return Json{{"bucket_s", lod.bucket_s()},
              {"max_buckets", lod.max_buckets()},
              {"end_time_s", lod.end_time_s()},
              {"unit", "0.1 mm/s"},
              {"min_speed", std::move(vmin)},
              {"max_speed", std::move(vmax)},
              {"mean_speed", std::move(vmean)},
              {"feature", std::move(feat)}};
}

/// The print's own heater targets: the first non-zero target of each heater (M104/M109 for
/// the hotend, M140/M190 for the bed), for the heater section's study.
class HeaterTargets final : public plan::Sink {
 public:
  void consume(const plan::PlanBatch& batch) override {
    for (const plan::PlanEvent& e : batch.events) {
      if (e.kind != plan::PlanEvent::Kind::heater || !(e.heater.target_c > 0.0)) continue;
      auto& slot = e.heater.kind == gcode::HeaterCommand::Kind::bed ? bed_c : hotend_c;
      if (!slot) slot = e.heater.target_c;
    }
  }
  std::optional<double> hotend_c, bed_c;
};

Json toolpath_json(const ToolpathSink& tp, bool with_error) {
  Json layers = Json::array();
  for (const ToolpathLayer& l : tp.layers()) {
    Json x = Json::array(), y = Json::array(), v = Json::array(), k = Json::array(),
         e = Json::array();
    std::int64_t px = 0, py = 0;
    for (const ToolpathVertex& p : l.vertices) {
      const std::int64_t qx = round_to(p.x_mm, 0.01), qy = round_to(p.y_mm, 0.01);
      x.push_back(qx - px);
      y.push_back(qy - py);
      px = qx;
      py = qy;
      v.push_back(round_to(p.speed_mm_s, 1.0));
      k.push_back(p.kind);
      if (with_error) e.push_back(p.error_mm < 0.0F ? -1 : round_to(p.error_mm, 0.001));
    }
    Json j{{"layer", l.layer},     {"z_mm", l.z_mm}, {"tolerance_mm", l.tolerance_mm},
           {"truncated", l.truncated}, {"moves", l.moves}, {"dx", std::move(x)},
           {"dy", std::move(y)},   {"speed", std::move(v)}, {"kind", std::move(k)}};
    if (with_error) j["error_um"] = std::move(e);
    layers.push_back(std::move(j));
  }
  const ToolpathOptions& o = tp.options();
  return Json{{"units", {{"xy", "0.01 mm, delta from the previous vertex"},
                         {"speed", "mm/s"},
                         {"error", "um, -1 = no sample"},
                         {"kind", "-2 start of a polyline, -1 travel, else feature index"}}},
              {"tolerance_mm", o.tolerance_mm},
              {"max_points_per_layer", o.max_points_per_layer},
              {"max_points", o.max_points},
              {"points", tp.points()},
              {"moves", tp.moves()},
              {"capped", tp.capped()},
              {"layers", std::move(layers)}};
}

}  // namespace

/// The resonance section: resonance::calibrate_file (Klipper's calibration) and, for the
/// plot, the normalised PSD up to Klipper's 200 Hz, each fitted shaper's remaining-vibration
/// curve (Klipper's estimate at the design damping ratio) and psd_xyz after the recommended
/// shaper (the PSD times its curve, as Klipper's graph draws it).
Json accel_json(const ReportOptions& options) {
  resonance::CalibrateOptions co;
  co.axis = options.accel_axis;
  const resonance::CalibrationReport r = resonance::calibrate_file(options.accel_path, co);
  Json a = resonance::to_json(r);
  const resonance::PsdTable& p = r.psd;
  std::vector<double> f;
  std::size_t n = 0;
  while (n < p.freq_hz.size() && p.freq_hz[n] <= co.klipper.max_freq_hz) ++n;
  std::size_t first = 0;  // Klipper's grid starts above 0 Hz; the curves need f > 0
  while (first < n && !(p.freq_hz[first] > 0.0)) ++first;
  f.assign(p.freq_hz.begin() + static_cast<std::ptrdiff_t>(first), p.freq_hz.begin() + static_cast<std::ptrdiff_t>(n));
  auto slice = [&](const std::vector<double>& v) {
    return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(first), v.begin() + static_cast<std::ptrdiff_t>(n));
  };
  Json plot;
  plot["freq_hz"] = f;
  plot["psd_x"] = slice(p.psd_x);
  plot["psd_y"] = slice(p.psd_y);
  plot["psd_z"] = slice(p.psd_z);
  plot["psd_xyz"] = slice(p.psd_xyz);
  Json curves = Json::array();
  std::vector<double> after;
  for (const resonance::ShaperFit& s : r.klipper.shapers) {
    const shaping::Shaper sh = shaping::make_shaper(s.name, s.freq_hz, co.klipper.damping_ratio);
    const shaping::VibrationCurve c = shaping::vibration_curve(sh, f, co.klipper.damping_ratio);
    curves.push_back({{"name", s.name}, {"freq_hz", s.freq_hz}, {"remaining", c.remaining_fraction}});
    if (s.name == r.klipper.recommended.name) {
      after.resize(f.size());
      for (std::size_t i = 0; i < f.size(); ++i) after[i] = p.psd_xyz[first + i] * c.remaining_fraction[i];
    }
  }
  plot["curves"] = std::move(curves);
  plot["after_recommended"] = after;
  a["plot"] = std::move(plot);
  a["file"] = options.accel_path;
  return a;
}

/// The heater section: the study of `amctl thermal hotend|bed` (its JSON) and, per controller,
/// the trace decimated to at most 1500 points (every k-th step; the scenario's 0.1 s steps
/// would be 3600 points a run).
Json thermal_json(const std::string& which, std::optional<double> print_target_c) {
  if (which != "hotend" && which != "bed") {
    throw Error(fmt::format("thermal section must be 'hotend' or 'bed', got '{}'", which));
  }
  thermal::HeaterStudyOptions o =
      which == "bed" ? thermal::HeaterStudyOptions::bed_defaults() : thermal::HeaterStudyOptions::hotend();
  const double study_default_c = o.target_c;
  if (print_target_c) o.target_c = *print_target_c;
  const thermal::HeaterStudy s = thermal::run_heater_study(o);
  Json t = thermal::to_json(s);
  t["heater"] = which;
  t["target_from"] = print_target_c ? "the print (its first " + which + " temperature)"
                                    : fmt::format("the study's default ({:g} C): the print sets no {} temperature",
                                                  study_default_c, which);
  t["target_c"] = s.scenario.target_c;
  t["fan_on_at_s"] = s.scenario.fan_on_at_s;
  t["flow_start_s"] = s.scenario.flow_start_s;
  Json traces = Json::array();
  for (const thermal::HeaterRunStats& r : s.runs) {
    const std::size_t n = r.t_s.size(), k = std::max<std::size_t>(1, (n + 1499) / 1500);
    std::vector<double> ts, temp, duty;
    for (std::size_t i = 0; i < n; i += k) {
      ts.push_back(r.t_s[i]);
      temp.push_back(r.measured_c[i]);
      duty.push_back(r.duty[i]);
    }
    traces.push_back({{"controller", r.controller}, {"t_s", ts}, {"measured_c", temp}, {"duty", duty}});
  }
  t["traces"] = std::move(traces);
  return t;
}

Json report_data(const std::string& path, const machine::Machine& machine,
                 const ReportOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  plan::SourceOptions so;
  so.strict = options.strict;
  so.planner.file_limits = options.file_limits;
  plan::PlanSource source(path, machine, so);
  plan::EstimateSink estimate(machine);
  SpeedLodSink lod(options.speed_buckets);
  std::optional<SpeedLodSink> fine;
  if (options.fine_speed_buckets > options.speed_buckets) fine.emplace(options.fine_speed_buckets);
  ToolpathSink toolpath(options.toolpath);
  HeaterTargets targets;
  std::vector<plan::Sink*> sinks{&estimate, &lod, &toolpath, &targets};
  if (fine) sinks.push_back(&*fine);

  std::unique_ptr<OptionalSimulation> sim;
  std::optional<dynamics::AxisModel> model;
  // With a shaper on the machine ([input_shaper], or M593 before the first move), the nozzle
  // follows the shaped command: the same shaped simulation `amctl simulate` runs.
  simulation::ShaperSettings shapers;
  std::optional<shaping::Shaper> shaper_x, shaper_y;
  std::unique_ptr<simulation::ShapedStreamingSimulation> shaped_stream;
  std::unique_ptr<simulation::ShapedSimulationSink> shaped;
  std::vector<std::string> shaper_warnings;
  if (options.belt) {
    model = dynamics::AxisModel::belt(options.belt->natural_frequency_hz, options.belt->damping_ratio);
    dynamics::require_above_nyquist(options.sample_rate_hz, {&*model});
    dynamics::SimulationOptions sim_o;
    sim_o.sample_rate_hz = options.sample_rate_hz;
    dynamics::MetricsOptions met_o;
    met_o.keep_per_move = false;  // bounded memory
    // The toolpath sink comes before the simulation in `sinks`, so it has seen every move
    // of a batch before the simulation emits that batch's samples.
    auto rows = [&toolpath](const dynamics::SimSample& s, double e) { toolpath.add_error_sample(s.t_s, e); };
    if (options.machine_shaper) {
      simulation::ShaperRequest none;
      shapers = simulation::resolve_shapers(none, machine, plan::GcodeInput(path));
    }
    if (shapers.any()) {
      if (shapers.x) shaper_x = simulation::make_axis_shaper(*shapers.x, options.sample_rate_hz, shapers.names_x);
      if (shapers.y) shaper_y = simulation::make_axis_shaper(*shapers.y, options.sample_rate_hz, shapers.names_y);
      shaper_warnings = shapers.warnings;
      shaped_stream = std::make_unique<simulation::ShapedStreamingSimulation>(
          *model, *model, sim_o, met_o, shaper_x, shaper_y, rows);
      shaped = std::make_unique<simulation::ShapedSimulationSink>(*shaped_stream, shaper_warnings, false);
      sinks.push_back(shaped.get());
    } else {
      sim = std::make_unique<OptionalSimulation>(*model, *model, sim_o, met_o, rows);
      sinks.push_back(sim.get());
    }
  }
  const plan::StreamSummary& summary = plan::run_pipeline(source, sinks);
  const double compute_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  Json d;
  d["format"] = "amctl-report-1";
  d["file"] = path;
  d["estimate"] = plan::to_json(estimate.report(), machine, compute_s);
  d["feature_names"] = summary.feature_names;
  d["speed"] = speed_json(lod);
  // Finer buckets for zoomed views, only where they add detail (a print shorter than the
  // coarse level's finest width gains nothing).
  d["speed_fine"] = fine && fine->bucket_s() < lod.bucket_s() ? speed_json(*fine) : Json(nullptr);
  const bool simulated = (sim && sim->ran()) || (shaped && shaped->moves() > 0);
  d["toolpath"] = toolpath_json(toolpath, simulated);
  d["no_moves"] = estimate.report().moves == 0;
  if (simulated) {
    Json q = shaped ? dynamics::to_json(shaped->report(), shaped->feature_names())
                    : dynamics::to_json(sim->sim().report(), sim->sim().feature_names());
    q["natural_frequency_hz"] = options.belt->natural_frequency_hz;
    q["damping_ratio"] = options.belt->damping_ratio;
    q["sample_rate_hz"] = options.sample_rate_hz;
    if (shaped) {
      // Only with a shaper, so that a report without one is what it was.
      auto axis = [](const std::optional<simulation::AxisShaperSetting>& set,
                     const std::optional<shaping::Shaper>& sh) -> Json {
        if (!set || !sh) return nullptr;
        return {{"type", shaping::to_string(sh->spec)},
                {"firmware", std::string(shaping::to_string(sh->spec.firmware))},
                {"marlin_sample_rate_hz",
                 sh->spec.sample_rate_hz > 0.0 ? json_number(sh->spec.sample_rate_hz) : Json(nullptr)},
                {"freq_hz", json_number(sh->freq_hz)},
                {"damping_ratio", json_number(sh->damping_ratio)},
                {"duration_s", json_number(sh->duration_s())},
                {"source", set->source}};
      };
      Json warn = Json::array();
      for (const std::string& w : shaper_warnings) warn.push_back(w);
      q["shaper"] = {{"x", axis(shapers.x, shaper_x)}, {"y", axis(shapers.y, shaper_y)},
                     {"warnings", std::move(warn)}};
    }
    d["quality"] = std::move(q);
  } else {
    d["quality"] = nullptr;
  }
  d["accel"] = options.accel_path.empty() ? Json(nullptr) : accel_json(options);
  d["thermal"] = options.thermal.empty()
                     ? Json(nullptr)
                     : thermal_json(options.thermal, options.thermal == "bed" ? targets.bed_c : targets.hotend_c);
  return d;
}

std::string render_html(const Json& data) {
  const std::string json = data.dump();
  std::string safe;
  safe.reserve(json.size() + json.size() / 64);
  for (const char c : json) {
    if (c == '<') {
      safe += "\\u003c";
    } else {
      safe += c;
    }
  }
  std::string page;
  page.reserve(safe.size() + 64 * 1024);
  page += page_head();
  page += safe;
  page += page_tail();
  return page;
}

ReportResult write_report(const std::string& path, const machine::Machine& machine,
                          const std::string& output_path, const ReportOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  // Opened first: an output that is the input, or cannot be written, fails before the work.
  OutputFile out(output_path, OutputOptions{"-o/--output", {path}, {}});
  const Json data = report_data(path, machine, options);
  const std::string page = render_html(data);
  out.write(page);
  out.commit();
  ReportResult r;
  r.file = path;
  r.output = output_path;
  r.bytes = page.size();
  r.moves = data["estimate"]["moves"].get<std::uint64_t>();
  r.layers = data["estimate"]["layers"].size();
  r.toolpath_points = data["toolpath"]["points"].get<std::size_t>();
  r.toolpath_capped = data["toolpath"]["capped"].get<bool>();
  r.speed_buckets = data["speed"]["max_speed"].size();
  r.simulated = !data["quality"].is_null();
  r.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

Json to_json(const ReportResult& r) {
  return Json{{"file", r.file},
              {"output", r.output},
              {"bytes", r.bytes},
              {"moves", r.moves},
              {"layers", r.layers},
              {"toolpath_points", r.toolpath_points},
              {"toolpath_capped", r.toolpath_capped},
              {"speed_buckets", r.speed_buckets},
              {"simulated", r.simulated},
              {"compute_time_s", r.compute_time_s}};
}

}  // namespace amctl::report
