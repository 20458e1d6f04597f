// The closed-loop simulations a user runs: the machine's axes and motors, the reversing-strokes
// scenario, a G-code file through the plan stream, the request of `amctl stepper simulate`, its
// JSON and the speed sweep (docs/closedloop.md, sections 1, 4 and 5). The engine is
// simulate_engine.cpp.
#include "amctl/closedloop/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/motor_presets.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/steppers/steps.hpp"
#include "amctl/trajectory/build.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::closedloop {
namespace {

// The rows of stepper_x and stepper_y over (X, Y, Z, E): the one use of the step generator's
// public functions here (it validates the stepper sections with `amctl steps`'s messages).
std::vector<steppers::StepperChannel> xy_channels(const machine::Machine& m) {
  std::vector<steppers::StepperChannel> ch = steppers::stepper_channels(m);
  ch.resize(2);
  return ch;
}

// The motor of a stepper section: its preset (or the default preset of its step angle), then
// the section's own datasheet keys over it.
void set_motor(AxisSetup& a, const machine::Stepper& st, const std::string& key) {
  const machine::MotorPreset* preset = nullptr;
  if (!st.motor.empty()) {
    preset = machine::find_motor_preset(st.motor);
    if (preset == nullptr) {
      throw Error(fmt::format("stepper_{}.motor = '{}': unknown motor, expected one of {}", key,
                              st.motor, machine::motor_preset_names()));
    }
    if (preset->full_steps_per_rotation != st.full_steps_per_rotation) {
      throw Error(fmt::format(
          "stepper_{}: motor '{}' has {} full steps per rotation ({} deg), but "
          "full_steps_per_rotation is {}: one of them is wrong",
          key, preset->name, preset->full_steps_per_rotation,
          360.0 / preset->full_steps_per_rotation, st.full_steps_per_rotation));
    }
    a.motor_source = fmt::format("stepper_{}.motor", key);
  } else {
    for (const machine::MotorPreset& p : machine::motor_presets()) {
      if (p.full_steps_per_rotation == st.full_steps_per_rotation) {
        preset = &p;
        break;
      }
    }
    if (preset == nullptr) preset = &machine::default_motor_preset();
    a.motor_source = fmt::format("the default for a {}-step motor: the machine names no motor",
                                 st.full_steps_per_rotation);
  }
  a.motor_name = std::string(preset->name);
  a.motor.full_steps_per_rotation = st.full_steps_per_rotation;
  a.motor.holding_torque_n_m = preset->holding_torque_n_m;
  a.motor.rated_current_a = preset->rated_current_a;
  a.motor.phase_resistance_ohm = preset->phase_resistance_ohm;
  a.motor.phase_inductance_h = preset->phase_inductance_h;
  a.motor.rotor_inertia_kg_m2 = preset->rotor_inertia_kg_m2;
  a.motor.detent_torque_n_m = preset->detent_torque_n_m;
  std::vector<std::string> own;
  auto over = [&](const std::optional<double>& v, double& field, const char* name) {
    if (v) {
      field = *v;
      own.emplace_back(name);
    }
  };
  over(st.holding_torque_n_m, a.motor.holding_torque_n_m, "holding_torque");
  over(st.rated_current_a, a.motor.rated_current_a, "rated_current");
  over(st.phase_resistance_ohm, a.motor.phase_resistance_ohm, "phase_resistance");
  over(st.phase_inductance_h, a.motor.phase_inductance_h, "phase_inductance");
  over(st.rotor_inertia_kg_m2, a.motor.rotor_inertia_kg_m2, "rotor_inertia");
  over(st.detent_torque_n_m, a.motor.detent_torque_n_m, "detent_torque");
  if (!own.empty()) {
    a.motor_source += fmt::format(", with the machine's {}", fmt::join(own, ", "));
  }
}

// A current amplitude above the motor's rating is refused, naming where it came from.
void require_rated_current(const AxisSetup& a, double amplitude_a, const std::string& what) {
  if (amplitude_a > a.motor.rated_current_a * (1.0 + 1e-9)) {
    throw Error(fmt::format(
        "{} = {:.3f} A amplitude ({:.3f} A RMS) on axis {} is above the motor's rated current "
        "{} A ({}): at most {:.3f} A RMS",
        what, amplitude_a, amplitude_a / std::numbers::sqrt2, a.name, a.motor.rated_current_a,
        a.motor_name, a.motor.rated_current_a / std::numbers::sqrt2));
  }
}

}  // namespace

