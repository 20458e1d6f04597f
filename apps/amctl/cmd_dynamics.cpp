// `amctl simulate` and `amctl sweep`: what the printer physically does with a plan.
//   amctl simulate FILE --machine SPEC --natural-frequency-hz F --damping-ratio Z [--json]
//                  [--sample-rate-hz R] [--csv OUT --csv-rate-hz C] [--t-begin/--t-end S]
//                  [--layer-begin/--layer-end N] [--profile P --jerk J] [--motor-space]
//   amctl sweep [--json]   seed 000 tables 3.2/3.3 with real look-ahead and zero junction speed
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "amctl/core/error.hpp"
#include "amctl/dynamics/metrics.hpp"
#include "amctl/dynamics/simulate.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/trajectory/retime.hpp"
#include "amctl/trajectory/sampling.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

using nlohmann::json;
namespace dy = amctl::dynamics;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

struct ModelFlags {
  std::optional<double> f_hz, zeta, mass_kg, stiffness, damping;
  std::optional<double> f_hz_y, zeta_y;
  std::vector<std::string> modes;  ///< "f_hz,zeta[,participation]" for both axes
};

dy::Mode parse_mode(const std::string& text) {
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = text.find(',', pos);
    const std::string part = text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    try {
      std::size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size()) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw Error(fmt::format("--mode '{}': expected f_hz,damping_ratio[,participation]", text));
    }
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  if (v.size() < 2 || v.size() > 3) {
    throw Error(fmt::format("--mode '{}': expected f_hz,damping_ratio[,participation]", text));
  }
  return dy::Mode{v[0], v[1], v.size() == 3 ? v[2] : 1.0};
}

dy::AxisModel build_model(const ModelFlags& m, bool y_axis) {
  if (!m.modes.empty()) {
    if (m.f_hz || m.mass_kg) throw Error("--mode replaces the belt flags; give one or the other");
    std::vector<dy::Mode> modes;
    for (const auto& t : m.modes) modes.push_back(parse_mode(t));
    return dy::AxisModel::from_modes(std::move(modes));
  }
  const auto f = y_axis && m.f_hz_y ? m.f_hz_y : m.f_hz;
  const auto z = y_axis && m.zeta_y ? m.zeta_y : m.zeta;
  if (m.mass_kg || m.stiffness) {
    if (!m.mass_kg || !m.stiffness) {
      throw Error("--mass-kg and --stiffness-n-per-m must be given together");
    }
    return dy::AxisModel::belt(dy::BeltParameters{*m.mass_kg, *m.stiffness, m.damping.value_or(0.0)});
  }
  if (!f) throw Error("give the belt model: --natural-frequency-hz (with --damping-ratio) or --mass-kg and --stiffness-n-per-m");
  return dy::AxisModel::belt(*f, z.value_or(0.1));
}

struct SimRun {
  dy::QualityReport report;
  dy::SimulationStats stats;
  double compute_s = 0.0;
};

