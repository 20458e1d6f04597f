#include "amctl/closedloop/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/steppers/steps.hpp"
#include "amctl/trajectory/build.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::closedloop {

void SimulationOptions::validate() const {
  gains.validate();
  encoder.validate();
  require_positive("substep_s", substep_s);
  require_non_negative("settle_s", settle_s);
  require_positive("csv_rate_hz", csv_rate_hz);
  const double ratio = gains.period_s / substep_s;
  if (std::abs(ratio - std::round(ratio)) > 1e-9 * ratio || std::round(ratio) < 1.0) {
    throw Error(fmt::format("controller.period_s = {} is not a whole multiple of substep_s = {}",
                            gains.period_s, substep_s));
  }
}

namespace {

// The trace CSV through amctl::OutputFile (a regular file appears at commit, whole or not at
// all; every write checked).
class TraceCsv {
 public:
  TraceCsv(std::string path, const std::vector<AxisSetup>& axes)
      : out_(std::move(path), OutputOptions{"--csv", {}, {}}) {
    std::string h = "time_s";
    for (const AxisSetup& a : axes) {
      h += fmt::format(",{0}_ref_mm,{0}_mm,{0}_error_mm,{0}_command_mm,{0}_encoder_mm,"
                       "{0}_load_angle_deg,{0}_lost_steps", a.name);
    }
    h += "\n";
    out_.write(h);
  }
  void write(const std::string& row) { out_.write(row); }
  void commit() { out_.commit(); }

 private:
  OutputFile out_;
};

struct AxisRun {
  AxisSetup setup;
  StepperAxisModel model;
  MotorState state;
  std::unique_ptr<Controller> controller;
  As5311Encoder encoder;
  double command_mm = 0.0;
  std::deque<double> x_hist, ref_hist;  // at control periods, newest last (latency)
  std::int64_t last_slip = 0;
  double err2 = 0.0, current_sum = 0.0;
  std::uint64_t samples = 0, steps_last = 0;
  double last_measured = 0.0;
  AxisResult res;
};

}  // namespace

struct ClosedLoopSimulator::Impl {
  SimulationOptions opt;
  std::vector<AxisRun> runs;
  int substeps_per_tick = 5;
  int latency_ticks = 1;
  std::uint64_t ticks = 0;
  std::uint64_t csv_every = 10;
  std::unique_ptr<TraceCsv> csv;
};

ClosedLoopSimulator::ClosedLoopSimulator(std::vector<AxisSetup> axes,
                                         const SimulationOptions& options,
                                         std::span<const double> start_mm)
    : impl_(std::make_unique<Impl>()) {
  options.validate();
  AMCTL_CHECK(start_mm.size() == axes.size(), "one start position per axis");
  Impl& s = *impl_;
  s.opt = options;
  s.substeps_per_tick = static_cast<int>(std::lround(options.gains.period_s / options.substep_s));
  s.latency_ticks = static_cast<int>(std::lround(options.encoder.latency_s / options.gains.period_s));
  s.csv_every = std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(std::llround(1.0 / (options.csv_rate_hz * options.gains.period_s))));
  ControllerParameters gains = options.gains;
  gains.latency_s = s.latency_ticks * options.gains.period_s;
  s.runs.reserve(axes.size());
  for (std::size_t i = 0; i < axes.size(); ++i) {
    StepperAxisModel model(axes[i].motor, axes[i].drive, axes[i].mechanics);
    require_stable_loop(options.controller, gains, model, axes[i].name);
    EncoderParameters ep = options.encoder;
    ep.seed = options.encoder.seed + i;
    AxisRun run{axes[i], model, model.rest_state(start_mm[i]), nullptr,
                As5311Encoder(ep, start_mm[i]), 0.0, {}, {}, 0, 0.0, 0.0, 0, 0, 0.0, {}};
    run.controller = make_controller(options.controller, gains, run.model);
    run.command_mm = static_cast<double>(run.state.microstep) * run.model.step_distance_mm();
    run.res.name = axes[i].name;
    run.res.pull_out_torque_n_m = run.model.pull_out_torque_n_m();
    run.last_measured = start_mm[i];
    s.runs.push_back(std::move(run));
  }
  if (!options.csv_path.empty()) s.csv = std::make_unique<TraceCsv>(options.csv_path, axes);
}