std::vector<AxisSetup> machine_axes(const machine::Machine& m) {
  (void)xy_channels(m);  // validates every stepper section (missing, rotation_distance, ...)
  std::vector<AxisSetup> out;
  for (const char* key : {"x", "y"}) {
    const machine::Stepper& st = m.steppers.at(key);
    AxisSetup a;
    a.name = key;
    a.drive.microsteps = st.microsteps;
    a.mechanics.rotation_distance_mm = st.rotation_distance_mm;
    set_motor(a, st, key);
    // The driver: the machine's run_current (RMS), else the motor's rated current as the
    // phase current amplitude; its supply voltage, else 24 V.
    a.drive.current_amplitude_a =
        st.run_current_a ? std::numbers::sqrt2 * *st.run_current_a : a.motor.rated_current_a;
    if (st.run_current_a) {
      require_rated_current(a, a.drive.current_amplitude_a, fmt::format("stepper_{}.run_current", key));
    }
    if (st.supply_voltage_v) a.drive.supply_voltage_v = *st.supply_voltage_v;
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

// The encoder must be able to tell where the axis is between two reads: the AS5311 unwraps
// pole crossings only below half a pole pair (1 mm) per read.
void require_encoder_rate(const AxisSetup& a, double speed_mm_s, double period_s, const std::string& where) {
  const double per_read = std::abs(speed_mm_s) * period_s;
  if (per_read >= 0.5 * kAs5311PolePairMm) {
    throw Error(fmt::format(
        "{}: axis {} moves {:.3f} mm between two encoder frames at {} mm/s and a frame rate of "
        "{:.0f} Hz; the AS5311 unwraps pole crossings only below 1 mm per frame: raise "
        "--encoder-rate-hz above {:.0f} Hz",
        where, a.name, per_read, speed_mm_s, 1.0 / period_s, 2.0 * std::abs(speed_mm_s) / kAs5311PolePairMm));
  }
}

// A reference sample of one axis from the move under way (or the hold): position, speed,
// acceleration, and the move's figures along this axis for the governor and the path error.
RefSample axis_sample(const trajectory::AxisState& st, const trajectory::Cursor::Location& loc,
                      const trajectory::Cursor& cur, const std::array<double, 4>& row,
                      std::uint64_t move_base) {
  RefSample r;
  for (int k = 0; k < 4; ++k) {
    r.pos_mm += row[k] * st.pos_mm[k];
    r.vel_mm_s += row[k] * st.vel_mm_s[k];
    r.acc_mm_s2 += row[k] * st.acc_mm_s2[k];
  }
  if (loc.holding) {
    r.seg_from_mm = r.seg_to_mm = r.pos_mm;
    return r;
  }
  const plan::PlannedMove& mv = cur.move(loc.move_index);
  double c = 0.0, start = 0.0;
  for (int k = 0; k < 4; ++k) {
    c += row[k] * mv.axes_r[k];
    start += row[k] * mv.start_mm[k];
  }
  r.move = move_base + loc.move_index + 1;
  r.move_speed_mm_s = std::abs(c) * mv.cruise_v_mm_s;
  r.move_accel_mm_s2 = std::abs(c) * mv.accel_mm_s2;
  r.seg_from_mm = start;
  r.seg_to_mm = start + c * mv.distance_mm;
  r.line = mv.line;
  return r;
}

// The commands of a move on each axis's own sequence (the encoder-sequenced law).
void push_move_commands(ClosedLoopSimulator& sim, const plan::PlannedMove& mv,
                        const std::vector<steppers::StepperChannel>& ch) {
  for (std::size_t i = 0; i < sim.axes(); ++i) {
    double c = 0.0, start = 0.0;
    for (int k = 0; k < 4; ++k) {
      c += ch[i].row[k] * mv.axes_r[k];
      start += ch[i].row[k] * mv.start_mm[k];
    }
    sim.push_command(i, {start + c * mv.distance_mm, std::abs(c) * mv.cruise_v_mm_s, mv.line});
  }
}

// After the plan's end: a sequenced law may still be executing its commands; it gets up to
// half the plan's duration more (at least 5 s) with the reference held at its end.
double overtime_s(double plan_duration_s) { return std::max(5.0, 0.5 * plan_duration_s); }

}  // namespace

SimulationResult simulate_reversing_strokes(const machine::Machine& machine_in,
                                            const ReversingStrokesScenario& sc,
                                            const SimulationOptions& options) {
  require_positive("--speed-mm-s", sc.speed_mm_s);
  // The default preset has no stepper sections: the scenario then runs on the default drive
  // train (rotation_distance 40, 16 microsteps, 200 steps) and says so.
  machine::Machine m = machine_in;
  std::vector<std::string> notes;
  for (const char* key : {"x", "y"}) {
    if (m.steppers.count(key) == 0) {
      m.steppers[key] = machine::Stepper{};
      notes.push_back(fmt::format(
          "the machine has no [stepper_{}]: the scenario's default drive train is assumed "
          "(rotation_distance 40 mm, 16 microsteps, 200 full steps per rotation)",
          key));
    }
  }
  std::vector<AxisSetup> axes;
  {
    // The scenario drives each motor on its own: only the two sections are needed.
    machine::Machine only = m;
    only.kinematics = machine::Kinematics::cartesian;
    if (only.steppers.count("z") == 0) only.steppers["z"] = machine::Stepper{};
    if (only.steppers.count("e") == 0) only.steppers["e"] = machine::Stepper{};
    axes = machine_axes(only);
  }
  axes[0].mechanics.belt.mass_kg = sc.x_mass_kg;
  axes[1].mechanics.belt.mass_kg = sc.y_mass_kg;
  for (AxisSetup& a : axes) {
    // Same belt frequency (40 Hz, damping ratio 0.1) for the scenario's masses.
    const double w = 2.0 * std::numbers::pi * 40.0;
    a.mechanics.belt.stiffness_n_per_m = a.mechanics.belt.mass_kg * w * w;
    a.mechanics.belt.damping_n_s_per_m = 2.0 * 0.1 * w * a.mechanics.belt.mass_kg;
    // The scenario's printer class where the machine does not say (its motor keys win; the
    // request's overrides win over both). The class's 0.8 A RMS is capped at the motor's rating.
    const machine::Stepper& st = m.steppers.at(a.name);
    a.drive.supply_voltage_v =
        sc.supply_voltage_v.value_or(st.supply_voltage_v.value_or(sc.default_supply_voltage_v));
    const double rms = sc.run_current_a.value_or(
        st.run_current_a.value_or(std::min(sc.default_run_current_a,
                                           a.motor.rated_current_a / std::numbers::sqrt2)));
    a.drive.current_amplitude_a = std::numbers::sqrt2 * rms;
    require_rated_current(a, a.drive.current_amplitude_a,
                          sc.run_current_a ? "--run-current-a" : fmt::format("stepper_{}.run_current", a.name));
    a.mechanics.backlash_mm = sc.backlash_mm.value_or(st.backlash_mm.value_or(sc.default_backlash_mm));
    if (sc.max_current_a > 0.0) {
      require_rated_current(a, sc.max_current_a, "--max-current-a");
      a.drive.max_current_a = sc.max_current_a;
    }
    if (sc.load) {
      a.mechanics.drag_force_n = sc.drag_force_n;
      a.mechanics.end_load_n_per_mm = sc.end_load_n_per_mm;
      a.mechanics.end_load_start_mm = sc.end_load_start_mm;
      a.mechanics.bump_force_n = sc.bump_force_n;
      a.mechanics.bump_position_mm = sc.bump_position_mm;
      a.mechanics.bump_half_width_mm = sc.bump_half_width_mm;
      a.mechanics.drag_n_s_per_m = sc.drag_n_s_per_m;
    }
    require_step_rate(a, sc.speed_mm_s, "scenario reversing-strokes");
    require_encoder_rate(a, sc.speed_mm_s, options.gains.period_s, "scenario reversing-strokes");
  }
  // 0 -> -stroke -> 0 ..., each stroke from rest to rest.
  std::vector<trajectory::MoveSpec> specs;
  for (int k = 0; k < sc.strokes; ++k) {
    trajectory::MoveSpec sp;
    sp.to_mm = {k % 2 == 0 ? -sc.stroke_mm : 0.0, 0, 0, 0};
    sp.max_v_mm_s = sc.speed_mm_s;
    specs.push_back(sp);
  }
  std::vector<plan::PlannedMove> moves = trajectory::chain_moves(
      {0, 0, 0, 0}, specs, m.max_accel_mm_s2, plan::VelocityProfile::trapezoid);
  for (std::size_t k = 0; k < moves.size(); ++k) moves[k].line = k + 1;
  trajectory::Cursor cur(moves);
  const double t0 = moves.front().start_time_s;
  const double t_plan = moves.back().start_time_s + moves.back().duration_s() - t0;
  const double start[2] = {0.0, 0.0};
  ClosedLoopSimulator sim(axes, options, start);
  const double T = sim.period_s();
  std::vector<steppers::StepperChannel> ch(2);
  ch[0].row = ch[1].row = {1.0, 0.0, 0.0, 0.0};  // both axes follow the same stroke
  for (const plan::PlannedMove& mv : moves) push_move_commands(sim, mv, ch);
  RefSample now[2], next[2];
  auto sample = [&](double t, RefSample* out) {
    const trajectory::Cursor::Location loc = cur.locate(t0 + t);
    const trajectory::AxisState st = cur.evaluate(t0 + t);
    for (int i = 0; i < 2; ++i) out[i] = axis_sample(st, loc, cur, ch[i].row, 0);
  };
  sample(0.0, now);
  const double t_end = t_plan + options.settle_s;
  const double t_limit = t_end + overtime_s(t_plan);
  while (sim.time_s() < t_end || (!sim.finished() && sim.time_s() < t_limit)) {
    sample(sim.time_s() + T, next);
    sim.tick(now, next);
    std::copy(next, next + 2, now);
  }
  SimulationResult r = sim.finish();
  r.source = "scenario reversing-strokes";
  r.speed_mm_s = sc.speed_mm_s;
  r.load = sc.load;
  r.notes.insert(r.notes.begin(), notes.begin(), notes.end());
  return r;
}

namespace {

// The plan stream into the simulator: a window of the previous batch's last move and this
// batch's moves, evaluated on a Cursor; ticks run while their next sample lies inside it.
class ClosedLoopSink final : public plan::Sink {
 public:
  ClosedLoopSink(ClosedLoopSimulator& sim, std::vector<steppers::StepperChannel> ch,
                 std::vector<AxisSetup> axes, const SimulationOptions& options)
      : sim_(sim), ch_(std::move(ch)), axes_(std::move(axes)), settle_s_(options.settle_s),
        period_s_(options.gains.period_s) {}

  void consume(const plan::PlanBatch& batch) override {
    if (batch.moves.empty()) return;
    for (const plan::PlannedMove& mv : batch.moves) {
      check_rate(mv);
      push_move_commands(sim_, mv, ch_);
    }
    if (!window_.empty()) {
      base_ += window_.size() - 1;
      window_.erase(window_.begin(), window_.end() - 1);
    }
    window_.insert(window_.end(), batch.moves.begin(), batch.moves.end());
    const plan::PlannedMove& last = window_.back();
    run_until(last.start_time_s + last.duration_s());
  }
  void finish(const plan::StreamSummary& summary) override {
    if (window_.empty()) return;
    const double end = std::max(summary.end_time_s, window_.back().start_time_s + window_.back().duration_s());
    run_until(end + settle_s_ + sim_.period_s());
    // A sequenced law may still be executing its commands: the reference holds at the end.
    const double limit = sim_.time_s() + overtime_s(end - t0_);
    while (!sim_.finished() && sim_.time_s() < limit) run_until(t0_ + sim_.time_s() + 0.1);
  }

 private:
  void check_rate(const plan::PlannedMove& mv) {
    for (std::size_t i = 0; i < axes_.size(); ++i) {
      double speed = 0.0;
      for (int k = 0; k < 4; ++k) speed += ch_[i].row[k] * mv.axes_r[k];
      speed = std::abs(speed) * mv.cruise_v_mm_s;
      require_step_rate(axes_[i], speed, fmt::format("line {}", mv.line));
      require_encoder_rate(axes_[i], speed, period_s_, fmt::format("line {}", mv.line));
    }
  }
  void sample(trajectory::Cursor& cur, double t, RefSample* out) {
    const trajectory::Cursor::Location loc = cur.locate(t);
    const trajectory::AxisState st = cur.evaluate(t);
    for (std::size_t i = 0; i < axes_.size(); ++i) out[i] = axis_sample(st, loc, cur, ch_[i].row, base_);
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
  double settle_s_, period_s_;
  std::vector<plan::PlannedMove> window_;
  std::uint64_t base_ = 0;  // the plan's index of window_[0]
  bool started_ = false;
  double t0_ = 0.0;
};

// Builds the simulator on the first batch (the start position is the first move's start) and
// feeds it every batch.
class LazyClosedLoop final : public plan::Sink {
 public:
  LazyClosedLoop(const machine::Machine& m, const SimulationOptions& o)
      : ch_(xy_channels(m)), axes_(machine_axes(m)), options_(o) {}
  void consume(const plan::PlanBatch& b) override {
    if (b.moves.empty()) return;
    if (!sim_) {
      const plan::PlannedMove& f = b.moves.front();
      double start[2] = {0.0, 0.0};
      for (std::size_t i = 0; i < 2; ++i)
        for (int k = 0; k < 4; ++k) start[i] += ch_[i].row[k] * f.start_mm[k];
      sim_ = std::make_unique<ClosedLoopSimulator>(axes_, options_, start);
      sink_ = std::make_unique<ClosedLoopSink>(*sim_, ch_, axes_, options_);
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

namespace {

// The governor's and the sequencer's figures as notes a reader sees.
void add_notes(SimulationResult& r, bool governor) {
  if (r.controller == "open") return;
  if (!governor) {
    r.notes.push_back("no command governor (--no-governor): the controller's commands reach the "
                      "motor unchecked");
    return;
  }
  for (const AxisResult& a : r.axes) {
    if (a.degraded_moves > 0) {
      r.notes.push_back(fmt::format(
          "axis {}: degraded to open loop on {} of {} moves, the first at line {}: {}", a.name,
          a.degraded_moves, a.moves, a.first_degraded_line, a.first_degraded_reason));
    }
    if (a.commands_left > 0) {
      r.notes.push_back(fmt::format("axis {}: {} commands of its sequence not reached when the "
                                    "simulation stopped",
                                    a.name, a.commands_left));
    }
  }
}

}  // namespace

SimulationResult stepper_simulate(const machine::Machine& m, const SimulateRequest& a) {
  SimulationOptions o;
  o.controller = controller_from_string(a.controller);
  o.csv_path = a.csv_path;
  o.gains.max_accel_mm_s2 = m.max_accel_mm_s2;
  o.governor.enabled = a.governor;
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
  if (!(a.corrupt_probability >= 0.0 && a.corrupt_probability <= 1.0)) {
    throw Error(fmt::format("--corrupt-probability must be a probability in [0, 1], got {}",
                            a.corrupt_probability));
  }
  if (a.encoder_rate_hz) {
    require_positive("--encoder-rate-hz", *a.encoder_rate_hz);
    // The AS5311's SSI: 18 bits at up to 1 MHz, plus chip-select time: at most 50 kHz.
    if (*a.encoder_rate_hz > 50000.0) {
      throw Error(fmt::format("--encoder-rate-hz {}: the AS5311 reads at most 50000 frames/s "
                              "(18-bit SSI frames at its 1 MHz clock)",
                              *a.encoder_rate_hz));
    }
    const double period = 1.0 / *a.encoder_rate_hz;
    const double ratio = period / o.substep_s;
    if (std::abs(ratio - std::round(ratio)) > 1e-6 * ratio) {
      throw Error(fmt::format("--encoder-rate-hz {}: the control period 1/rate = {} us must be a "
                              "whole number of the {} us physics substeps (50000, 25000, 16666.67, "
                              "12500, 10000, ... Hz)",
                              *a.encoder_rate_hz, period * 1e6, o.substep_s * 1e6));
    }
    o.gains.period_s = std::round(ratio) * o.substep_s;
    // The encoder's latency: its internal sampling plus one frame.
    o.encoder.latency_s = o.gains.period_s;
  }
  if (a.encoder_resolution_um) {
    require_positive("--encoder-resolution-um", *a.encoder_resolution_um);
    o.encoder.resolution_mm = *a.encoder_resolution_um * 1e-3;
    try {
      o.encoder.validate();
    } catch (const Error& e) {
      throw Error(fmt::format("--encoder-resolution-um: {}", e.what()));
    }
  }
  if (a.model_mass_scale) o.gains.ff_model_mass_scale = *a.model_mass_scale;
  if (a.model_stiffness_scale) o.gains.ff_model_stiffness_scale = *a.model_stiffness_scale;
  if (a.kp) o.gains.kp = o.gains.ff_kp = *a.kp;
  if (a.ki_per_s) o.gains.ki_per_s = o.gains.ff_ki_per_s = *a.ki_per_s;
  if (a.kd_s) o.gains.kd_s = o.gains.ff_kd_s = *a.kd_s;
  if (a.alpha_per_s) o.gains.alpha_per_s = *a.alpha_per_s;
  if (a.drag_gain_per_s) o.gains.ff_drag_gain_per_s = *a.drag_gain_per_s;
  if (a.load_angle_deg) o.gains.ff_load_angle_deg = *a.load_angle_deg;
  o.encoder.corrupt_probability = a.corrupt_probability;
  auto encoder_resolution = [&](const std::vector<AxisSetup>& axes) {
    // The position judgement and the loops need the encoder to resolve a step.
    for (const AxisSetup& ax : axes) {
      const double step = ax.mechanics.rotation_distance_mm /
                          (static_cast<double>(ax.motor.full_steps_per_rotation) * ax.drive.microsteps);
      if (is_feedback(o.controller) && o.encoder.resolution_mm > 0.5 * step) {
        throw Error(fmt::format("--encoder-resolution-um {}: coarser than half a microstep of axis "
                                "{} ({:.3f} um); the controller could not tell one step from the "
                                "next: at most {:.3f} um",
                                o.encoder.resolution_mm * 1e3, ax.name, step * 1e3, 0.5 * step * 1e3));
      }
    }
  };
  SimulationResult r;
  if (!a.scenario.empty()) {
    if (!a.file.empty()) throw Error("give either FILE or --scenario, not both");
    if (a.scenario != "reversing-strokes" && a.scenario != "seed003") {
      throw Error(fmt::format("--scenario '{}': expected reversing-strokes", a.scenario));
    }
    ReversingStrokesScenario sc;
    sc.speed_mm_s = a.speed_mm_s;
    sc.load = a.load;
    if (a.drag_force_n) sc.drag_force_n = *a.drag_force_n;
    if (a.bump_force_n) sc.bump_force_n = *a.bump_force_n;
    if (a.end_load_n_per_mm) sc.end_load_n_per_mm = *a.end_load_n_per_mm;
    if (a.drag_n_s_per_m) sc.drag_n_s_per_m = *a.drag_n_s_per_m;
    if (a.backlash_mm) sc.backlash_mm = *a.backlash_mm;
    if (a.run_current_a) sc.run_current_a = *a.run_current_a;
    if (a.max_current_a) sc.max_current_a = *a.max_current_a;
    if (a.encoder_resolution_um) {
      machine::Machine mm = m;
      for (const char* key : {"x", "y", "z", "e"}) {
        if (mm.steppers.count(key) == 0) mm.steppers[key] = machine::Stepper{};
      }
      mm.kinematics = machine::Kinematics::cartesian;
      encoder_resolution(machine_axes(mm));
    }
    r = simulate_reversing_strokes(m, sc, o);
    if (a.scenario == "seed003") {
      r.notes.insert(r.notes.begin(), "--scenario seed003 is now 'reversing-strokes'; the old name "
                                      "goes in the next release");
    }
  } else {
    if (a.file.empty()) throw Error("give a G-code FILE or --scenario reversing-strokes");
    if (a.run_current_a || a.max_current_a || a.backlash_mm || a.drag_force_n || a.bump_force_n ||
        a.end_load_n_per_mm || a.drag_n_s_per_m) {
      throw Error("--run-current-a, --max-current-a, --backlash-mm and the load flags apply to "
                  "--scenario only; for a file, set the machine's stepper_x.run_current, "
                  "stepper_x.backlash, ... (--set)");
    }
    encoder_resolution(machine_axes(m));
    r = simulate_file(a.file, m, o);
  }
  if (auto note = controller_alias_note(a.controller)) r.notes.insert(r.notes.begin(), *note);
  add_notes(r, a.governor);
  return r;
}

namespace {

Json motor_json(const AxisResult& a) {
  Json mj;
  mj["name"] = a.motor_name;
  mj["source"] = a.motor_source;
  mj["full_steps_per_rotation"] = a.motor.full_steps_per_rotation;
  mj["holding_torque_n_m"] = json_number(a.motor.holding_torque_n_m);
  mj["rated_current_a"] = json_number(a.motor.rated_current_a);
  mj["phase_resistance_ohm"] = json_number(a.motor.phase_resistance_ohm);
  mj["phase_inductance_h"] = json_number(a.motor.phase_inductance_h);
  mj["rotor_inertia_kg_m2"] = json_number(a.motor.rotor_inertia_kg_m2);
  mj["detent_torque_n_m"] = json_number(a.motor.detent_torque_n_m);
  return mj;
}

Json drive_json(const AxisResult& a) {
  Json d;
  d["supply_voltage_v"] = json_number(a.drive.supply_voltage_v);
  d["run_current_a_rms"] = json_number(a.drive.current_amplitude_a / std::numbers::sqrt2);
  d["current_amplitude_a"] = json_number(a.drive.current_amplitude_a);
  d["max_current_a"] = json_number(a.max_current_a);
  d["microsteps"] = a.drive.microsteps;
  d["max_step_rate_hz"] = json_number(a.drive.max_step_rate_hz);
  return d;
}

Json mechanics_json(const AxisResult& a) {
  Json x;
  const dynamics::BeltParameters& b = a.mechanics.belt;
  x["rotation_distance_mm"] = json_number(a.mechanics.rotation_distance_mm);
  x["carriage_mass_kg"] = json_number(b.mass_kg);
  x["belt_frequency_hz"] = json_number(std::sqrt(b.stiffness_n_per_m / b.mass_kg) / (2.0 * std::numbers::pi));
  x["backlash_mm"] = json_number(a.mechanics.backlash_mm);
  return x;
}

Json axis_json(const AxisResult& a) {
  Json x;
  x["max_tracking_error_mm"] = json_number(a.max_tracking_error_mm);
  x["max_error_time_s"] = json_number(a.max_error_time_s);
  x["rms_tracking_error_mm"] = json_number(a.rms_tracking_error_mm);
  x["final_error_mm"] = json_number(a.final_error_mm);
  x["max_path_error_mm"] = json_number(a.max_path_error_mm);
  x["max_path_error_time_s"] = json_number(a.max_path_error_time_s);
  x["rms_path_error_mm"] = json_number(a.rms_path_error_mm);
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
  x["governor_limited_periods"] = a.governor_limited_periods;
  x["moves_checked"] = a.moves;
  x["degraded_moves"] = a.degraded_moves;
  x["first_degraded_line"] = a.first_degraded_line;
  x["accel_lead_dropped_moves"] = a.accel_lead_dropped_moves;
  x["commands_reached"] = a.commands_reached;
  x["commands_left"] = a.commands_left;
  x["motor"] = motor_json(a);
  x["drive"] = drive_json(a);
  x["mechanics"] = mechanics_json(a);
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
  j["notes"] = r.notes;
  Json axes = Json::object();
  for (const AxisResult& a : r.axes) axes[a.name] = axis_json(a);
  j["axes"] = axes;
  return j;
}

std::vector<SweepRow> sweep_reversing_strokes(const machine::Machine& m,
                                              std::span<const ControllerKind> controllers,
                                              std::span<const double> speeds, bool load,
                                              const SimulationOptions& options) {
  std::vector<SweepRow> rows;
  for (ControllerKind k : controllers) {
    for (double v : speeds) {
      SimulationOptions o = options;
      o.controller = k;
      o.csv_path.clear();
      ReversingStrokesScenario sc;
      sc.speed_mm_s = v;
      sc.load = load;
      const SimulationResult r = simulate_reversing_strokes(m, sc, o);
      rows.push_back({to_string(k), v, r.axes[0], r.axes[1]});
    }
  }
  return rows;
}

std::vector<SweepRow> stepper_sweep(const machine::Machine& m, bool load) {
  SimulationOptions o;
  o.gains.max_accel_mm_s2 = m.max_accel_mm_s2;
  const double speeds[] = {30, 60, 90, 120, 150};
  return sweep_reversing_strokes(m, all_controllers(), speeds, load, o);
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
      "y_rms_error_mm,y_lost_steps,x_max_path_error_mm,y_max_path_error_mm\n";
  for (const SweepRow& r : rows) {
    s += fmt::format("{},{},{:.6f},{:.6f},{},{:.6f},{:.6f},{},{:.6f},{:.6f}\n", r.controller,
                     r.speed_mm_s, r.x.max_tracking_error_mm, r.x.rms_tracking_error_mm,
                     r.x.lost_steps, r.y.max_tracking_error_mm, r.y.rms_tracking_error_mm,
                     r.y.lost_steps, r.x.max_path_error_mm, r.y.max_path_error_mm);
  }
  return s;
}

}  // namespace amctl::closedloop
