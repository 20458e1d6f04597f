// The closed-loop simulations a user runs: the machine's axes and motors, the reversing-strokes
// scenario, a G-code file through the plan stream, the request of `amctl stepper simulate`, its
// JSON and the speed sweep (docs/closedloop.md, sections 1, 4 and 5). The engine is
// simulate_engine.cpp.
#include "amctl/closedloop/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <numbers>
#include <optional>
#include <variant>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/motor_presets.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"
#include "amctl/steppers/shaped_steps.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/steppers/steps.hpp"
#include "amctl/trajectory/build.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::closedloop {
namespace {

// The rows of stepper_x and stepper_y over (X, Y, Z, E): the one use of the step generator's
// public functions here (it validates the stepper sections with `amctl steps`'s messages).
std::vector<kinematics::Motor> xy_channels(const machine::Machine& m) {
  std::vector<kinematics::Motor> ch = machine::motors(m);
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
  if (st.holding_torque_n_m && st.rated_current_a && st.phase_resistance_ohm && st.phase_inductance_h) {
    // The machine describes its own motor: the preset only fills what it leaves out.
    a.motor_name = "the machine's own";
    a.motor_source = fmt::format("stepper_{}'s {}{}", key, fmt::join(own, ", "),
                                 own.size() < 6 ? fmt::format("; the rest of {}", preset->name) : "");
  } else if (!own.empty()) {
    a.motor_source += fmt::format(", with the machine's {}", fmt::join(own, ", "));
  }
}

// A machine without [stepper_x] / [stepper_y] (the default preset, a printer.cfg that leaves
// them out) runs on the default drive train, and the notes say so; a missing [stepper_z] or
// extruder (not simulated here) is filled in silently. Only for kinematics whose X and Y
// motors are stepper_x and stepper_y.
machine::Machine with_default_drive_train(const machine::Machine& in, std::vector<std::string>& notes) {
  machine::Machine m = in;
  if (!std::holds_alternative<kinematics::Cartesian>(m.kinematics) &&
      !std::holds_alternative<kinematics::CoreXY>(m.kinematics) &&
      !std::holds_alternative<kinematics::CoreXZ>(m.kinematics)) {
    return m;
  }
  for (const char* key : {"x", "y"}) {
    if (m.steppers.count(key) == 0) {
      m.steppers[key] = machine::Stepper{};
      notes.push_back(fmt::format(
          "the machine has no [stepper_{}]: the default drive train is assumed (rotation_distance "
          "40 mm, 16 microsteps, 200 full steps per rotation)",
          key));
    }
  }
  for (const char* key : {"z", "e"}) {
    if (m.steppers.count(key) == 0) m.steppers[key] = machine::Stepper{};
  }
  return m;
}

// A current amplitude above the motor's rating is refused, naming where it came from.
void require_rated_current(const AxisSetup& a, double amplitude_a, const std::string& what) {
  if (amplitude_a > a.motor.rated_current_a * (1.0 + 1e-9)) {
    throw Error(fmt::format(
        "{}: {:.3f} A RMS ({:.3f} A amplitude) on axis {} is above the rated current of motor {} "
        "({} A per phase): expected at most {:.3f} A RMS ({} A amplitude)",
        what, amplitude_a / std::numbers::sqrt2, amplitude_a, a.name, a.motor_name,
        a.motor.rated_current_a, a.motor.rated_current_a / std::numbers::sqrt2,
        a.motor.rated_current_a));
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
        "{}: {:.0f} frames/s: axis {} moves {:.3f} mm between two encoder frames at {:g} mm/s, "
        "and the AS5311 unwraps its 2 mm pole pairs only below 1 mm per frame: expected above "
        "{:.0f} frames/s",
        where, 1.0 / period_s, a.name, per_read, speed_mm_s,
        2.0 * std::abs(speed_mm_s) / kAs5311PolePairMm));
  }
}

