#include "amctl/compensation/command_table.hpp"
#include "amctl/compensation/compensate.hpp"
#include "amctl/dynamics/metrics.hpp"
#include "amctl/dynamics/plant.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include <fmt/format.h>

#include "amctl/control/discretize.hpp"
#include "amctl/control/state_space.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/core/memory.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/core/fixed_format.hpp"
#include "amctl/dynamics/simulate.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "detail.hpp"

namespace amctl::compensation {

std::string_view to_string(CompensationStatus s) {
  switch (s) {
    case CompensationStatus::ok: return "ok";
    case CompensationStatus::unbounded_command_acceleration: return "unbounded_command_acceleration";
    case CompensationStatus::base_accel_limit_exceeded: return "base_accel_limit_exceeded";
    case CompensationStatus::machine_accel_limit_exceeded: return "machine_accel_limit_exceeded";
    case CompensationStatus::non_finite_command: return "non_finite_command";
    case CompensationStatus::infeasible: return "infeasible";
    case CompensationStatus::solver_failed: return "solver_failed";
  }
  return "unknown";
}

Method parse_method(const std::string& name) {
  if (name == "invert") return Method::invert;
  if (name == "fbf") return Method::fbf;
  if (name == "lpfbf") return Method::lpfbf;
  if (name == "rfbf") return Method::rfbf;
  if (name == "collocation") return Method::collocation;
  throw Error(fmt::format("--method: '{}' is not a method; expected invert, fbf, lpfbf, rfbf or collocation", name));
}

const char* method_name(Method m) {
  switch (m) {
    case Method::invert: return "invert";
    case Method::fbf: return "fbf";
    case Method::lpfbf: return "lpfbf";
    case Method::rfbf: return "rfbf";
    case Method::collocation: return "collocation";
  }
  return "?";
}

namespace detail {

double slowest_decay_rate_per_s(const dynamics::AxisModel& m) {
  double r = std::numeric_limits<double>::infinity();
  // The slowest pole's real part: z w for z <= 1; an overdamped mode's slow real pole sits at
  // w (z - sqrt(z^2 - 1)) (w / (2 z) for large z), far slower than z w.
  for (const dynamics::Mode& mode : m.modes()) {
    const double w = 2.0 * M_PI * mode.natural_frequency_hz, z = mode.damping_ratio;
    r = std::min(r, z <= 1.0 ? z * w : w * (z - std::sqrt(z * z - 1.0)));
  }
  return r;
}

}  // namespace detail

void simulate_command(const std::vector<double>& t_s, const std::vector<double>& x_cmd_mm,
                      const std::vector<double>& y_cmd_mm, const dynamics::AxisModel& plant_x,
                      const dynamics::AxisModel& plant_y, double sample_rate_hz,
                      std::vector<double>& x_sim_mm, std::vector<double>& y_sim_mm) {
  const std::size_t n = t_s.size();
  x_sim_mm.assign(x_cmd_mm.begin(), x_cmd_mm.end());
  y_sim_mm.assign(y_cmd_mm.begin(), y_cmd_mm.end());
  if (n < 2) return;
  // The command, linear between samples, as one command piece per sample step through the
  // plant engine (dynamics/plant.hpp): the velocity steps at the samples are applied exactly;
  // at rest on the first sample before it.
  dynamics::PieceSimulator sim(plant_x, plant_y, sample_rate_hz, t_s.front());
  const auto sink = [&](const dynamics::PlantSample& s) {
    const long k = std::lround((s.t_s - t_s.front()) * sample_rate_hz);
    if (k < 0 || static_cast<std::size_t>(k) >= n) return;
    const auto i = static_cast<std::size_t>(k);
    x_sim_mm[i] = x_cmd_mm[i] + (s.sim_mm[0] - s.cmd_mm[0]);
    y_sim_mm[i] = y_cmd_mm[i] + (s.sim_mm[1] - s.cmd_mm[1]);
  };
  for (std::size_t k = 0; k + 1 < n; ++k) {
    dynamics::CommandPiece p;
    p.t0_s = t_s[k];
    p.duration_s = t_s[k + 1] - t_s[k];
    p.c[0][0] = x_cmd_mm[k];
    p.c[1][0] = y_cmd_mm[k];
    if (p.duration_s > 0.0) {
      p.c[0][1] = (x_cmd_mm[k + 1] - x_cmd_mm[k]) / p.duration_s;
      p.c[1][1] = (y_cmd_mm[k + 1] - y_cmd_mm[k]) / p.duration_s;
    }
    sim.push(p, sink);
  }
  sim.rest_until(n - 1, sink);
}

void simulate_command_foh(const std::vector<double>& x_cmd_mm, const std::vector<double>& y_cmd_mm,
                          const std::vector<double>& x_acc_mm_s2, const std::vector<double>& y_acc_mm_s2,
                          const dynamics::AxisModel& plant_x, const dynamics::AxisModel& plant_y,
                          double sample_rate_hz, std::vector<double>& x_sim_mm, std::vector<double>& y_sim_mm) {
  x_sim_mm.assign(x_cmd_mm.begin(), x_cmd_mm.end());
  y_sim_mm.assign(y_cmd_mm.begin(), y_cmd_mm.end());
  const std::size_t n = std::min(x_cmd_mm.size(), y_cmd_mm.size());
  if (n < 2) return;
  // The command's acceleration linear between samples: on each step a cubic
  //   x(tau) = x_k + v_k tau + a_k tau^2 / 2 + (a_{k+1} - a_k) tau^3 / (6 h),
  // v continuous from rest (v_0 = 0, v_{k+1} the cubic's end velocity), through the plant
  // engine. The deflection depends on x'' alone; the nozzle is the given command plus it.
  const double h = 1.0 / sample_rate_hz;
  dynamics::PieceSimulator sim(plant_x, plant_y, sample_rate_hz, 0.0);
  const std::vector<double>* cmd[2] = {&x_cmd_mm, &y_cmd_mm};
  const std::vector<double>* acc[2] = {&x_acc_mm_s2, &y_acc_mm_s2};
  std::vector<double>* out[2] = {&x_sim_mm, &y_sim_mm};
  const auto sink = [&](const dynamics::PlantSample& s) {
    const long k = std::lround(s.t_s * sample_rate_hz);
    if (k < 0 || static_cast<std::size_t>(k) >= n) return;
    for (std::size_t a = 0; a < 2; ++a) {
      (*out[a])[static_cast<std::size_t>(k)] = (*cmd[a])[static_cast<std::size_t>(k)] + (s.sim_mm[a] - s.cmd_mm[a]);
    }
  };
  double v[2] = {0.0, 0.0};
  for (std::size_t k = 0; k + 1 < n; ++k) {
    dynamics::CommandPiece p;
    p.t0_s = static_cast<double>(k) * h;
    p.duration_s = h;
    for (std::size_t a = 0; a < 2; ++a) {
      const double a0 = (*acc[a])[k], a1 = (*acc[a])[k + 1];
      p.c[a][0] = (*cmd[a])[k];
      p.c[a][1] = v[a];
      p.c[a][2] = 0.5 * a0;
      p.c[a][3] = (a1 - a0) / (6.0 * h);
      // The end velocity as the engine evaluates it (Horner), so no spurious jump.
      v[a] = (3.0 * p.c[a][3] * h + 2.0 * p.c[a][2]) * h + p.c[a][1];
    }
    sim.push(p, sink);
  }
  sim.rest_until(n - 1, sink);
}

namespace detail {

double auto_tail_s(const CompensationOptions& options) {
  const double decay = std::min({slowest_decay_rate_per_s(options.model_x),
                                 slowest_decay_rate_per_s(options.model_y),
                                 slowest_decay_rate_per_s(options.plant_x),
                                 slowest_decay_rate_per_s(options.plant_y)});
  return std::isfinite(decay) && decay > 0 ? std::clamp(5.0 / decay, 0.05, 1.0) : 1.0;
}

void validate_options(const CompensationOptions& o) {
  if (!in_range(kSampleRateRange, o.sample_rate_hz))
    throw Error(fmt::format("--sample-rate-hz: must be {}, got {}", describe(kSampleRateRange), o.sample_rate_hz));
  if (o.lead_in_s > kMaxLeadTail_s || std::isnan(o.lead_in_s))
    throw Error(fmt::format("--lead-in-s: must be at most {} s, got {}", kMaxLeadTail_s, o.lead_in_s));
  if (o.tail_s > kMaxLeadTail_s || std::isnan(o.tail_s))
    throw Error(fmt::format("tail_s: must be at most {} s, got {}", kMaxLeadTail_s, o.tail_s));
  if (o.model_x.is_rigid() || o.model_y.is_rigid())
    throw Error("--natural-frequency-hz: compensation needs a belt model (one mode or more)");
  dynamics::require_above_nyquist(o.sample_rate_hz,
                                  {&o.model_x, &o.model_y, &o.plant_x, &o.plant_y});
  if (!(o.max_base_accel_mm_s2 > 0.0))
    throw Error(fmt::format("--max-base-accel-mm-s2: must be > 0, got {}", o.max_base_accel_mm_s2));
  if (o.method == Method::fbf || o.method == Method::lpfbf || o.method == Method::rfbf) {
    if (o.degree < 1 || o.degree > 7)
      throw Error(fmt::format("--degree: must be between 1 and 7, got {}", o.degree));
  }
}

}  // namespace detail

CompensationResult compensate(std::span<const plan::PlannedMove> all_moves,
                              const CompensationOptions& options) {
  detail::validate_options(options);
  std::vector<plan::PlannedMove> moves;
  for (const plan::PlannedMove& m : all_moves)
    if (!m.extrude_only && m.distance_mm > 0.0) moves.push_back(m);
  if (moves.empty()) throw Error("compensate: the plan has no XY motion");

  const auto clock0 = std::chrono::steady_clock::now();
  const double h = 1.0 / options.sample_rate_hz;
  const double t_begin = moves.front().start_time_s, t_end = moves.back().end_time_s();
  {
    // Said before anything is allocated for the command: how much it will hold (an upper
    // bound of the automatic lead-in and tail, 10 s each).
    const double lead = options.lead_in_s >= 0.0 ? options.lead_in_s : 10.0;
    const double tail = options.tail_s >= 0.0 ? options.tail_s : 10.0;
    const double samples = (t_end - t_begin + lead + tail) * options.sample_rate_hz + 1.0;
    MemoryEstimate est;
    est.method = method_name(options.method);
    est.samples = static_cast<std::uint64_t>(std::min(samples, 1e18));
    est.bytes = static_cast<std::uint64_t>(std::min(samples * static_cast<double>(kCompensationBytesPerSample) +
                                                        static_cast<double>(all_moves.size() * sizeof(plan::PlannedMove)),
                                                    1e18));
    if (options.on_memory_estimate) options.on_memory_estimate(est);
    const std::uint64_t limit = options.max_memory_bytes != 0 ? options.max_memory_bytes : available_memory_bytes();
    if (limit != 0 && est.bytes > limit) {
      throw Error(fmt::format(
          "--method: {} would hold {} samples ({:.1f} s at {:g} Hz), about {} of memory, more than the {} "
          "available; expected a shorter file, a lower --sample-rate-hz, or --method lpfbf, which streams",
          est.method, est.samples, samples / options.sample_rate_hz, options.sample_rate_hz, memory_text(est.bytes),
          memory_text(limit)));
    }
  }

  CompensationResult r;
  r.method = method_name(options.method);
  r.sample_rate_hz = options.sample_rate_hz;
  r.motion_time_s = t_end - t_begin;

  const double auto_tail = detail::auto_tail_s(options);

  detail::Grid grid;
  grid.h = h;
  if (options.method == Method::invert) {
    detail::InverseFilter fx(options.model_x), fy(options.model_y);
    const double lead = options.lead_in_s >= 0.0 ? options.lead_in_s : h;
    // Automatic tail: the plant settled and the inverse's own transient decayed (e^-30).
    const double tail = options.tail_s >= 0.0
                            ? options.tail_s
                            : std::max(auto_tail, std::min(std::max(fx.settle_s(), fy.settle_s()), 5.0));
    grid.lead_steps = static_cast<std::size_t>(std::ceil(lead / h - 1e-9));
    grid.t0 = t_begin - static_cast<double>(grid.lead_steps) * h;
    grid.count = static_cast<std::size_t>(std::ceil((t_end + tail - grid.t0) / h - 1e-9)) + 1;
    const detail::InverseRun run = detail::run_inverse(moves, fx, fy, grid, r);
    r.peak_command_accel_mm_s2 = run.peak_accel_mm_s2;
    if (run.unbounded_accel) {
      r.status = CompensationStatus::unbounded_command_acceleration;
      r.peak_command_accel_mm_s2 = std::numeric_limits<double>::infinity();
      const int rd = std::min(fx.relative_degree(), fy.relative_degree());
      std::string cause, fix = "plan a jerk-limited profile (--set printer.profile=scurve7)";
      if (run.velocity_jump) {
        cause = "velocity steps (corners taken at speed, which no profile smooths)";
        fix = "stop at corners (--set printer.square_corner_velocity=0) and plan a jerk-limited "
              "profile (--set printer.profile=scurve7)";
      } else if (run.accel_jump && rd < 2) {
        cause = fmt::format("acceleration steps (a trapezoid), which the inverse (relative degree {}) "
                            "turns into command {} steps", rd, rd == 0 ? "position" : "velocity");
      } else {
        cause = "jerk steps, which the inverse of an undamped mode (x_b = x + x''/w^2) turns into "
                "command velocity steps";
        fix = "plan a profile with continuous jerk (--set printer.profile=bezier5)";
      }
      r.message = fmt::format(
          "the exact inverse of this model demands unbounded base acceleration: the plan has {}; "
          "the sampled command is written and checked, but for a bounded command {}", cause, fix);
    } else {
      r.status = CompensationStatus::ok;
      r.message = run.unbounded_jerk ? "command acceleration bounded; command jerk has steps or impulses" : "";
    }
  } else if (options.method == Method::fbf) {
    detail::run_fbf(moves, options, auto_tail, grid, r);
  } else if (options.method == Method::rfbf) {
    detail::run_rfbf(moves, options, auto_tail, grid, r);
  } else if (options.method == Method::collocation) {
    detail::run_collocation(moves, options, auto_tail, grid, r);
    if (r.status == CompensationStatus::infeasible || r.status == CompensationStatus::solver_failed) {
      // No command: nothing to check or write.
      r.t_s.clear();
      r.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - clock0).count();
      return r;
    }
  } else {
    detail::run_lpfbf(moves, options, auto_tail, grid, r);
  }

