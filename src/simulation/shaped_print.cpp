// A whole print through the belt dynamics with and without input shaping (one plan pass).
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>

#include <sys/stat.h>

#include <fmt/format.h>

#include "amctl/dynamics/sample_csv.hpp"
#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/profile_peaks.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/simulation/shaped_simulation.hpp"

namespace amctl::simulation {

namespace dy = amctl::dynamics;

shaping::Shaper make_axis_shaper(const AxisShaperSetting& s, double rate_hz, const ShaperParamNames& n) {
  shaping::ShaperSpec spec;
  try {
    spec = s.firmware == shaping::Firmware::marlin
               ? shaping::parse_shaper_spec(s.type, s.firmware, s.marlin_sample_rate_hz)
               : shaping::parse_shaper_spec(s.type);
  } catch (const Error& e) {
    throw Error(fmt::format("{} ({}): {}", n.type, s.source, e.what()));
  }
  if (!std::isfinite(s.freq_hz) || s.freq_hz <= 0.0) {
    throw Error(fmt::format("{}: must be a shaper frequency > 0 Hz ({}), got {}", n.freq, s.source, s.freq_hz));
  }
  if (s.freq_hz >= 0.5 * rate_hz) {
    throw Error(fmt::format("{} ({}) = {} Hz is at or above the Nyquist limit {} Hz of the sample "
                            "rate (--sample-rate-hz {})", n.freq, s.source, s.freq_hz, 0.5 * rate_hz, rate_hz));
  }
  if (!std::isfinite(s.damping_ratio) || s.damping_ratio < 0.0 || s.damping_ratio >= 1.0) {
    throw Error(fmt::format("{}: must be in [0, 1) ({}), got {}", n.damping, s.source, s.damping_ratio));
  }
  try {
    return shaping::make_shaper(spec, s.freq_hz, s.damping_ratio);
  } catch (const Error& e) {
    throw Error(fmt::format("{} ({}): {}", n.type, s.source, e.what()));
  }
}

void apply_machine_firmware(const machine::Machine& machine, AxisShaperSetting& setting) {
  if (machine.firmware != machine::Firmware::marlin) return;
  std::string name = setting.type.substr(0, setting.type.find('('));
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  while (!name.empty() && name.back() == ' ') name.pop_back();
  if (name != "zv") return;  // see the header: Prusa's Marlin-derived firmware runs Klipper's MZV
  setting.firmware = shaping::Firmware::marlin;
  setting.marlin_sample_rate_hz = 0.0;
}

void apply_requested_firmware(shaping::Firmware firmware, AxisShaperSetting& setting) {
  setting.firmware = firmware;
  setting.marlin_sample_rate_hz = firmware == shaping::Firmware::marlin ? shaping::kMarlinFtmSampleRateHz : 0.0;
}

std::vector<gcode::InputShapingCommand> m593_before_first_move(const plan::GcodeInput& input,
                                                              const machine::Machine& machine) {
  std::vector<gcode::InputShapingCommand> out;
  if (input.file() == nullptr) {
    // Only a path: a second open of "-" or a FIFO would find nothing (or wait forever).
    struct stat st {};
    if (input.path() == "-" || ::stat(input.path().c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return out;
  }
  plan::PlanSource source(input, machine);
  plan::PlanBatch batch;
  while (source.next(batch)) {
    for (const plan::PlanEvent& e : batch.events) {
      if (e.before_move > 0) return out;
      if (e.kind == plan::PlanEvent::Kind::input_shaping) out.push_back(e.shaping);
    }
    if (!batch.moves.empty()) return out;
  }
  return out;
}

ShaperSettings shapers_from_m593(std::span<const gcode::InputShapingCommand> commands) {
  ShaperSettings r;
  struct Axis {
    std::optional<double> freq_hz;
    double zeta = 0.15;  // Marlin SHAPING_ZETA_X / _Y default
    bool zeta_set = false;
    std::uint64_t line = 0;
  } axes[2];
  for (const gcode::InputShapingCommand& c : commands) {
    const bool sel[2] = {c.x, c.y};
    if (c.type) {
      r.warnings.push_back(fmt::format("line {}: M593 T{:g} ignored (Marlin documents the shaper "
                                       "type as not implemented; its stepper shaping is ZV)",
                                       c.line, *c.type));
    }
    if (c.damping_ratio) {
      const double z = *c.damping_ratio;
      if (std::isfinite(z) && z >= 0.0 && z <= 1.0) {
        for (int a = 0; a < 2; ++a) {
          if (!sel[a]) continue;
          axes[a].zeta = z;
          axes[a].zeta_set = true;
          axes[a].line = c.line;
        }
      } else {
        r.warnings.push_back(fmt::format("line {}: M593 D{} rejected, as Marlin does (range 0-1)", c.line, z));
      }
    }
    if (c.freq_hz) {
      const double f = *c.freq_hz;
      if (std::isfinite(f) && f >= 0.0) {
        for (int a = 0; a < 2; ++a) {
          if (!sel[a]) continue;
          axes[a].freq_hz = f;
          axes[a].line = c.line;
        }
      } else {
        r.warnings.push_back(fmt::format("line {}: M593 F{} rejected, as Marlin does (F must be > 0, or 0 to disable)",
                                         c.line, f));
      }
    }
  }
  for (int a = 0; a < 2; ++a) {
    const char ax = a == 0 ? 'X' : 'Y';
    if (!axes[a].freq_hz) {
      if (axes[a].zeta_set) {
        r.warnings.push_back(fmt::format("M593 sets the {} damping ratio but no frequency: the "
                                         "firmware's compiled-in frequency is not in the file, {} is not shaped",
                                         ax, ax));
      }
      continue;
    }
    if (*axes[a].freq_hz == 0.0) continue;  // F0: off
    AxisShaperSetting s;
    s.type = "zv";
    s.freq_hz = *axes[a].freq_hz;
    s.damping_ratio = axes[a].zeta;
    s.source = fmt::format("M593 line {}", axes[a].line);
    s.firmware = shaping::Firmware::marlin;  // the stepper ZV: exact times
    (a == 0 ? r.x : r.y) = s;
    ShaperParamNames& n = a == 0 ? r.names_x : r.names_y;
    n.type = fmt::format("M593 {}", ax);
    n.freq = fmt::format("M593 {} F", ax);
    n.damping = fmt::format("M593 {} D", ax);
  }
  return r;
}

namespace {

}  // namespace

ShapedSimulationSink::ShapedSimulationSink(ShapedStreamingSimulation& sim, std::vector<std::string>& warnings,
                                           bool require_moves)
    : sim_(sim), warnings_(warnings), require_moves_(require_moves) {}

void ShapedSimulationSink::consume(const plan::PlanBatch& batch) {
  plan::for_each_in_order(
      batch,
      [&](const plan::PlannedMove& m) {
        used_features_.insert(m.feature);
        sim_.push(m);
        ++moves_;
      },
      [&](const plan::PlanEvent& e) {
        if (e.kind != plan::PlanEvent::Kind::input_shaping || moves_ == 0) return;
        if (warnings_.size() < 100) {
          warnings_.push_back(fmt::format("line {}: M593 at print time {:.3f} s changes input shaping "
                                          "after the first move: not modelled (the simulation keeps "
                                          "the shaping it started with)", e.line, e.time_s));
        }
      });
}

void ShapedSimulationSink::finish(const plan::StreamSummary& summary) {
  if (moves_ == 0) {
    if (require_moves_) throw Error(fmt::format("{}: no moves to simulate", summary.file));
    return;
  }
  report_ = sim_.finish();
  feature_names_ = summary.feature_names;
  for (std::uint16_t f : used_features_) {
    if (feature_names_.size() <= f) feature_names_.resize(f + 1u, "unknown");
  }
}

ShapedPrintResult simulate_shaped_print(const plan::GcodeInput& input, const machine::Machine& machine,
                                        const dy::AxisModel& model_x, const dy::AxisModel& model_y,
                                        const dy::PrintSimulationOptions& options,
                                        const ShaperSettings& shapers) {
  const std::string& path = input.path();
  const double rate = options.simulation.sample_rate_hz;
  dy::require_above_nyquist(rate, {&model_x, &model_y});
  const dy::MetricsOptions& mo = options.metrics;
  if (mo.t_end_s < mo.t_begin_s) {
    throw Error(fmt::format("empty range: --t-end {} is before --t-begin {}", mo.t_end_s, mo.t_begin_s));
  }
  if (mo.layer_end < mo.layer_begin) {
    throw Error(fmt::format("empty range: --layer-end {} is before --layer-begin {}", mo.layer_end,
                            mo.layer_begin));
  }
  ShapedPrintResult r;
  r.settings = shapers;
  if (shapers.x) r.shaper_x = make_axis_shaper(*shapers.x, rate, shapers.names_x);
  if (shapers.y) r.shaper_y = make_axis_shaper(*shapers.y, rate, shapers.names_y);

  std::unique_ptr<dy::SampleCsvFile> csv;
  if (!options.csv_path.empty()) {
    csv = std::make_unique<dy::SampleCsvFile>(options.csv_path, dy::csv_decimation(rate, options.csv_rate_hz),
                                              OutputOptions{"--csv", {path}, {}});
  }
  ShapedStreamingSimulation::RowSink rows;
  if (csv || options.rows) {
    rows = [&csv, &options](const dy::SimSample& s, double e) {
      if (csv) csv->row(s, e);
      if (options.rows) options.rows(s, e);
    };
  }

  const auto t0 = std::chrono::steady_clock::now();
  plan::PlanSource source(input, machine);
  dy::SimulationOptions plain_opt = options.simulation;
  plain_opt.vibration_per_sample = false;
  dy::SimulationSink plain(model_x, model_y, plain_opt, options.metrics);
  ShapedStreamingSimulation stream(model_x, model_y, options.simulation, options.metrics, r.shaper_x, r.shaper_y,
                                   std::move(rows));
  if (csv) csv->set_first_step(stream.grid_start_steps());
  r.warnings = shapers.warnings;
  ShapedSimulationSink shaped(stream, r.warnings);
  plan::ProfilePeaksSink peaks;
  plan::Sink* sinks[] = {&plain, &shaped, &peaks};
  plan::run_pipeline(source, sinks);
  if (csv) csv->commit();
  const double compute_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  auto common = [&](dy::PrintSimulationResult& p) {
    p.compute_time_s = compute_s;
    p.file = path;
    p.machine_name = machine.name;
    p.profile = std::string(machine::to_string(machine.profile));
    p.model_x = model_x;
    p.model_y = model_y;
    p.motor_space = options.simulation.motor_space;
    p.sample_rate_hz = rate;
    p.peaks = peaks.peaks();
  };
  common(r.shaped);
  r.shaped.report = shaped.report();
  r.shaped.stats = stream.stats();
  r.shaped.moves = shaped.moves();
  r.shaped.max_window_moves = stream.max_window_moves();
  r.shaped.feature_names = shaped.feature_names();
  common(r.without);
  r.without.report = plain.report();
  r.without.stats = plain.stats();
  r.without.moves = plain.moves();
  r.without.max_window_moves = plain.max_window_moves();
  r.without.feature_names = plain.feature_names();
  r.smoothing = stream.smoothing();
  r.simulators = stream.simulators();
  return r;
}

Json to_json(const ShapedPrintResult& r, bool with_peaks) {
  Json j = dy::to_json(r.shaped, with_peaks);
  auto axis = [&](const std::optional<AxisShaperSetting>& s, const std::optional<shaping::Shaper>& sh) -> Json {
    if (!s || !sh) return nullptr;
    return {{"type", shaping::to_string(sh->spec)},
            {"freq_hz", json_number(sh->freq_hz)},
            {"damping_ratio", json_number(sh->damping_ratio)},
            {"source", s->source},
            {"firmware", std::string(shaping::to_string(sh->spec.firmware))},
            {"marlin_sample_rate_hz",
             sh->spec.sample_rate_hz > 0.0 ? json_number(sh->spec.sample_rate_hz) : Json(nullptr)},
            {"duration_s", json_number(sh->duration_s())},
            {"klipper_smoothing_mm",
             json_number(shaping::smoothing_mm(*sh, shaping::kKlipperSmoothingAccelMmS2,
                                               shaping::kKlipperSquareCornerVelocityMmS))}};
  };
  j["shaper"] = {{"x", axis(r.settings.x, r.shaper_x)}, {"y", axis(r.settings.y, r.shaper_y)},
                 {"simulators", r.simulators}};
  j["smoothing_mm"] = {{"max", json_number(r.smoothing.max_mm)},
                       {"rms", json_number(r.smoothing.rms_mm)},
                       {"max_at_corners", json_number(r.smoothing.max_at_corners_mm)}};
  Json w = dy::to_json(r.without.report, r.without.feature_names);
  w["axis_state_updates"] = r.without.stats.axis_state_updates;
  j["without_shaper"] = w;
  Json warn = Json::array();
  for (const auto& s : r.warnings) warn.push_back(s);
  j["shaper_warnings"] = warn;
  return j;
}

}  // namespace amctl::simulation