// The reference of the axes along their channel rows, with the figures of the move under way
// along each axis (the governor's check and the path error), recomputed only when the move
// changes.
class AxisSampler {
 public:
  AxisSampler(std::vector<std::array<double, 4>> rows) : rows_(std::move(rows)), moves_(rows_.size()) {}
  /// `shaped`: the machine's input shaper over the same window (the position, speed and
  /// acceleration come from it; the move's figures stay the plan's).
  void sample(trajectory::Cursor& cur, double t, std::uint64_t move_base, RefSample* out,
              shaping::ShapedCursor* shaped = nullptr) {
    const trajectory::Cursor::Location& loc = cur.locate(t);
    const std::uint64_t id = loc.holding ? 0 : move_base + loc.move_index + 1;
    const bool fresh = id != id_ || id == 0;
    id_ = id;
    const trajectory::AxisState st = shaped ? shaped->evaluate(t) : cur.evaluate(t);
    for (std::size_t i = 0; i < rows_.size(); ++i) {
      const std::array<double, 4>& row = rows_[i];
      RefSample& r = out[i];
      r.pos_mm = r.vel_mm_s = r.acc_mm_s2 = 0.0;
      for (int k = 0; k < 4; ++k) {
        r.pos_mm += row[k] * st.pos_mm[k];
        r.vel_mm_s += row[k] * st.vel_mm_s[k];
        r.acc_mm_s2 += row[k] * st.acc_mm_s2[k];
      }
      if (fresh) {
        RefSample& m = moves_[i];
        m = RefSample{};
        if (id == 0) {
          m.seg_from_mm = m.seg_to_mm = r.pos_mm;
        } else {
          const plan::PlannedMove& mv = cur.move(loc.move_index);
          double c = 0.0, start = 0.0;
          for (int k = 0; k < 4; ++k) {
            c += row[k] * mv.axes_r[k];
            start += row[k] * mv.start_mm[k];
          }
          m.move = id;
          // The step of this axis's speed at the junction with the previous move (a planner
          // bounds it; a plan that jumps asks the impossible of the motor).
          if (loc.move_index > 0) {
            const plan::PlannedMove& pv = cur.move(loc.move_index - 1);
            double cp = 0.0;
            for (int k = 0; k < 4; ++k) cp += row[k] * pv.axes_r[k];
            m.move_jump_mm_s = std::abs(c * mv.start_v_mm_s - cp * pv.end_v_mm_s);
          }
          m.move_speed_mm_s = std::abs(c) * mv.cruise_v_mm_s;
          m.move_accel_mm_s2 = std::abs(c) * mv.accel_mm_s2;
          m.seg_from_mm = start;
          m.seg_to_mm = start + c * mv.distance_mm;
          m.line = mv.line;
        }
      }
      const RefSample& m = moves_[i];
      r.move = m.move;
      r.move_speed_mm_s = m.move_speed_mm_s;
      r.move_accel_mm_s2 = m.move_accel_mm_s2;
      r.move_jump_mm_s = m.move_jump_mm_s;
      r.seg_from_mm = m.seg_from_mm;
      r.seg_to_mm = m.seg_to_mm;
      r.line = m.line;
    }
  }
  /// Forget the cached move (a new window: its indices start over).
  void reset() { id_ = static_cast<std::uint64_t>(-1); }

 private:
  std::vector<std::array<double, 4>> rows_;
  std::vector<RefSample> moves_;
  std::uint64_t id_ = static_cast<std::uint64_t>(-1);
};

// The commands of a move on each axis's own sequence (the encoder-sequenced law).
void push_move_commands(ClosedLoopSimulator& sim, const plan::PlannedMove& mv,
                        const std::vector<kinematics::Motor>& ch) {
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

std::vector<AxisSetup> reversing_strokes_axes(const machine::Machine& machine_in,
                                              const ReversingStrokesScenario& sc,
                                              std::vector<std::string>* notes) {
  // The scenario drives each motor on its own (the kinematics does not matter): a machine
  // without the two sections (the default preset) runs on the default drive train.
  std::vector<std::string> ignored;
  machine::Machine m = machine_in;
  m.kinematics = kinematics::Cartesian{};
  m = with_default_drive_train(m, notes ? *notes : ignored);
  std::vector<AxisSetup> axes = machine_axes(m);
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
  }
  return axes;
}