ClosedLoopSimulator::~ClosedLoopSimulator() = default;

double ClosedLoopSimulator::time_s() const {
  return static_cast<double>(impl_->ticks) * impl_->opt.gains.period_s;
}
double ClosedLoopSimulator::period_s() const { return impl_->opt.gains.period_s; }
std::size_t ClosedLoopSimulator::axes() const { return impl_->runs.size(); }
const StepperAxisModel& ClosedLoopSimulator::model(std::size_t i) const {
  return impl_->runs.at(i).model;
}

void ClosedLoopSimulator::tick(std::span<const RefSample> now, std::span<const RefSample> next) {
  Impl& s = *impl_;
  const double T = s.opt.gains.period_s, h = s.opt.substep_s;
  const double t = time_s();
  const bool write_row = s.csv && (s.ticks % s.csv_every == 0);
  std::string row;
  if (write_row) row = fmt::format("{:.6f}", t);
  for (std::size_t i = 0; i < s.runs.size(); ++i) {
    AxisRun& r = s.runs[i];
    const double x = StepperAxisModel::position_mm(r.state);
    const double err = x - now[i].pos_mm;
    r.err2 += err * err;
    ++r.samples;
    if (std::abs(err) > r.res.max_tracking_error_mm) {
      r.res.max_tracking_error_mm = std::abs(err);
      r.res.max_error_time_s = t;
    }
    r.res.final_error_mm = err;
    // Encoder: the head as it was latency_ticks periods ago, and the reference then.
    r.x_hist.push_back(x);
    r.ref_hist.push_back(now[i].pos_mm);
    while (r.x_hist.size() > static_cast<std::size_t>(s.latency_ticks) + 1) {
      r.x_hist.pop_front();
      r.ref_hist.pop_front();
    }
    const double measured = r.encoder.read(r.x_hist.front());
    ControlInput in;
    in.t_s = t;
    in.ref_mm = now[i].pos_mm;
    in.ref_vel_mm_s = now[i].vel_mm_s;
    in.ref_acc_mm_s2 = now[i].acc_mm_s2;
    in.next_ref_mm = next[i].pos_mm;
    in.next_vel_mm_s = next[i].vel_mm_s;
    in.next_acc_mm_s2 = next[i].acc_mm_s2;
    in.measured_ref_mm = r.ref_hist.front();
    in.measured_mm = measured;
    in.command_mm = r.command_mm;
    in.steps_since_last = r.steps_last;
    const double target = r.controller->target_mm(in);
    const double current = r.controller->current_request_a();
    if (current > 0.0 && current != r.state.current_a) r.model.set_current(r.state, current);
    r.res.peak_current_a = std::max(r.res.peak_current_a, r.state.current_a);
    r.current_sum += r.state.current_a;
    const double step = r.model.step_distance_mm();
    double v = (target - r.command_mm) / T;
    const double vmax = r.setup.drive.max_step_rate_hz * step;
    if (std::abs(v) > vmax) {
      v = std::copysign(vmax, v);
      ++r.res.step_rate_limited_periods;
    }
    r.res.peak_step_rate_hz = std::max(r.res.peak_step_rate_hz, std::abs(v) / step);
    std::uint64_t steps = 0;
    for (int j = 0; j < s.substeps_per_tick; ++j) {
      r.command_mm += v * h;
      // Klipper's half-step rule: step n -> n +- 1 when the command crosses (n +- 1/2) s.
      std::int64_t n = r.state.microstep;
      const std::int64_t n0 = n;
      while (r.command_mm >= (static_cast<double>(n) + 0.5) * step) ++n;
      while (r.command_mm < (static_cast<double>(n) - 0.5) * step) --n;
      if (n != n0) {
        steps += static_cast<std::uint64_t>(std::llabs(n - n0));
        r.model.set_microstep(r.state, n);
      }
      r.model.step(r.state, h);
    }
    r.steps_last = steps;
    r.res.steps += steps;
    const std::int64_t slip = r.model.slip_cycles(r.state);
    if (slip != r.last_slip) {
      const auto cycles = static_cast<std::uint64_t>(std::llabs(slip - r.last_slip));
      r.res.slip_events += cycles;
      r.res.lost_full_steps += 4 * cycles;
      r.res.lost_steps += cycles * static_cast<std::uint64_t>(r.model.microsteps_per_cycle());
      r.last_slip = slip;
    }
    const double d = r.model.load_angle_rad(r.state) - 2.0 * std::numbers::pi * static_cast<double>(slip);
    r.res.max_load_angle_deg = std::max(r.res.max_load_angle_deg, std::abs(d) * 180.0 / std::numbers::pi);
    if (write_row) {
      row += fmt::format(",{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.3f},{}", now[i].pos_mm, x, err,
                         r.command_mm, measured, d * 180.0 / std::numbers::pi, r.res.lost_steps);
    }
  }
  if (write_row) {
    row += "\n";
    s.csv->write(row);
  }
  ++s.ticks;
}