SimRun run_simulation(const std::vector<plan::PlannedMove>& moves, const dy::AxisModel& mx,
                      const dy::AxisModel& my, const dy::SimulationOptions& so,
                      const dy::MetricsOptions& mo, const std::function<void(const dy::SimSample&, double)>& row) {
  const auto t0 = std::chrono::steady_clock::now();
  dy::QualityMeter meter(moves, mo);
  SimRun r;
  r.stats = dy::simulate(moves, mx, my, so, [&](const dy::SimSample& s) {
    const double e = meter.add(s);
    if (row) row(s, e);
  }, [&](std::size_t i, double t, const std::array<double, 2>& v) { meter.on_move_end(i, t, v); });
  r.report = meter.finish();
  r.compute_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

json report_json(const dy::QualityReport& r, const std::vector<std::string>& feature_names) {
  json j;
  j["motion_time_s"] = r.motion_time_s;
  j["samples"] = r.samples;
  j["max_contour_error_mm"] = r.max_contour_error_mm;
  j["rms_contour_error_mm"] = r.rms_contour_error_mm;
  j["max_contour_error_printing_mm"] = r.max_contour_error_printing_mm;
  j["rms_contour_error_printing_mm"] = r.rms_contour_error_printing_mm;
  j["max_corner_overshoot_mm"] = r.max_corner_overshoot_mm;
  j["max_residual_vibration_mm"] = r.max_residual_vibration_mm;
  j["final_residual_vibration_mm"] = r.final_residual_vibration_mm;
  j["ringing_wavelength_mm"] = num(r.ringing_wavelength_mm);
  j["ringing_amplitude_mm"] = r.ringing_amplitude_mm;
  j["corners"] = r.corner_count;
  json corners = json::array();
  for (const auto& c : r.corners) {
    corners.push_back({{"line", c.line}, {"angle_deg", c.angle_deg},
                       {"junction_speed_mm_s", c.junction_speed_mm_s},
                       {"overshoot_mm", c.overshoot_mm},
                       {"ringing_wavelength_mm", num(c.ringing_wavelength_mm)},
                       {"ringing_amplitude_mm", c.ringing_amplitude_mm}});
  }
  j["worst_corners"] = corners;
  json worst = json::array();
  for (const auto& w : r.worst) {
    worst.push_back({{"line", w.line}, {"layer", w.layer}, {"feature", w.feature < feature_names.size() ? json(feature_names[w.feature]) : json(w.feature)},
                     {"t_s", w.t_s}, {"x_mm", w.x_mm}, {"y_mm", w.y_mm},
                     {"contour_error_mm", w.contour_error_mm}});
  }
  j["worst"] = worst;
  json layers = json::array();
  for (const auto& [k, g] : r.per_layer) {
    layers.push_back({{"layer", k}, {"max_contour_error_mm", g.max_contour_error_mm},
                      {"rms_contour_error_mm", g.rms_contour_error_mm}, {"samples", g.samples}});
  }
  j["layers"] = layers;
  json feats = json::array();
  for (const auto& [k, g] : r.per_feature) {
    feats.push_back({{"feature", k < feature_names.size() ? json(feature_names[k]) : json(k)},
                     {"max_contour_error_mm", g.max_contour_error_mm},
                     {"rms_contour_error_mm", g.rms_contour_error_mm}, {"samples", g.samples}});
  }
  j["features"] = feats;
  return j;
}

plan::VelocityProfile parse_profile(const std::string& s) {
  if (s == "trapezoid") return plan::VelocityProfile::trapezoid;
  if (s == "scurve7") return plan::VelocityProfile::scurve7;
  if (s == "bezier5") return plan::VelocityProfile::bezier5;
  throw Error(fmt::format("--profile must be trapezoid, scurve7 or bezier5, got '{}'", s));
}

// ------------------------------------------------------------------------------ simulate
struct SimulateArgs {
  std::string file;
  MachineOptions machine;
  ModelFlags model;
  double rate_hz = 1000.0;
  std::optional<double> csv_rate_hz;
  std::string csv;
  std::optional<double> t_begin, t_end;
  std::optional<int> layer_begin, layer_end;
  std::string profile;
  std::optional<double> jerk;
  bool motor_space = false;
  bool json_out = false;
  std::size_t worst = 10;
  double corner_window_s = 0.25;
};

void do_simulate(const SimulateArgs& a) {
  const machine::Machine mach = resolve_machine(a.machine);
  const dy::AxisModel mx = build_model(a.model, false), my = build_model(a.model, true);
  dy::SimulationOptions so;
  so.sample_rate_hz = a.rate_hz;
  so.kinematics = mach.kinematics;
  so.motor_space = a.motor_space;
  so.vibration_per_sample = !a.csv.empty();
  dy::require_above_nyquist(a.rate_hz, {&mx, &my});
  dy::MetricsOptions mo;
  mo.worst_count = a.worst;
  mo.corner_window_s = a.corner_window_s;
  mo.keep_per_move = false;  // bounded memory
  if (a.t_begin) mo.t_begin_s = *a.t_begin;
  if (a.t_end) mo.t_end_s = *a.t_end;
  if (a.layer_begin) mo.layer_begin = *a.layer_begin;
  if (a.layer_end) mo.layer_end = *a.layer_end;
  if (mo.t_end_s < mo.t_begin_s) {
    throw Error(fmt::format("empty range: --t-end {} is before --t-begin {}", mo.t_end_s, mo.t_begin_s));
  }
  if (mo.layer_end < mo.layer_begin) {
    throw Error(fmt::format("empty range: --layer-end {} is before --layer-begin {}", mo.layer_end, mo.layer_begin));
  }
  std::ofstream csv;
  std::size_t decim = 1;
  if (!a.csv.empty()) {
    const double cr = a.csv_rate_hz.value_or(a.rate_hz);
    require_positive("csv_rate_hz", cr);
    const double ratio = a.rate_hz / cr;
    decim = static_cast<std::size_t>(std::llround(ratio));
    if (decim < 1 || std::abs(ratio - static_cast<double>(decim)) > 1e-9 * ratio) {
      throw Error(fmt::format("--csv-rate-hz {} must divide --sample-rate-hz {} evenly", cr, a.rate_hz));
    }
    csv.open(a.csv);
    if (!csv) throw Error(fmt::format("cannot write CSV file '{}'", a.csv));
    csv << "t_s,cmd_x_mm,cmd_y_mm,cmd_z_mm,sim_x_mm,sim_y_mm,contour_error_mm,vibration_mm,line\n";
  }
  std::size_t k = 0;
  auto row = [&](const dy::SimSample& s, double e) {
    if (!csv.is_open()) return;
    if (k++ % decim != 0 || std::isnan(e)) return;
    csv << fmt::format("{:.6f},{:.6f},{:.6f},{:.4f},{:.6f},{:.6f},{:.6g},{:.6g},{}\n", s.t_s,
                       s.cmd_mm[0], s.cmd_mm[1], s.cmd_mm[2], s.sim_mm[0], s.sim_mm[1], e,
                       std::hypot(s.vibration_mm[0], s.vibration_mm[1]), s.line);
  };

  const auto t_start = std::chrono::steady_clock::now();
  dy::StreamingSimulation stream(mx, my, so, mo, row);
  std::set<std::uint16_t> used_features;
  std::size_t n_moves = 0;
  trajectory::ProfileFigures fig;
  double first_start = 0.0;
  auto feed = [&](const plan::PlannedMove& m) {
    if (n_moves++ == 0) first_start = m.start_time_s;
    used_features.insert(m.feature);
    fig.motion_time_s = m.end_time_s() - first_start;
    stream.push(m);
  };
  // The planner times every move as a trapezoid; an S-curve machine profile (or --profile)
  // is applied by re-timing, which needs the whole plan (backward pass).
  std::string profile = a.profile;
  if (profile.empty() && mach.profile == machine::VelocityProfile::scurve7) profile = "scurve7";
  std::vector<plan::PlannedMove> all;  // only when re-timing
  plan::EstimateOptions eo;
  eo.on_move = [&](const plan::PlannedMove& m) {
    if (profile.empty()) {
      feed(m);
    } else {
      all.push_back(m);
    }
  };
  const plan::EstimateReport est = plan::estimate_file(a.file, mach, eo);
  if (!profile.empty()) {
    all = trajectory::retime(all, parse_profile(profile), a.jerk.value_or(mach.max_jerk_mm_s3));
    const auto f = trajectory::profile_figures(all);
    for (const auto& m : all) feed(m);
    fig = f;
  }
  if (n_moves == 0) throw Error(fmt::format("{}: no moves to simulate", a.file));
  const dy::QualityReport rep = stream.finish();
  const double compute_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  // Feature names by PlannedMove::feature index.
  std::vector<std::string> names;
  for (const auto& f : est.features) {
    if (names.size() <= f.index) names.resize(f.index + 1u);
    names[f.index] = f.name;
  }
  for (std::uint16_t f : used_features) {
    if (names.size() <= f) names.resize(f + 1u);
    if (names[f].empty()) names[f] = fmt::format("{}", f);
  }
  json j = report_json(rep, names);
  j["file"] = a.file;
  j["machine"] = mach.name;
  j["profile"] = profile.empty() ? std::string(machine::to_string(mach.profile)) : profile;
  auto modes_json = [](const dy::AxisModel& m) {
    json arr = json::array();
    for (const auto& md : m.modes()) {
      arr.push_back({{"natural_frequency_hz", md.natural_frequency_hz},
                     {"damping_ratio", md.damping_ratio}, {"participation", md.participation}});
    }
    return arr;
  };
  j["model"] = {{"x", modes_json(mx)}, {"y", modes_json(my)},
                {"space", a.motor_space ? "motor" : "cartesian"}};
  j["sample_rate_hz"] = a.rate_hz;
  j["moves"] = n_moves;
  j["max_window_moves"] = stream.max_window_moves();
  j["simulated_time_s"] = stream.stats().end_time_s - stream.stats().start_time_s;
  j["axis_state_updates"] = stream.stats().axis_state_updates;
  j["compute_time_s"] = compute_s;
  if (!profile.empty()) {
    j["peak_accel_mm_s2"] = fig.peak_accel_mm_s2;
    j["peak_jerk_mm_s3"] = fig.peak_jerk_mm_s3;
  }
  if (a.json_out) {
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << fmt::format("{}: {} moves, motion {:.3f} s, profile {}\n", a.file, n_moves,
                           rep.motion_time_s, j["profile"].get<std::string>());
  std::cout << fmt::format("contour error: max {:.4f} mm, RMS {:.4f} mm (printing: max {:.4f}, RMS {:.4f})\n",
                           rep.max_contour_error_mm, rep.rms_contour_error_mm,
                           rep.max_contour_error_printing_mm, rep.rms_contour_error_printing_mm);
  std::cout << fmt::format("corners {}: max overshoot {:.4f} mm; ringing wavelength {:.3f} mm, amplitude {:.4f} mm\n",
                           rep.corner_count, rep.max_corner_overshoot_mm, rep.ringing_wavelength_mm,
                           rep.ringing_amplitude_mm);
  std::cout << fmt::format("residual vibration: max {:.4f} mm, at the end {:.4g} mm\n",
                           rep.max_residual_vibration_mm, rep.final_residual_vibration_mm);
  std::cout << "worst places:\n";
  for (const auto& w : rep.worst) {
    std::cout << fmt::format("  line {:>8}  layer {:>4}  t {:9.3f} s  ({:8.3f}, {:8.3f})  {:.4f} mm\n",
                             w.line, w.layer, w.t_s, w.x_mm, w.y_mm, w.contour_error_mm);
  }
  std::cout << fmt::format("simulated {} samples in {:.3f} s (plan included)\n", rep.samples, compute_s);
}

// ------------------------------------------------------------------------------ sweep
struct SweepCase {
  std::string name;
  double w_rad_s = 100, zeta = 0.5, accel = 5000, v = 100, h = 0.005;
};

std::vector<SweepCase> seed_cases() {
  std::vector<SweepCase> c{{"base"}};
  for (double w : {50.0, 200.0, 500.0}) c.push_back({fmt::format("1 w={:g}", w), w});
  for (double z : {0.0, 1.0, 2.0}) c.push_back({fmt::format("2 z={:g}", z), 100, z});
  for (double a : {1000.0, 10000.0}) c.push_back({fmt::format("3 a={:g}", a), 100, 0.5, a});
  for (double v : {50.0, 200.0}) c.push_back({fmt::format("4 v={:g}", v), 100, 0.5, 5000, v});
  for (double h : {0.01, 0.001, 0.0002}) c.push_back({fmt::format("5 h={:g}", h), 100, 0.5, 5000, 100, h});
  return c;
}

void do_sweep(bool json_out, double scv) {
  json rows = json::array();
  if (!json_out) {
    std::cout << fmt::format("{:<12} {:<10} {:>9} {:>8} {:>10} {:>10} {:>10} {:>10} {:>9}\n", "case",
                             "junction", "time_s", "samples", "max_err", "rms_err", "overshoot",
                             "residual", "junc_v");
  }
  for (const SweepCase& c : seed_cases()) {
    for (const bool lookahead : {true, false}) {
      machine::Machine m = machine::preset("default");
      m.firmware = machine::Firmware::klipper;
      m.junction = machine::JunctionPolicy::square_corner_velocity;
      m.max_accel_mm_s2 = c.accel;
      m.max_velocity_mm_s = std::max(m.max_velocity_mm_s, c.v);
      m.minimum_cruise_ratio = 0.0;  // the thesis's trapezoid has no cruise smoothing
      m.square_corner_velocity_mm_s = lookahead ? scv : 0.0;
      const std::string gcode = fmt::format("G90\nG1 X0 Y0 F{0:g}\nG1 X10 Y0 F{0:g}\nG1 X10 Y10 F{0:g}\n", c.v * 60.0);
      std::vector<plan::PlannedMove> moves;
      plan::EstimateOptions eo;
      eo.on_move = [&](const plan::PlannedMove& mv) {
        if (mv.distance_mm > 0.0) moves.push_back(mv);
      };
      (void)plan::estimate_text(gcode, "seed000", m, eo);
      const dy::AxisModel model = dy::AxisModel::belt_rad_s(c.w_rad_s, c.zeta);
      dy::SimulationOptions so;
      so.sample_rate_hz = 1.0 / c.h;
      so.settle_s = 0.5;
      dy::MetricsOptions mo;
      mo.corner_window_s = 0.5;
      const SimRun r = run_simulation(moves, model, model, so, mo, nullptr);
      const std::size_t seed_samples = trajectory::sample_seed000(moves, c.h).size();
      const double jv = moves.empty() ? 0.0 : moves.front().end_v_mm_s;
      json row{{"case", c.name}, {"junction", lookahead ? "lookahead" : "zero"},
               {"w_rad_s", c.w_rad_s}, {"damping_ratio", c.zeta}, {"accel_mm_s2", c.accel},
               {"v_mm_s", c.v}, {"h_s", c.h}, {"junction_speed_mm_s", jv},
               {"motion_time_s", r.report.motion_time_s}, {"samples", seed_samples},
               {"max_contour_error_mm", r.report.max_contour_error_mm},
               {"rms_contour_error_mm", r.report.rms_contour_error_mm},
               {"max_corner_overshoot_mm", r.report.max_corner_overshoot_mm},
               {"final_residual_vibration_mm", r.report.final_residual_vibration_mm},
               {"compute_time_s", r.compute_s}};
      if (json_out) {
        rows.push_back(row);
      } else {
        std::cout << fmt::format("{:<12} {:<10} {:>9.4f} {:>8} {:>10.4f} {:>10.4f} {:>10.4f} {:>10.3g} {:>9.3f}\n",
                                 c.name, lookahead ? "lookahead" : "zero", r.report.motion_time_s,
                                 seed_samples, r.report.max_contour_error_mm,
                                 r.report.rms_contour_error_mm, r.report.max_corner_overshoot_mm,
                                 r.report.final_residual_vibration_mm, jv);
      }
    }
  }
  if (json_out) std::cout << json{{"seed", "000"}, {"square_corner_velocity_mm_s", scv}, {"cases", rows}}.dump(2) << "\n";
}

}  // namespace

void register_dynamics(CLI::App& app) {
  auto a = std::make_shared<SimulateArgs>();
  CLI::App* sim = app.add_subcommand("simulate", "Simulate the nozzle through the belt dynamics and measure print quality");
  sim->add_option("file", a->file, "G-code file")->required();
  add_machine_options(*sim, a->machine);
  sim->add_option("--natural-frequency-hz", a->model.f_hz, "belt natural frequency of X and Y [Hz]");
  sim->add_option("--damping-ratio", a->model.zeta, "belt damping ratio of X and Y (default 0.1)");
  sim->add_option("--natural-frequency-y-hz", a->model.f_hz_y, "Y natural frequency if different [Hz]");
  sim->add_option("--damping-ratio-y", a->model.zeta_y, "Y damping ratio if different");
  sim->add_option("--mass-kg", a->model.mass_kg, "moving mass [kg] (instead of the frequency)");
  sim->add_option("--stiffness-n-per-m", a->model.stiffness, "belt stiffness [N/m]");
  sim->add_option("--damping-n-s-per-m", a->model.damping, "belt damping [N s/m]");
  sim->add_option("--mode", a->model.modes,
                  "a vibration mode 'f_hz,damping_ratio[,participation]' of X and Y (repeatable; replaces the belt flags)");
  sim->add_option("--sample-rate-hz", a->rate_hz, "simulation output rate [Hz] (default 1000)");
  sim->add_option("--csv", a->csv, "write commanded and simulated path to this CSV file");
  sim->add_option("--csv-rate-hz", a->csv_rate_hz, "CSV row rate [Hz]; must divide the sample rate");
  sim->add_option("--t-begin", a->t_begin, "only measure/write from this print time [s]");
  sim->add_option("--t-end", a->t_end, "only measure/write up to this print time [s]");
  sim->add_option("--layer-begin", a->layer_begin, "only measure/write from this layer");
  sim->add_option("--layer-end", a->layer_end, "only measure/write up to this layer");
  sim->add_option("--profile", a->profile, "re-time the plan with trapezoid, scurve7 or bezier5");
  sim->add_option("--jerk", a->jerk, "jerk limit for scurve7 [mm/s^3] (default: machine max_jerk)");
  sim->add_flag("--motor-space", a->motor_space, "apply the belt models to the motors (corexy A, B)");
  sim->add_option("--worst", a->worst, "how many worst places to list (default 10)");
  sim->add_option("--corner-window-s", a->corner_window_s, "time watched after each corner [s]");
  sim->add_flag("--json", a->json_out, "print one JSON object");
  sim->callback([a] { do_simulate(*a); });

  auto sj = std::make_shared<bool>(false);
  auto scv = std::make_shared<double>(5.0);
  CLI::App* sw = app.add_subcommand("sweep", "Seed 000 tables 3.2/3.3: base case and variations, look-ahead vs zero junction speed");
  sw->add_option("--square-corner-velocity", *scv, "junction model of the look-ahead runs [mm/s] (default 5)");
  sw->add_flag("--json", *sj, "print one JSON object");
  sw->callback([sj, scv] { do_sweep(*sj, *scv); });
}

}  // namespace amctl::cli