  if (options.method != Method::collocation && std::isfinite(options.max_base_accel_mm_s2) &&
      !(r.peak_command_accel_mm_s2 <= options.max_base_accel_mm_s2)) {
    r.max_base_accel_mm_s2 = options.max_base_accel_mm_s2;
    r.status = CompensationStatus::base_accel_limit_exceeded;
    r.message = fmt::format("the command's peak acceleration {:.6g} mm/s^2 exceeds --max-base-accel-mm-s2 {:.6g}; "
                            "--method collocation enforces the bound{}{}",
                            r.peak_command_accel_mm_s2, options.max_base_accel_mm_s2,
                            r.message.empty() ? "" : "; ", r.message);
  }

  // The check: the sampled command simulated on the plant (linear between samples, or with
  // its acceleration linear between samples when the method gives it).
  if (!r.x_cmd_accel_mm_s2.empty())
    simulate_command_foh(r.x_cmd_mm, r.y_cmd_mm, r.x_cmd_accel_mm_s2, r.y_cmd_accel_mm_s2, options.plant_x,
                         options.plant_y, options.sample_rate_hz, r.x_sim_mm, r.y_sim_mm);
  else
    simulate_command(r.t_s, r.x_cmd_mm, r.y_cmd_mm, options.plant_x, options.plant_y,
                     options.sample_rate_hz, r.x_sim_mm, r.y_sim_mm);
  const auto clock1 = std::chrono::steady_clock::now();
  r.compute_time_s = std::chrono::duration<double>(clock1 - clock0).count();
  r.real_time_factor = r.compute_time_s > 0.0 ? r.motion_time_s / r.compute_time_s : 0.0;