SimulationResult ClosedLoopSimulator::finish() {
  Impl& s = *impl_;
  SimulationResult out;
  out.controller = to_string(s.opt.controller);
  out.duration_s = time_s();
  out.substeps = s.ticks * static_cast<std::uint64_t>(s.substeps_per_tick);
  for (AxisRun& r : s.runs) {
    AxisResult a = r.res;
    a.rms_tracking_error_mm = r.samples ? std::sqrt(r.err2 / static_cast<double>(r.samples)) : 0.0;
    a.mean_current_a = r.samples ? r.current_sum / static_cast<double>(r.samples) : 0.0;
    a.encoder_rejected_frames = r.encoder.rejected_frames();
    out.axes.push_back(a);
  }
  if (s.csv) {
    s.csv->commit();
    s.csv.reset();
  }
  return out;
}

std::vector<AxisSetup> machine_axes(const machine::Machine& m) {
  // Validates every stepper section (missing ones, rotation_distance, microsteps) with the
  // messages `amctl steps` gives.
  (void)steppers::stepper_channels(m);
  std::vector<AxisSetup> out;
  for (const char* key : {"x", "y"}) {
    const machine::Stepper& st = m.steppers.at(key);
    AxisSetup a;
    a.name = key;
    a.drive.microsteps = st.microsteps;
    a.motor.full_steps_per_rotation = st.full_steps_per_rotation;
    a.mechanics.rotation_distance_mm = st.rotation_distance_mm;
    // The machine's motor keys (docs/machine.md; unset: the defaults of motor.hpp).
    if (st.run_current_a) a.drive.current_amplitude_a = std::numbers::sqrt2 * *st.run_current_a;
    if (st.supply_voltage_v) a.drive.supply_voltage_v = *st.supply_voltage_v;
    if (st.holding_torque_n_m) a.motor.holding_torque_n_m = *st.holding_torque_n_m;
    if (st.rated_current_a) a.motor.rated_current_a = *st.rated_current_a;
    if (st.phase_resistance_ohm) a.motor.phase_resistance_ohm = *st.phase_resistance_ohm;
    if (st.phase_inductance_h) a.motor.phase_inductance_h = *st.phase_inductance_h;
    if (st.rotor_inertia_kg_m2) a.motor.rotor_inertia_kg_m2 = *st.rotor_inertia_kg_m2;
    if (st.detent_torque_n_m) a.motor.detent_torque_n_m = *st.detent_torque_n_m;
    if (st.backlash_mm) a.mechanics.backlash_mm = *st.backlash_mm;
    out.push_back(a);
  }
  return out;
}

namespace {

void require_step_rate(const AxisSetup& a, double speed_mm_s, const std::string& where) {
  const double step = a.mechanics.rotation_distance_mm /
                      (static_cast<double>(a.motor.full_steps_per_rotation) * a.drive.microsteps);
  const double rate = std::abs(speed_mm_s) / step;
  if (rate > a.drive.max_step_rate_hz) {
    throw Error(fmt::format(
        "{}: axis {} needs {:.0f} steps/s at {} mm/s, above drive.max_step_rate_hz = {:.0f} "
        "(the driver cannot reach that step rate; lower the speed or the microsteps)",
        where, a.name, rate, speed_mm_s, a.drive.max_step_rate_hz));
  }
}

}  // namespace