SimulationResult simulate_reversing_strokes(const machine::Machine& m,
                                            const ReversingStrokesScenario& sc,
                                            const SimulationOptions& options) {
  require_positive("--speed-mm-s", sc.speed_mm_s);
  std::vector<std::string> notes;
  std::vector<AxisSetup> axes = reversing_strokes_axes(m, sc, &notes);
  for (const AxisSetup& a : axes) {
    require_step_rate(a, sc.speed_mm_s, "scenario reversing-strokes");
    require_encoder_rate(a, sc.speed_mm_s, options.gains.period_s, "--encoder-rate-hz");
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
  std::vector<kinematics::Motor> ch(2);
  ch[0].row = ch[1].row = {1.0, 0.0, 0.0, 0.0};  // both axes follow the same stroke
  for (const plan::PlannedMove& mv : moves) push_move_commands(sim, mv, ch);
  RefSample now[2], next[2];
  AxisSampler sampler({ch[0].row, ch[1].row});
  auto sample = [&](double t, RefSample* out) { sampler.sample(cur, t0 + t, 0, out); };
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
// With the machine's [input_shaper] the reference is the shaped motion (as `amctl steps`
// generates the steps: Klipper's convolution of the plan with the shaper's impulses): the
// window then keeps the moves of the shaper's look-behind, and a batch runs only up to its
// end less the look-ahead (the rest waits for the next batch or the plan's end).
class ClosedLoopSink final : public plan::Sink {
 public:
  ClosedLoopSink(ClosedLoopSimulator& sim, std::vector<kinematics::Motor> ch,
                 std::vector<AxisSetup> axes, const SimulationOptions& options,
                 const shaping::AxisShapers& shapers)
      : sim_(sim), ch_(std::move(ch)), axes_(std::move(axes)), settle_s_(options.settle_s),
        period_s_(options.gains.period_s), sampler_({ch_[0].row, ch_[1].row}), shapers_(shapers) {
    for (const auto& sh : shapers_.xyz) shaped_ = shaped_ || sh.has_value();
    if (shaped_) {
      // The delays, from a cursor over no moves.
      std::vector<plan::PlannedMove> none;
      shaping::ShapedCursor probe(none, shapers_);
      look_behind_s_ = probe.max_delay_s();
      look_ahead_s_ = -probe.min_delay_s();
    }
  }

  void consume(const plan::PlanBatch& batch) override {
    if (batch.moves.empty()) return;
    for (const plan::PlannedMove& mv : batch.moves) {
      check_rate(mv);
      push_move_commands(sim_, mv, ch_);
    }
    if (!window_.empty()) {
      std::size_t drop = window_.size() - 1;
      if (shaped_) {
        // Keep every move the shaper still looks back at from the next sample on.
        const double keep_from = t0_ + sim_.time_s() - look_behind_s_ - 2.0 * period_s_;
        drop = 0;
        while (drop + 1 < window_.size() &&
               window_[drop].start_time_s + window_[drop].duration_s() < keep_from) {
          ++drop;
        }
      }
      base_ += drop;
      window_.erase(window_.begin(), window_.begin() + static_cast<std::ptrdiff_t>(drop));
    }
    window_.insert(window_.end(), batch.moves.begin(), batch.moves.end());
    const plan::PlannedMove& last = window_.back();
    run_until(last.start_time_s + last.duration_s() - look_ahead_s_);
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
      require_encoder_rate(axes_[i], speed, period_s_, fmt::format("--encoder-rate-hz (line {})", mv.line));
    }
  }
  void sample(trajectory::Cursor& cur, double t, RefSample* out) {
    sampler_.sample(cur, t, base_, out, shaped_cursor_ ? &*shaped_cursor_ : nullptr);
  }
  void run_until(double t_end) {
    trajectory::Cursor cur(window_);
    sampler_.reset();
    shaped_cursor_.reset();
    if (shaped_) shaped_cursor_.emplace(window_, shapers_);
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
  std::vector<kinematics::Motor> ch_;
  std::vector<AxisSetup> axes_;
  double settle_s_, period_s_;
  AxisSampler sampler_;
  std::vector<plan::PlannedMove> window_;
  shaping::AxisShapers shapers_;
  bool shaped_ = false;
  double look_behind_s_ = 0.0, look_ahead_s_ = 0.0;
  std::optional<shaping::ShapedCursor> shaped_cursor_;
  std::uint64_t base_ = 0;  // the plan's index of window_[0]
  bool started_ = false;
  double t0_ = 0.0;
};

// Builds the simulator on the first batch (the start position is the first move's start) and
// feeds it every batch.
class LazyClosedLoop final : public plan::Sink {
 public:
  LazyClosedLoop(const machine::Machine& m, const SimulationOptions& o)
      : ch_(xy_channels(m)), axes_(machine_axes(m)), options_(o),
        shapers_(steppers::axis_shapers(m.input_shaper)) {}
  void consume(const plan::PlanBatch& b) override {
    if (b.moves.empty()) return;
    if (!sim_) {
      const plan::PlannedMove& f = b.moves.front();
      double start[2] = {0.0, 0.0};
      for (std::size_t i = 0; i < 2; ++i)
        for (int k = 0; k < 4; ++k) start[i] += ch_[i].row[k] * f.start_mm[k];
      sim_ = std::make_unique<ClosedLoopSimulator>(axes_, options_, start);
      sink_ = std::make_unique<ClosedLoopSink>(*sim_, ch_, axes_, options_, shapers_);
    }
    sink_->consume(b);
  }
  void finish(const plan::StreamSummary& s) override {
    if (sink_) sink_->finish(s);
  }
  [[nodiscard]] bool started() const { return sim_ != nullptr; }
  SimulationResult result() { return sim_->finish(); }

 private:
  std::vector<kinematics::Motor> ch_;
  std::vector<AxisSetup> axes_;
  SimulationOptions options_;
  shaping::AxisShapers shapers_;
  std::unique_ptr<ClosedLoopSimulator> sim_;
  std::unique_ptr<ClosedLoopSink> sink_;
};

}  // namespace

SimulationResult simulate_file(const std::string& gcode_path, const machine::Machine& machine_in,
                               const SimulationOptions& options) {
  std::vector<std::string> notes;
  const machine::Machine m = with_default_drive_train(machine_in, notes);
  LazyClosedLoop lazy(m, options);
  plan::PlanSource source(gcode_path, m);
  plan::Sink* sinks[] = {&lazy};
  plan::run_pipeline(source, sinks);
  if (!lazy.started()) throw Error(fmt::format("{}: no moves to simulate", gcode_path));
  SimulationResult r = lazy.result();
  r.source = gcode_path;
  if (m.input_shaper.active()) {
    std::vector<std::string> parts;
    const machine::InputShaper& is = m.input_shaper;
    if (is.shaper_freq_x_hz > 0.0) parts.push_back(fmt::format("{} {:g} Hz on X", is.shaper_type_x, is.shaper_freq_x_hz));
    if (is.shaper_freq_y_hz > 0.0) parts.push_back(fmt::format("{} {:g} Hz on Y", is.shaper_type_y, is.shaper_freq_y_hz));
    notes.push_back(fmt::format("the reference is the plan through the machine's input shaper ({}), "
                                "as amctl steps generates the steps; errors are against it",
                                fmt::join(parts, ", ")));
  }
  r.notes.insert(r.notes.begin(), notes.begin(), notes.end());
  return r;
}

SimulationResult simulate_moves(std::span<const plan::PlannedMove> moves,
                                const machine::Machine& m, const SimulationOptions& options) {
  if (moves.empty()) throw Error("simulate_moves: no moves to simulate");
  std::vector<std::string> notes;
  const machine::Machine mm = with_default_drive_train(m, notes);
  LazyClosedLoop lazy(mm, options);
  plan::PlanBatch b;
  b.moves.assign(moves.begin(), moves.end());
  lazy.consume(b);
  plan::StreamSummary s;
  s.end_time_s = moves.back().start_time_s + moves.back().duration_s();
  lazy.finish(s);
  SimulationResult r = lazy.result();
  r.source = "moves";
  r.notes.insert(r.notes.begin(), notes.begin(), notes.end());
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
    if (a.gain_scale < 1.0) {
      r.notes.push_back(fmt::format(
          "axis {}: the default {} gains scaled by {:.3f} (kp and ki) to keep its linearised loop "
          "stable with a gain margin of {:g} up to the governor's design load angle, the carriage "
          "mass and belt stiffness {:.0f} % off",
          a.name, r.controller, a.gain_scale, kGainMargin, 100.0 * kModelUncertainty));
    }
    if (a.degraded_moves > 0) {
      r.notes.push_back(fmt::format(
          "axis {}: degraded to open loop on {} of {} moves, the first at line {}: {}", a.name,
          a.degraded_moves, a.moves, a.first_degraded_line, a.first_degraded_reason));
    }
    if (a.fall_back_time_s >= 0.0) {
      r.notes.push_back(fmt::format(
          "axis {}: slipped at {:.3f} s on a move the governor found feasible: the machine is not "
          "the one its analysis assumed; open loop's command from there to the end",
          a.name, a.fall_back_time_s));
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
  if (a.speed_change_mm_s) require_positive("--speed-change-mm-s", *a.speed_change_mm_s);
  // A controller's own parameters given to a controller that has no use for them are refused
  // (a value the run would silently ignore, 1e308 included), and the used ones must be
  // physical: the loop analysis below checks the gains, these the rest.
  {
    const ControllerKind k = o.controller;
    const bool pid_like = k == ControllerKind::pid || k == ControllerKind::feedforward;
    const bool speed_law = k == ControllerKind::encoder_sequenced || k == ControllerKind::speed_tracking;
    const bool ff = k == ControllerKind::feedforward;
    const std::tuple<const char*, bool, bool, const char*> own[] = {
        {"--kp", a.kp.has_value(), pid_like, "pid, feedforward"},
        {"--ki", a.ki_per_s.has_value(), pid_like, "pid, feedforward"},
        {"--kd", a.kd_s.has_value(), pid_like, "pid, feedforward"},
        {"--alpha", a.alpha_per_s.has_value(), speed_law, "encoder-sequenced, speed-tracking"},
        {"--speed-change-mm-s", a.speed_change_mm_s.has_value(), speed_law,
         "encoder-sequenced, speed-tracking"},
        {"--drag-gain", a.drag_gain_per_s.has_value(), ff, "feedforward"},
        {"--load-angle-deg", a.load_angle_deg.has_value(), ff, "feedforward"},
        {"--model-mass-scale", a.model_mass_scale.has_value(), ff, "feedforward"},
        {"--model-stiffness-scale", a.model_stiffness_scale.has_value(), ff, "feedforward"}};
    for (const auto& [flag, given_flag, used, users] : own) {
      if (given_flag && !used) {
        throw Error(fmt::format("{}: the {} controller does not use it (only {} do): expected "
                                "it left out",
                                flag, to_string(k), users));
      }
    }
    // The learned drag moves k I T gain into D each period: above 1 / T it overshoots in one
    // period.
    const double period = a.encoder_rate_hz ? 1.0 / *a.encoder_rate_hz : o.gains.period_s;
    if (a.drag_gain_per_s && *a.drag_gain_per_s > 1.0 / period) {
      throw Error(fmt::format("--drag-gain: {} /s: the learned drag would overshoot within one "
                              "control period of {} us: expected at most {} /s",
                              *a.drag_gain_per_s, period * 1e6, 1.0 / period));
    }
    if (a.load_angle_deg && !(*a.load_angle_deg > 0.0 && *a.load_angle_deg < 90.0)) {
      throw Error(fmt::format("--load-angle-deg: {} deg: the design load angle of the current "
                              "scaling must be below pull-out: expected (0, 90)",
                              *a.load_angle_deg));
    }
    for (const auto& [flag, v] : {std::pair{"--model-mass-scale", a.model_mass_scale},
                                  std::pair{"--model-stiffness-scale", a.model_stiffness_scale}}) {
      if (v && *v > 10.0) {
        throw Error(fmt::format("{}: {}: expected a model error factor in (0, 10]", flag, *v));
      }
    }
    // Gains far beyond any stable 10 kHz loop (the stability check below refuses what is
    // unstable; these bounds keep its arithmetic finite: 1e308 overflows the loop matrix).
    const std::tuple<const char*, const std::optional<double>*, double, const char*> gain_range[] = {
        {"--kp", &a.kp, 1e3, ""}, {"--ki", &a.ki_per_s, 1e7, " /s"},
        {"--kd", &a.kd_s, 10.0, " s"}, {"--alpha", &a.alpha_per_s, 1e4, " /s"}};
    for (const auto& [flag, v, hi, unit] : gain_range) {
      if (*v && **v > hi) {
        throw Error(fmt::format("{}: {}{}: far beyond any stable loop at the control rate: "
                                "expected at most {}{}",
                                flag, **v, unit, hi, unit));
      }
    }
    // Loads and backlash: what a printer's axis can meet, not 1e308.
    const std::tuple<const char*, const std::optional<double>*, double, const char*> phys[] = {
        {"--drag-n", &a.drag_force_n, 1e4, "N"},
        {"--bump-n", &a.bump_force_n, 1e4, "N"},
        {"--drag-n-s-per-m", &a.drag_n_s_per_m, 1e5, "N s/m"},
        {"--end-load-n-per-mm", &a.end_load_n_per_mm, 1e4, "N/mm"},
        {"--backlash-mm", &a.backlash_mm, 10.0, "mm"}};
    for (const auto& [flag, v, hi, unit] : phys) {
      if (*v && **v > hi) {
        throw Error(fmt::format("{}: {} {}: not a load or play a printer's axis meets: expected "
                                "at most {} {}",
                                flag, **v, unit, hi, unit));
      }
    }
  }
  if (a.run_current_a) require_positive("--run-current-a", *a.run_current_a);
  if (a.max_current_a) require_positive("--max-current-a", *a.max_current_a);
  if (a.model_mass_scale) require_positive("--model-mass-scale", *a.model_mass_scale);
  if (a.model_stiffness_scale) require_positive("--model-stiffness-scale", *a.model_stiffness_scale);
  if (!(a.corrupt_probability >= 0.0 && a.corrupt_probability <= 1.0)) {
    throw Error(fmt::format("--corrupt-probability: {}: expected a probability in [0, 1]",
                            a.corrupt_probability));
  }
  if (a.encoder_rate_hz) {
    const double rate = *a.encoder_rate_hz;
    // The AS5311's SSI: 18-bit frames at up to 1 MHz, plus chip-select time: 50 kHz at most.
    if (!(std::isfinite(rate) && rate > 0.0 && rate <= 50000.0)) {
      throw Error(fmt::format("--encoder-rate-hz: {} frames/s: the AS5311 reads 18-bit SSI "
                              "frames at a 1 MHz clock: expected a rate in (0, 50000]",
                              rate));
    }
    // The control period 1 / rate, a whole number of microseconds; the physics substep the
    // largest whole fraction of it not above 50 us.
    const double period_us = 1e6 / rate;
    if (std::abs(period_us - std::round(period_us)) > 1e-6 * period_us) {
      throw Error(fmt::format("--encoder-rate-hz: {} frames/s gives a control period of {} us: "
                              "expected a whole number of microseconds (50000, 40000, 25000, "
                              "20000, 12500, 10000, 8000, 5000, ... frames/s)",
                              rate, period_us));
    }
    o.gains.period_s = std::round(period_us) * 1e-6;
    o.substep_s = o.gains.period_s / std::ceil(o.gains.period_s / 50e-6 - 1e-9);
    // The encoder's latency: its internal sampling plus one frame.
    o.encoder.latency_s = o.gains.period_s;
  }
  if (a.encoder_resolution_um) {
    const double res = *a.encoder_resolution_um;
    if (!(std::isfinite(res) && res >= kAs5311ResolutionMm * 1e3 * (1.0 - 1e-9) &&
          res <= 0.25 * kAs5311PolePairMm * 1e3)) {
      throw Error(fmt::format("--encoder-resolution-um: {} um: the AS5311's frame carries 12 bits "
                              "per 2 mm pole pair: expected a count in [{:.4f}, 500] um",
                              res, kAs5311ResolutionMm * 1e3));
    }
    o.encoder.resolution_mm = res * 1e-3;
  }
  if (a.model_mass_scale) o.gains.ff_model_mass_scale = *a.model_mass_scale;
  if (a.model_stiffness_scale) o.gains.ff_model_stiffness_scale = *a.model_stiffness_scale;
  if (a.kp) o.gains.kp = o.gains.ff_kp = *a.kp;
  if (a.ki_per_s) o.gains.ki_per_s = o.gains.ff_ki_per_s = *a.ki_per_s;
  if (a.kd_s) o.gains.kd_s = o.gains.ff_kd_s = *a.kd_s;
  if (a.alpha_per_s) o.gains.alpha_per_s = *a.alpha_per_s;
  if (a.speed_change_mm_s) o.gains.max_speed_change_mm_s = *a.speed_change_mm_s;
  if (a.drag_gain_per_s) o.gains.ff_drag_gain_per_s = *a.drag_gain_per_s;
  if (a.load_angle_deg) o.gains.ff_load_angle_deg = *a.load_angle_deg;
  o.encoder.corrupt_probability = a.corrupt_probability;
  o.default_gains = !(a.kp || a.ki_per_s || a.kd_s || a.alpha_per_s);

  // The axes as they will be simulated: the scenario's or the machine's.
  ReversingStrokesScenario sc;
  std::vector<AxisSetup> axes;
  std::vector<kinematics::Motor> channels;
  std::vector<std::string> ignored;
  if (!a.scenario.empty()) {
    if (!a.file.empty()) throw Error("give either FILE or --scenario, not both");
    if (a.scenario != "reversing-strokes" && a.scenario != "seed003") {
      throw Error(fmt::format("--scenario: '{}': expected reversing-strokes", a.scenario));
    }
    sc.speed_mm_s = a.speed_mm_s;
    sc.load = a.load;
    if (a.drag_force_n) sc.drag_force_n = *a.drag_force_n;
    if (a.bump_force_n) sc.bump_force_n = *a.bump_force_n;
    if (a.end_load_n_per_mm) sc.end_load_n_per_mm = *a.end_load_n_per_mm;
    if (a.drag_n_s_per_m) sc.drag_n_s_per_m = *a.drag_n_s_per_m;
    if (a.backlash_mm) sc.backlash_mm = *a.backlash_mm;
    if (a.run_current_a) sc.run_current_a = *a.run_current_a;
    if (a.max_current_a) sc.max_current_a = *a.max_current_a;
    axes = reversing_strokes_axes(m, sc, nullptr);
  } else {
    if (a.file.empty()) throw Error("give a G-code FILE or --scenario reversing-strokes");
    if (a.run_current_a || a.max_current_a || a.backlash_mm || a.drag_force_n || a.bump_force_n ||
        a.end_load_n_per_mm || a.drag_n_s_per_m) {
      throw Error("--run-current-a, --max-current-a, --backlash-mm and the load flags apply to "
                  "--scenario only; for a file, set the machine's stepper_x.run_current, "
                  "stepper_x.backlash, ... (--set)");
    }
    const machine::Machine mm = with_default_drive_train(m, ignored);
    axes = machine_axes(mm);
    channels = xy_channels(mm);
  }
  // Refused before anything is simulated, each naming its flag and the limit: an encoder that
  // cannot resolve a step, a frame rate too low for the fastest move the machine allows, gains
  // that make the loop unstable.
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const AxisSetup& ax = axes[i];
    const double step = ax.mechanics.rotation_distance_mm /
                        (static_cast<double>(ax.motor.full_steps_per_rotation) * ax.drive.microsteps);
    if (is_feedback(o.controller) && o.encoder.resolution_mm > 0.5 * step * (1.0 + 1e-9)) {
      throw Error(fmt::format("--encoder-resolution-um: {} um is coarser than half a microstep of "
                              "axis {} ({:.3f} um): expected at most {:.3f} um (the controller must "
                              "tell one step from the next)",
                              o.encoder.resolution_mm * 1e3, ax.name, step * 1e3, 0.5 * step * 1e3));
    }
    if (is_feedback(o.controller)) {
      // The fastest the axis can move: the scenario's speed, or the machine's max_velocity
      // along the motor's row (a CoreXY motor turns at up to sqrt 2 times it on a diagonal).
      double vmax = sc.speed_mm_s;
      if (a.scenario.empty()) {
        const std::array<double, 4>& row = channels[i].row;
        vmax = m.max_velocity_mm_s * std::hypot(row[0], row[1]);
      }
      require_encoder_rate(ax, vmax, o.gains.period_s, "--encoder-rate-hz");
    }
    if (o.default_gains) continue;  // the defaults are fitted to each axis instead
    const StepperAxisModel model(ax.motor, ax.drive, ax.mechanics);
    ControllerParameters g = o.gains;
    g.latency_s = std::round(o.encoder.latency_s / g.period_s) * g.period_s;
    const double design = o.governor.max_load_angle_deg * std::numbers::pi / 180.0;
    for (double angle : {0.0, design}) {
      const LoopAnalysis la = analyse_loop(o.controller, g, model, angle);
      if (la.stable) continue;
      std::vector<std::string> flags, values;
      const bool pid_like = o.controller == ControllerKind::pid || o.controller == ControllerKind::feedforward;
      const ControllerParameters d;
      if (pid_like) {
        if (a.kp) flags.emplace_back("--kp");
        if (a.ki_per_s) flags.emplace_back("--ki");
        if (a.kd_s) flags.emplace_back("--kd");
        const bool ff = o.controller == ControllerKind::feedforward;
        values.push_back(fmt::format("kp {}, ki {} /s, kd {} s", ff ? g.ff_kp : g.kp,
                                     ff ? g.ff_ki_per_s : g.ki_per_s, ff ? g.ff_kd_s : g.kd_s));
        values.push_back(fmt::format("kp {}, ki {} /s, kd {} s", ff ? d.ff_kp : d.kp,
                                     ff ? d.ff_ki_per_s : d.ki_per_s, ff ? d.ff_kd_s : d.kd_s));
      } else {
        if (a.alpha_per_s) flags.emplace_back("--alpha");
      }
      if (a.encoder_rate_hz) flags.emplace_back("--encoder-rate-hz");
      if (!pid_like) {
        values.push_back(fmt::format("alpha {} /s", g.alpha_per_s));
        values.push_back(fmt::format("alpha {} /s", d.alpha_per_s));
      }
      throw Error(fmt::format(
          "{}: {} make the {} loop on axis {} unstable (spectral radius {:.4f} of the linearised "
          "loop at load angle {:.0f} deg, run current {:.2f} A, period {} us): expected a radius "
          "below 1; lower the gains (the defaults: {})",
          flags.empty() ? std::string("--controller") : fmt::format("{}", fmt::join(flags, ", ")),
          values[0], to_string(o.controller), ax.name, la.spectral_radius,
          angle * 180.0 / std::numbers::pi, ax.drive.current_amplitude_a, g.period_s * 1e6,
          values[1]));
    }
  }
  SimulationResult r;
  if (!a.scenario.empty()) {
    r = simulate_reversing_strokes(m, sc, o);
    if (a.scenario == "seed003") {
      r.notes.insert(r.notes.begin(), "--scenario seed003 is now 'reversing-strokes'; the old name "
                                      "goes in the next release");
    }
  } else {
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
  x["max_endpoint_error_mm"] = json_number(a.max_endpoint_error_mm);
  x["rms_endpoint_error_mm"] = json_number(a.rms_endpoint_error_mm);
  x["endpoints"] = a.endpoints;
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
  x["gain_scale"] = json_number(a.gain_scale);
  x["governor_limited_periods"] = a.governor_limited_periods;
  x["moves_checked"] = a.moves;
  x["degraded_moves"] = a.degraded_moves;
  x["first_degraded_line"] = a.first_degraded_line;
  x["accel_lead_dropped_moves"] = a.accel_lead_dropped_moves;
  x["load_limited_periods"] = a.load_limited_periods;
  x["slips_inferred"] = a.slips_inferred;
  x["lead_capped_periods"] = a.lead_capped_periods;
  x["rotor_capped_periods"] = a.rotor_capped_periods;
  if (a.fall_back_time_s >= 0.0) x["fall_back_time_s"] = json_number(a.fall_back_time_s);
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