  if (options.sample_z_e) {  // the whole plan, retractions included
    trajectory::Cursor all(all_moves);
    r.z_des_mm.resize(r.t_s.size());
    r.e_des_mm.resize(r.t_s.size());
    for (std::size_t k = 0; k < r.t_s.size(); ++k) {
      const trajectory::AxisState st = all.evaluate(r.t_s[k]);
      r.z_des_mm[k] = st.pos_mm[2];
      r.e_des_mm[k] = st.pos_mm[3];
    }
  }

  // Contour error: dynamics::distance_to_path, the one definition simulate, compare and the
  // report use (the nozzle's distance to the planned XY path near its move, searched along the
  // path within 2 x tracking error + 0.05 mm).
  trajectory::Cursor cur(moves);
  double sum2 = 0.0;
  for (std::size_t k = 0; k < r.t_s.size(); ++k) {
    const double e = std::hypot(r.x_sim_mm[k] - r.x_des_mm[k], r.y_sim_mm[k] - r.y_des_mm[k]);
    if (!std::isfinite(e)) r.status = CompensationStatus::non_finite_command;
    r.max_tracking_error_mm = std::max(r.max_tracking_error_mm, e);
    sum2 += e * e;
    const std::size_t mi = cur.locate(r.t_s[k]).move_index;
    if (std::isfinite(e)) {
      r.max_contour_error_mm = std::max(
          r.max_contour_error_mm, dynamics::distance_to_path(moves, mi, r.x_sim_mm[k], r.y_sim_mm[k], 2.0 * e + 0.05));
    }
  }
  r.rms_tracking_error_mm = r.t_s.empty() ? 0.0 : std::sqrt(sum2 / static_cast<double>(r.t_s.size()));