SimulationResult simulate_seed003(const machine::Machine& m, const Seed003Scenario& sc,
                                  const SimulationOptions& options) {
  require_positive("--speed-mm-s", sc.speed_mm_s);
  std::vector<AxisSetup> axes = machine_axes(m);
  axes[0].mechanics.belt.mass_kg = sc.x_mass_kg;
  axes[1].mechanics.belt.mass_kg = sc.y_mass_kg;
  for (AxisSetup& a : axes) {
    // Same belt frequency (40 Hz, damping ratio 0.1) for the scenario's masses.
    const double w = 2.0 * std::numbers::pi * 40.0;
    a.mechanics.belt.stiffness_n_per_m = a.mechanics.belt.mass_kg * w * w;
    a.mechanics.belt.damping_n_s_per_m = 2.0 * 0.1 * w * a.mechanics.belt.mass_kg;
    // The scenario's printer class where the machine does not say (its motor keys win; the
    // request's overrides win over both).
    const machine::Stepper& st = m.steppers.at(a.name);
    a.drive.supply_voltage_v =
        sc.supply_voltage_v.value_or(st.supply_voltage_v.value_or(sc.default_supply_voltage_v));
    a.drive.current_amplitude_a =
        std::numbers::sqrt2 *
        sc.run_current_a.value_or(st.run_current_a.value_or(sc.default_run_current_a));
    a.mechanics.backlash_mm = sc.backlash_mm.value_or(st.backlash_mm.value_or(sc.default_backlash_mm));
    if (sc.max_current_a > 0.0) a.drive.max_current_a = sc.max_current_a;
    if (sc.load) {
      a.mechanics.drag_force_n = sc.drag_force_n;
      a.mechanics.end_load_n_per_mm = sc.end_load_n_per_mm;
      a.mechanics.end_load_start_mm = sc.end_load_start_mm;
      a.mechanics.bump_force_n = sc.bump_force_n;
      a.mechanics.bump_position_mm = sc.bump_position_mm;
      a.mechanics.bump_half_width_mm = sc.bump_half_width_mm;
      a.mechanics.drag_n_s_per_m = sc.drag_n_s_per_m;
    }
    require_step_rate(a, sc.speed_mm_s, "scenario seed003");
  }
  // 0 -> -stroke -> 0 ..., each stroke from rest to rest.
  std::vector<trajectory::MoveSpec> specs;
  for (int k = 0; k < sc.strokes; ++k) {
    trajectory::MoveSpec sp;
    sp.to_mm = {k % 2 == 0 ? -sc.stroke_mm : 0.0, 0, 0, 0};
    sp.max_v_mm_s = sc.speed_mm_s;
    specs.push_back(sp);
  }
  const std::vector<plan::PlannedMove> moves = trajectory::chain_moves(
      {0, 0, 0, 0}, specs, m.max_accel_mm_s2, plan::VelocityProfile::trapezoid);
  trajectory::Cursor cur(moves);
  const double t0 = moves.front().start_time_s;
  const double t_end = moves.back().start_time_s + moves.back().duration_s() + options.settle_s;
  const double start[2] = {0.0, 0.0};
  ClosedLoopSimulator sim(axes, options, start);
  const double T = sim.period_s();
  // Both axes follow the same stroke (each on its own); evaluated on one cursor.
  RefSample now[2], next[2];
  auto sample = [&](double t, RefSample* out) {
    const trajectory::AxisState st = cur.evaluate(t0 + t);
    for (int i = 0; i < 2; ++i) out[i] = {st.pos_mm[0], st.vel_mm_s[0], st.acc_mm_s2[0]};
  };
  sample(0.0, now);
  while (sim.time_s() < t_end - t0) {
    sample(sim.time_s() + T, next);
    sim.tick(now, next);
    std::copy(next, next + 2, now);
  }
  SimulationResult r = sim.finish();
  r.source = "scenario seed003";
  r.speed_mm_s = sc.speed_mm_s;
  r.load = sc.load;
  return r;
}

namespace {

// The plan stream into the simulator: a window of the previous batch's last move and this
// batch's moves, evaluated on a Cursor; ticks run while their next sample lies inside it.
class ClosedLoopSink final : public plan::Sink {
 public:
  ClosedLoopSink(ClosedLoopSimulator& sim, std::vector<steppers::StepperChannel> ch,
                 std::vector<AxisSetup> axes, double settle_s)
      : sim_(sim), ch_(std::move(ch)), axes_(std::move(axes)), settle_s_(settle_s) {}

  void consume(const plan::PlanBatch& batch) override {
    if (batch.moves.empty()) return;
    for (const plan::PlannedMove& mv : batch.moves) check_rate(mv);
    if (!window_.empty()) window_.erase(window_.begin(), window_.end() - 1);
    window_.insert(window_.end(), batch.moves.begin(), batch.moves.end());
    const plan::PlannedMove& last = window_.back();
    run_until(last.start_time_s + last.duration_s());
  }
  void finish(const plan::StreamSummary& summary) override {
    if (window_.empty()) return;
    run_until(std::max(summary.end_time_s, window_.back().start_time_s + window_.back().duration_s()) +
              settle_s_ + sim_.period_s());
  }
  double start_time() const { return t0_; }

 private:
  void check_rate(const plan::PlannedMove& mv) {
    for (std::size_t i = 0; i < axes_.size(); ++i) {
      double speed = 0.0;
      for (int k = 0; k < 4; ++k) speed += ch_[i].row[k] * mv.axes_r[k];
      speed = std::abs(speed) * mv.cruise_v_mm_s;
      require_step_rate(axes_[i], speed, fmt::format("line {}", mv.line));
    }
  }
  void sample(trajectory::Cursor& cur, double t, RefSample* out) {
    const trajectory::AxisState st = cur.evaluate(t);
    for (std::size_t i = 0; i < axes_.size(); ++i) {
      RefSample r;
      for (int k = 0; k < 4; ++k) {
        r.pos_mm += ch_[i].row[k] * st.pos_mm[k];
        r.vel_mm_s += ch_[i].row[k] * st.vel_mm_s[k];
        r.acc_mm_s2 += ch_[i].row[k] * st.acc_mm_s2[k];
      }
      out[i] = r;
    }
  }
  void run_until(double t_end) {
    trajectory::Cursor cur(window_);
    if (!started_) {
      t0_ = window_.front().start_time_s;
      started_ = true;
    }
    const double T = sim_.period_s();
    RefSample now[2], next[2];
    sample(cur, t0_ + sim_.time_s(), now);
    while (t0_ + sim_.time_s() + T <= t_end) {
      sample(cur, t0_ + sim_.time_s() + T, next);
      sim_.tick(now, next);
      std::copy(next, next + 2, now);
    }
  }

  ClosedLoopSimulator& sim_;
  std::vector<steppers::StepperChannel> ch_;
  std::vector<AxisSetup> axes_;
  double settle_s_;
  std::vector<plan::PlannedMove> window_;
  bool started_ = false;
  double t0_ = 0.0;
};

}  // namespace

namespace {

// Builds the simulator on the first batch (the start position is the first move's start) and
// feeds it every batch.
class LazyClosedLoop final : public plan::Sink {
 public:
  LazyClosedLoop(const machine::Machine& m, const SimulationOptions& o)
      : ch_(steppers::stepper_channels(m)), axes_(machine_axes(m)), options_(o) {
    ch_.resize(2);  // stepper_x, stepper_y
  }
  void consume(const plan::PlanBatch& b) override {
    if (b.moves.empty()) return;
    if (!sim_) {
      const plan::PlannedMove& f = b.moves.front();
      double start[2] = {0.0, 0.0};
      for (std::size_t i = 0; i < 2; ++i)
        for (int k = 0; k < 4; ++k) start[i] += ch_[i].row[k] * f.start_mm[k];
      sim_ = std::make_unique<ClosedLoopSimulator>(axes_, options_, start);
      sink_ = std::make_unique<ClosedLoopSink>(*sim_, ch_, axes_, options_.settle_s);
    }
    sink_->consume(b);
  }
  void finish(const plan::StreamSummary& s) override {
    if (sink_) sink_->finish(s);
  }
  [[nodiscard]] bool started() const { return sim_ != nullptr; }
  SimulationResult result() { return sim_->finish(); }

 private:
  std::vector<steppers::StepperChannel> ch_;
  std::vector<AxisSetup> axes_;
  SimulationOptions options_;
  std::unique_ptr<ClosedLoopSimulator> sim_;
  std::unique_ptr<ClosedLoopSink> sink_;
};

}  // namespace