  // Uncompensated: the plan itself as the command, the same plant, the same grid.
  dynamics::SimulationOptions so;
  so.sample_rate_hz = options.sample_rate_hz;
  so.settle_s = std::max(0.0, r.t_s.empty() ? 0.0 : r.t_s.back() - t_end);
  dynamics::simulate(moves, options.plant_x, options.plant_y, so, [&](const dynamics::SimSample& s) {
    const double e = std::hypot(s.sim_mm[0] - s.cmd_mm[0], s.sim_mm[1] - s.cmd_mm[1]);
    r.uncompensated_max_tracking_error_mm = std::max(r.uncompensated_max_tracking_error_mm, e);
    r.uncompensated_max_contour_error_mm =
        std::max(r.uncompensated_max_contour_error_mm,
                 dynamics::distance_to_path(moves, s.move_index, s.sim_mm[0], s.sim_mm[1], 2.0 * e + 0.05));
  });
  return r;
}

namespace detail {

void judge_machine_accel(CompensationResult& r, const machine::Machine& m, const CompensationOptions& o) {
  if (!o.judge_machine_accel || std::isfinite(o.max_base_accel_mm_s2)) return;
  const bool klipper = m.firmware == machine::Firmware::klipper;
  r.machine_accel_limit_mm_s2 =
      klipper ? m.max_accel_mm_s2 : std::min(m.max_axis_accel_mm_s2[0], m.max_axis_accel_mm_s2[1]);
  r.machine_accel_limit_key = klipper ? "printer.max_accel" : "marlin.max_accel";
  if (r.status != CompensationStatus::ok || r.peak_command_accel_mm_s2 <= r.machine_accel_limit_mm_s2) return;
  r.status = CompensationStatus::machine_accel_limit_exceeded;
  r.message = fmt::format(
      "the command's peak acceleration {:.6g} mm/s^2 is {:.3g} times the machine's {} ({:g} mm/s^2): the "
      "firmware would not follow it; raise the limit if the motors can (--set {}=...), bound the "
      "command (--method collocation --max-base-accel-mm-s2 {:g}), or --ignore-machine-limits{}{}",
      r.peak_command_accel_mm_s2, r.peak_command_accel_mm_s2 / r.machine_accel_limit_mm_s2,
      r.machine_accel_limit_key, r.machine_accel_limit_mm_s2, klipper ? "printer.max_accel" : "marlin.max_accel",
      r.machine_accel_limit_mm_s2, r.message.empty() ? "" : "; ", r.message);
}

}  // namespace detail