SimulationResult simulate_file(const std::string& gcode_path, const machine::Machine& m,
                               const SimulationOptions& options) {
  LazyClosedLoop lazy(m, options);
  plan::PlanSource source(gcode_path, m);
  plan::Sink* sinks[] = {&lazy};
  plan::run_pipeline(source, sinks);
  if (!lazy.started()) throw Error(fmt::format("{}: no moves to simulate", gcode_path));
  SimulationResult r = lazy.result();
  r.source = gcode_path;
  return r;
}

SimulationResult simulate_moves(std::span<const plan::PlannedMove> moves,
                                const machine::Machine& m, const SimulationOptions& options) {
  if (moves.empty()) throw Error("simulate_moves: no moves to simulate");
  LazyClosedLoop lazy(m, options);
  plan::PlanBatch b;
  b.moves.assign(moves.begin(), moves.end());
  lazy.consume(b);
  plan::StreamSummary s;
  s.end_time_s = moves.back().start_time_s + moves.back().duration_s();
  lazy.finish(s);
  SimulationResult r = lazy.result();
  r.source = "moves";
  return r;
}

SimulationResult stepper_simulate(const machine::Machine& m, const SimulateRequest& a) {
  SimulationOptions o;
  o.controller = controller_from_string(a.controller);
  o.csv_path = a.csv_path;
  o.gains.max_accel_mm_s2 = m.max_accel_mm_s2;
  // Every override is checked first, named by its flag.
  const std::pair<const char*, const std::optional<double>*> given[] = {
      {"--kp", &a.kp}, {"--ki", &a.ki_per_s}, {"--kd", &a.kd_s}, {"--alpha", &a.alpha_per_s},
      {"--drag-n", &a.drag_force_n}, {"--bump-n", &a.bump_force_n},
      {"--end-load-n-per-mm", &a.end_load_n_per_mm}, {"--drag-n-s-per-m", &a.drag_n_s_per_m},
      {"--backlash-mm", &a.backlash_mm}, {"--drag-gain", &a.drag_gain_per_s},
      {"--load-angle-deg", &a.load_angle_deg}};
  for (const auto& [flag, v] : given) {
    if (*v) require_non_negative(flag, **v);
  }
  if (a.run_current_a) require_positive("--run-current-a", *a.run_current_a);
  if (a.max_current_a) require_positive("--max-current-a", *a.max_current_a);
  if (a.model_mass_scale) require_positive("--model-mass-scale", *a.model_mass_scale);
  if (a.model_stiffness_scale) require_positive("--model-stiffness-scale", *a.model_stiffness_scale);
  if (a.model_mass_scale) o.gains.best_model_mass_scale = *a.model_mass_scale;
  if (a.model_stiffness_scale) o.gains.best_model_stiffness_scale = *a.model_stiffness_scale;
  if (a.kp) o.gains.kp = o.gains.best_kp = *a.kp;
  if (a.ki_per_s) o.gains.ki_per_s = o.gains.best_ki_per_s = *a.ki_per_s;
  if (a.kd_s) o.gains.kd_s = o.gains.best_kd_s = *a.kd_s;
  if (a.alpha_per_s) o.gains.alpha_per_s = *a.alpha_per_s;
  if (a.drag_gain_per_s) o.gains.best_drag_gain_per_s = *a.drag_gain_per_s;
  if (a.load_angle_deg) o.gains.best_load_angle_deg = *a.load_angle_deg;
  o.encoder.corrupt_probability = a.corrupt_probability;
  if (!a.scenario.empty()) {
    if (!a.file.empty()) throw Error("give either FILE or --scenario, not both");
    if (a.scenario != "seed003") {
      throw Error(fmt::format("--scenario '{}': expected seed003", a.scenario));
    }
    Seed003Scenario sc;
    sc.speed_mm_s = a.speed_mm_s;
    sc.load = a.load;
    if (a.drag_force_n) sc.drag_force_n = *a.drag_force_n;
    if (a.bump_force_n) sc.bump_force_n = *a.bump_force_n;
    if (a.end_load_n_per_mm) sc.end_load_n_per_mm = *a.end_load_n_per_mm;
    if (a.drag_n_s_per_m) sc.drag_n_s_per_m = *a.drag_n_s_per_m;
    if (a.backlash_mm) sc.backlash_mm = *a.backlash_mm;
    if (a.run_current_a) sc.run_current_a = *a.run_current_a;
    if (a.max_current_a) sc.max_current_a = *a.max_current_a;
    return simulate_seed003(m, sc, o);
  }
  if (a.file.empty()) throw Error("give a G-code FILE or --scenario seed003");
  return simulate_file(a.file, m, o);
}

namespace {

Json axis_json(const AxisResult& a) {
  Json x;
  x["max_tracking_error_mm"] = json_number(a.max_tracking_error_mm);
  x["max_error_time_s"] = json_number(a.max_error_time_s);
  x["rms_tracking_error_mm"] = json_number(a.rms_tracking_error_mm);
  x["final_error_mm"] = json_number(a.final_error_mm);
  x["lost_steps"] = a.lost_steps;
  x["lost_full_steps"] = a.lost_full_steps;
  x["slip_events"] = a.slip_events;
  x["max_load_angle_deg"] = json_number(a.max_load_angle_deg);
  x["steps"] = a.steps;
  x["peak_step_rate_hz"] = json_number(a.peak_step_rate_hz);
  x["step_rate_limited_periods"] = a.step_rate_limited_periods;
  x["encoder_rejected_frames"] = a.encoder_rejected_frames;
  x["pull_out_torque_n_m"] = json_number(a.pull_out_torque_n_m);
  x["peak_current_a"] = json_number(a.peak_current_a);
  x["mean_current_a"] = json_number(a.mean_current_a);
  return x;
}

}  // namespace

Json to_json(const SimulationResult& r) {
  Json j;
  j["source"] = r.source;
  j["controller"] = r.controller;
  j["speed_mm_s"] = json_number(r.speed_mm_s);
  j["load"] = r.load;
  j["duration_s"] = json_number(r.duration_s);
  j["substeps"] = r.substeps;
  Json axes = Json::object();
  for (const AxisResult& a : r.axes) axes[a.name] = axis_json(a);
  j["axes"] = axes;
  return j;
}

std::vector<SweepRow> sweep_seed003(const machine::Machine& m,
                                    std::span<const ControllerKind> controllers,
                                    std::span<const double> speeds, bool load,
                                    const SimulationOptions& options) {
  std::vector<SweepRow> rows;
  for (ControllerKind k : controllers) {
    for (double v : speeds) {
      SimulationOptions o = options;
      o.controller = k;
      o.csv_path.clear();
      Seed003Scenario sc;
      sc.speed_mm_s = v;
      sc.load = load;
      const SimulationResult r = simulate_seed003(m, sc, o);
      rows.push_back({to_string(k), v, r.axes[0], r.axes[1]});
    }
  }
  return rows;
}

std::vector<SweepRow> stepper_sweep(const machine::Machine& m, bool load) {
  SimulationOptions o;
  o.gains.max_accel_mm_s2 = m.max_accel_mm_s2;
  const ControllerKind kinds[] = {ControllerKind::open, ControllerKind::seed003,
                                  ControllerKind::pid, ControllerKind::best};
  const double speeds[] = {30, 60, 90, 120, 150};
  return sweep_seed003(m, kinds, speeds, load, o);
}

Json sweep_json(std::span<const SweepRow> rows) {
  Json out = Json::array();
  for (const SweepRow& r : rows) {
    Json j;
    j["controller"] = r.controller;
    j["speed_mm_s"] = json_number(r.speed_mm_s);
    j["x"] = axis_json(r.x);
    j["y"] = axis_json(r.y);
    out.push_back(j);
  }
  return out;
}

std::string sweep_csv(std::span<const SweepRow> rows) {
  std::string s =
      "controller,speed_mm_s,x_max_error_mm,x_rms_error_mm,x_lost_steps,y_max_error_mm,"
      "y_rms_error_mm,y_lost_steps\n";
  for (const SweepRow& r : rows) {
    s += fmt::format("{},{},{:.6f},{:.6f},{},{:.6f},{:.6f},{}\n", r.controller, r.speed_mm_s,
                     r.x.max_tracking_error_mm, r.x.rms_tracking_error_mm, r.x.lost_steps,
                     r.y.max_tracking_error_mm, r.y.rms_tracking_error_mm, r.y.lost_steps);
  }
  return s;
}

}  // namespace amctl::closedloop