CompensationResult compensate_file(const plan::GcodeInput& path, const machine::Machine& machine,
                                   const CompensationOptions& options) {
  plan::PlanSource source(path, machine);
  plan::CollectSink collect;
  std::vector<plan::Sink*> sinks{&collect};
  plan::run_pipeline(source, sinks);
  CompensationResult r = compensate(collect.moves, options);
  detail::judge_machine_accel(r, machine, options);
  return r;
}

Json to_json(const CompensationResult& r) {
  Json j;
  j["method"] = r.method;
  j["status"] = std::string(to_string(r.status));
  j["message"] = r.message;
  j["motion_time_s"] = json_number(r.motion_time_s);
  j["compute_time_s"] = json_number(r.compute_time_s);
  j["real_time_factor"] = json_number(r.real_time_factor);
  j["max_tracking_error_mm"] = json_number(r.max_tracking_error_mm);
  j["rms_tracking_error_mm"] = json_number(r.rms_tracking_error_mm);
  j["max_contour_error_mm"] = json_number(r.max_contour_error_mm);
  j["uncompensated_max_tracking_error_mm"] = json_number(r.uncompensated_max_tracking_error_mm);
  j["uncompensated_max_contour_error_mm"] = json_number(r.uncompensated_max_contour_error_mm);
  j["peak_command_accel_mm_s2"] = json_number(r.peak_command_accel_mm_s2);
  j["lead_in_s"] = json_number(r.lead_in_s);
  j["tail_s"] = json_number(r.tail_s);
  j["sample_rate_hz"] = json_number(r.sample_rate_hz);
  j["samples"] = r.t_s.empty() ? r.samples : r.t_s.size();
  if (r.method == "fbf" || r.method == "rfbf") {
    j["knot_spacing_s"] = json_number(r.knot_spacing_s);
    j["degree"] = r.degree;
    j["basis_functions"] = r.basis_functions;
  }
  if (r.method == "collocation") {
    j["solver_status"] = r.solver_status;
    j["solver_iterations"] = r.solver_iterations;
    j["windows"] = r.windows;
    j["window_s"] = json_number(r.window_s);
    j["overlap_s"] = json_number(r.overlap_s);
    j["max_defect_mm"] = json_number(r.max_defect_mm);
    j["effort_weight_s2"] = json_number(r.effort_weight_s2);
  }
  if (std::isfinite(r.max_base_accel_mm_s2)) j["max_base_accel_mm_s2"] = json_number(r.max_base_accel_mm_s2);
  if (std::isfinite(r.machine_accel_limit_mm_s2)) {
    j["machine_accel_limit"] = Json{{"key", r.machine_accel_limit_key},
                                    {"mm_s2", json_number(r.machine_accel_limit_mm_s2)},
                                    {"ratio", json_number(r.peak_command_accel_mm_s2 / r.machine_accel_limit_mm_s2)}};
  }
  if (r.method == "lpfbf") {
    j["knot_spacing_s"] = json_number(r.knot_spacing_s);
    j["degree"] = r.degree;
    j["basis_functions"] = r.basis_functions;
    j["window_s"] = json_number(r.window_s);
    j["overlap_s"] = json_number(r.overlap_s);
    j["windows"] = r.windows;
    j["max_held_samples"] = r.max_held_samples;
    if (r.max_held_moves > 0) j["max_held_moves"] = r.max_held_moves;
  }
  return j;
}

void write_csv(const CompensationResult& r, const std::string& path) {
  CommandTable out(path, OutputOptions{"--csv", {}, {}});
  write_table(r, out);
  out.commit();
}

void write_table(const CompensationResult& r, CommandTable& out) {
  const bool accel = !r.x_cmd_accel_mm_s2.empty();
  out.begin(accel);
  for (std::size_t k = 0; k < r.t_s.size(); ++k) {
    out.add(CommandSample{r.t_s[k], r.x_cmd_mm[k], r.y_cmd_mm[k], r.x_des_mm[k], r.y_des_mm[k],
                          r.x_sim_mm[k], r.y_sim_mm[k], accel ? r.x_cmd_accel_mm_s2[k] : 0.0,
                          accel ? r.y_cmd_accel_mm_s2[k] : 0.0});
  }
}

void write_gcode(const CompensationResult& r, const std::string& path) {
  OutputFile out(path, OutputOptions{"--gcode", {}, {}});
  write_gcode(r, out);
  out.commit();
}

void write_gcode(const CompensationResult& r, OutputFile& out) {
  const std::string& path = out.path();
  const std::size_t n = r.t_s.size();
  if (n == 0) throw Error(fmt::format("--gcode {}: there is no command to write", path));
  if (r.z_des_mm.size() != n || r.e_des_mm.size() != n)
    throw Error(fmt::format("--gcode {}: the result has no Z and E samples (CompensationOptions::sample_z_e)", path));
  if (!std::isfinite(r.peak_command_accel_mm_s2))
    throw Error(fmt::format("--gcode {}: the command's acceleration is unbounded ({}); a firmware cannot "
                            "follow it: use a jerk-limited plan or another method", path, to_string(r.status)));
  const double h = 1.0 / r.sample_rate_hz;
  const long accel = std::lround(std::ceil(r.peak_command_accel_mm_s2 * 1.01));
  {
    std::ostream& f = out.stream();
    f << fmt::format(
        "; amctl compensate --method {}: the motor-side command, one segment per {:.6g} s ({} Hz)\n"
        "; status {}; max tracking error {:.6g} mm (uncompensated {:.6g} mm), lead-in {:.4f} s\n"
        "; The segments already carry the belt's dynamics: the firmware must follow them as given.\n"
        "; Allow at least {} mm/s^2 (M204 below; Klipper: SET_VELOCITY_LIMIT ACCEL={}), a corner\n"
        "; speed that does not slow 0.1 mm segments (Klipper SQUARE_CORNER_VELOCITY, Marlin M205 J),\n"
        "; and no minimum segment time (Marlin M205 B0): otherwise it re-plans them.\n",
        r.method, h, r.sample_rate_hz, to_string(r.status), r.max_tracking_error_mm,
        r.uncompensated_max_tracking_error_mm, r.lead_in_s, accel, accel);
    f << "G90\nM83\n" << fmt::format("M204 S{}\n", accel);
    // Positions as printed (0.1 um; "+ 0.0" turns -0 into 0): a step that changes none of
    // them is a rest, and E is relative to the E last written, so nothing is lost to rounding.
    const auto q4 = [](double v) { return std::round(v * 1e4) / 1e4 + 0.0; };
    const auto q5 = [](double v) { return std::round(v * 1e5) / 1e5 + 0.0; };
    double px = q4(r.x_cmd_mm[0]), py = q4(r.y_cmd_mm[0]), pz = q4(r.z_des_mm[0]), pe = r.e_des_mm[0];
    f << fmt::format("G0 X{:.4f} Y{:.4f} Z{:.4f}\n", px, py, pz);
    double rest_s = 0.0;
    for (std::size_t k = 1; k < n; ++k) {
      const double x = q4(r.x_cmd_mm[k]), y = q4(r.y_cmd_mm[k]), z = q4(r.z_des_mm[k]);
      const double de = q5(r.e_des_mm[k] - pe);
      if (x == px && y == py && z == pz && de == 0.0) {
        rest_s += h;
        continue;
      }
      if (rest_s > 0.0) {
        f << fmt::format("G4 P{:.3f}\n", rest_s * 1e3);
        rest_s = 0.0;
      }
      const double d = std::sqrt((x - px) * (x - px) + (y - py) * (y - py) + (z - pz) * (z - pz));
      const double v = (d > 0.0 ? d : std::abs(de)) / h;
      f << fmt::format("G1 X{:.4f} Y{:.4f}", x, y);
      if (z != pz) f << fmt::format(" Z{:.4f}", z);
      if (de != 0.0) f << fmt::format(" E{:.5f}", de);
      f << fmt::format(" F{:.1f}\n", v * 60.0);
      px = x, py = y, pz = z, pe += de;
    }
    if (rest_s > 0.0) f << fmt::format("G4 P{:.3f}\n", rest_s * 1e3);
  }
}

}  // namespace amctl::compensation
