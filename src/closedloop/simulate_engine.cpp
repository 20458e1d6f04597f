// The closed-loop simulator's engine (ClosedLoopSimulator): the axes' physics, encoders,
// controllers and the command governor, period by period (docs/closedloop.md, section 4).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"

namespace amctl::closedloop {

void SimulationOptions::validate() const {
  gains.validate();
  encoder.validate();
  governor.validate();
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
    for (const AxisSetup& a : axes) h += fmt::format(",{}_path_error_mm", a.name);
    h += "\n";
    out_.write(h);
  }
  void write(const std::string& row) { out_.write(row); }
  void commit() { out_.commit(); }

 private:
  OutputFile out_;
};

const char* reason_text(DegradeReason r) {
  switch (r) {
    case DegradeReason::torque: return "the plan leaves the motor no torque margin";
    case DegradeReason::speed: return "the plan runs faster than the motor can be corrected at";
    case DegradeReason::jump: return "the plan's speed jumps at the move's start by more than the rotor absorbs";
    case DegradeReason::none: break;
  }
  return "";
}

struct AxisRun {
  AxisRun(const AxisSetup& a, const StepperAxisModel& m, double start_mm, const EncoderParameters& ep)
      : setup(a), model(m), state(m.rest_state(start_mm)), encoder(ep, start_mm) {}
  AxisSetup setup;
  StepperAxisModel model;
  MotorState state;
  std::unique_ptr<Controller> controller;
  As5311Encoder encoder;
  std::optional<CommandGovernor> governor;
  std::optional<RotorObserver> observer;  // the rotor's dynamic bound (governed runs)
  bool observer_lost = false;             // the bound stopped (see tick)
  double rotor_hold_until_s = -1.0, rotor_hold_s = 0.0;       // degraded until then: the bound held the command
  CommandLimiter limiter;
  MoveLimits limits;
  std::uint64_t move = static_cast<std::uint64_t>(-1);
  SubstepCoefficients coeffs;
  double command_mm = 0.0;
  // The head and the reference at the last latency_ticks + 1 periods (a ring; latency).
  std::vector<double> x_hist, ref_hist;
  std::size_t hist_at = 0;
  std::int64_t last_slip = 0;
  double err2 = 0.0, path2 = 0.0, current_sum = 0.0;
  std::uint64_t samples = 0, steps_last = 0;
  double period_v = 0.0;      // command speed over the present period [mm/s]
  double last_v = 0.0;        // over the previous one
  bool limited = false;       // the governor held the last command short
  bool sequenced = false;     // the controller follows its own command sequence
  // The slip guard: the largest lead of the command over the encoder without a slip, one
  // electrical cycle of travel, the loss taken out of the controller's view and its recovery.
  double hold_lead_mm = 0.0, cycle_mm = 0.0, latency_s = 0.0, recover_mm_s = 1.0;
  double slip_offset = 0.0;
  std::uint64_t slip_degraded_move = static_cast<std::uint64_t>(-1);
  // A slip on a move the governor found feasible: the machine is not the one the analysis
  // assumed (a load, a motor or a dynamic it does not know); from then on every move is
  // degraded, the axis runs open loop's command for the rest of the print.
  bool fall_back = false;
  double measured_now = 0.0, err_now = 0.0, x_now = 0.0, path_now = 0.0;
  // Endpoint errors: the move (or command count) last seen and its segment.
  std::uint64_t endpoint_move = static_cast<std::uint64_t>(-1), reached_seen = 0, endpoints = 0;
  double endpoint_from = 0.0, endpoint_to = 0.0, endpoint2 = 0.0;
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
  bool feedback = false;  // the controller reads the encoder
};

ClosedLoopSimulator::ClosedLoopSimulator(std::vector<AxisSetup> axes,
                                         const SimulationOptions& options,
                                         std::span<const double> start_mm)
    : impl_(std::make_unique<Impl>()) {
  options.validate();
  AMCTL_CHECK(start_mm.size() == axes.size(), "one start position per axis");
  Impl& s = *impl_;
  s.opt = options;
  s.feedback = is_feedback(options.controller);
  s.substeps_per_tick = static_cast<int>(std::lround(options.gains.period_s / options.substep_s));
  s.latency_ticks = static_cast<int>(std::lround(options.encoder.latency_s / options.gains.period_s));
  s.csv_every = std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(std::llround(1.0 / (options.csv_rate_hz * options.gains.period_s))));
  ControllerParameters gains = options.gains;
  gains.latency_s = s.latency_ticks * options.gains.period_s;
  s.runs.reserve(axes.size());
  for (std::size_t i = 0; i < axes.size(); ++i) {
    StepperAxisModel model(axes[i].motor, axes[i].drive, axes[i].mechanics);
    const double design = options.governor.max_load_angle_deg * std::numbers::pi / 180.0;
    ControllerParameters axis_gains = gains;
    double scale = 1.0;
    if (options.default_gains && is_feedback(options.controller)) {
      axis_gains = fit_default_gains(options.controller, gains, model, design, scale);
    }
    require_stable_loop(options.controller, axis_gains, model, axes[i].name, design);
    EncoderParameters ep = options.encoder;
    ep.seed = options.encoder.seed + i;
    AxisRun run(axes[i], model, start_mm[i], ep);
    run.controller = make_controller(options.controller, axis_gains, run.model, start_mm[i]);
    run.res.gain_scale = scale;
    if (is_feedback(options.controller) && options.governor.enabled) {
      // The largest current the controller runs: feedforward scales up to the drive's
      // maximum, the others stay at the run current.
      const double current = options.controller == ControllerKind::feedforward
                                 ? std::max(run.model.max_current_a(), axes[i].drive.current_amplitude_a)
                                 : axes[i].drive.current_amplitude_a;
      run.governor.emplace(run.model, options.governor, current);
      run.limits = run.governor->limits(0.0, 0.0);
      run.rotor_hold_s = options.governor.rotor_hold_s;
      run.observer.emplace(run.model, options.governor.rotor_angle_limit_deg, start_mm[i]);
    }
    run.coeffs = run.model.substep(options.substep_s);
    run.sequenced = run.controller->sequenced();
    {
      const double r_m = run.model.pulley_radius_m(), p = run.model.motor().pole_pairs();
      const double po = run.model.pull_out_torque_at_n_m(0.0, run.model.max_current_a());
      run.cycle_mm = 1e3 * r_m * 2.0 * std::numbers::pi / p;
      run.hold_lead_mm = 1e3 * (po / r_m) / axes[i].mechanics.belt.stiffness_n_per_m +
                         0.5 * run.cycle_mm + 0.5 * axes[i].mechanics.backlash_mm + 0.02;
      run.latency_s = gains.latency_s + options.gains.period_s;
    }
    run.command_mm = static_cast<double>(run.state.microstep) * run.model.step_distance_mm();
    run.limiter.reset(run.command_mm - start_mm[i]);
    run.x_hist.assign(static_cast<std::size_t>(s.latency_ticks) + 1, start_mm[i]);
    run.ref_hist.assign(static_cast<std::size_t>(s.latency_ticks) + 1, start_mm[i]);
    run.res.name = axes[i].name;
    run.res.pull_out_torque_n_m = run.model.pull_out_torque_n_m();
    run.res.motor_name = axes[i].motor_name;
    run.res.motor_source = axes[i].motor_source;
    run.res.motor = axes[i].motor;
    run.res.drive = axes[i].drive;
    run.res.mechanics = axes[i].mechanics;
    run.res.max_current_a = run.model.max_current_a();
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

void ClosedLoopSimulator::push_command(std::size_t axis, const AxisCommand& c) {
  impl_->runs.at(axis).controller->push_command(c);
}

bool ClosedLoopSimulator::finished() const {
  for (const AxisRun& r : impl_->runs) {
    if (!r.controller->finished()) return false;
  }
  return true;
}

namespace {

// Distance of x from the segment [a, b] (either order).
double segment_distance(double x, double a, double b) {
  const double lo = std::min(a, b), hi = std::max(a, b);
  return x < lo ? lo - x : (x > hi ? x - hi : 0.0);
}

void add_endpoint(AxisRun& r, double e) {
  r.endpoint2 += e * e;
  ++r.endpoints;
  r.res.max_endpoint_error_mm = std::max(r.res.max_endpoint_error_mm, e);
}

// The governor's verdict on a move starting now, counted.
void enter_move(AxisRun& r, const RefSample& ref) {
  r.move = ref.move;
  r.limits = r.governor->limits(ref.move_speed_mm_s, ref.move_accel_mm_s2, ref.move_jump_mm_s);

  if (ref.move == 0 || (ref.move_speed_mm_s == 0.0 && ref.move_accel_mm_s2 == 0.0)) return;
  ++r.res.moves;
  if (!r.limits.feasible) {
    if (r.res.degraded_moves++ == 0) {
      r.res.first_degraded_line = ref.line;
      r.res.first_degraded_reason = fmt::format(
          "{} (needs {:.3f} N m at {:.0f} mm/s and {:.0f} mm/s^2; pull-out {:.3f} N m, design "
          "angle {:.0f} deg)",
          reason_text(r.governor->reason(r.limits, ref.move_speed_mm_s, ref.move_jump_mm_s)),
          r.limits.plan_torque_n_m,
          ref.move_speed_mm_s, ref.move_accel_mm_s2, r.limits.pull_out_n_m,
          r.governor->parameters().max_load_angle_deg);
    }
  } else if (!r.limits.accel_lead && ref.move_accel_mm_s2 > 0.0) {
    ++r.res.accel_lead_dropped_moves;
  }
}

// enter_move, then the fall-back: after a slip on a feasible move every move runs degraded.
void enter_move_checked(AxisRun& r, const RefSample& ref) {
  enter_move(r, ref);
  if (r.fall_back) {
    r.limits.feasible = false;
    r.limits.accel_lead = false;
    r.limits.max_feedback_mm = 0.0;
  }
}

// The machine could not follow (the rotor's dynamic bound held the command): degrade until
// `hold_until_s`, the correction brought back to open loop's command within the budgets.
void degrade_now(AxisRun& r) {
  r.limits.feasible = false;
  r.limits.accel_lead = false;
  r.limits.max_feedback_mm = 0.0;
}

}  // namespace

void ClosedLoopSimulator::tick(std::span<const RefSample> now, std::span<const RefSample> next) {
  Impl& s = *impl_;
  const double T = s.opt.gains.period_s, h = s.opt.substep_s;
  const double t = time_s();
  const bool write_row = s.csv && (s.ticks % s.csv_every == 0);
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
    // Path error: the distance from the segment of the command under way on this axis.
    const auto seg = r.sequenced ? r.controller->active_segment() : std::nullopt;
    const double path = seg ? segment_distance(x, seg->first, seg->second)
                            : segment_distance(x, now[i].seg_from_mm, now[i].seg_to_mm);
    r.path2 += path * path;
    if (path > r.res.max_path_error_mm) {
      r.res.max_path_error_mm = path;
      r.res.max_path_error_time_s = t;
    }
    // Endpoint error: where the axis is when a command of its sequence ends, against the point
    // it commanded (time-referenced controllers: at the plan's end of the move; the sequenced
    // law: when its position judgement moves on).
    if (seg) {
      const std::uint64_t reached = r.controller->commands_reached();
      if (reached != r.reached_seen) {
        r.reached_seen = reached;
        add_endpoint(r, std::abs(x - seg->first));
      }
    } else if (now[i].move != r.endpoint_move) {
      if (r.endpoint_move != static_cast<std::uint64_t>(-1) && r.endpoint_to != r.endpoint_from) {
        add_endpoint(r, std::abs(x - r.endpoint_to));
      }
      r.endpoint_move = now[i].move;
      r.endpoint_from = now[i].seg_from_mm;
      r.endpoint_to = now[i].seg_to_mm;
    }
    // The ring holds latency_ticks + 1 periods: the slot after the one written now was
    // written latency_ticks periods ago.
    const std::size_t ring = r.x_hist.size();
    r.x_hist[r.hist_at] = x;
    r.ref_hist[r.hist_at] = now[i].pos_mm;
    if (s.ticks == 0) {
      std::fill(r.x_hist.begin(), r.x_hist.end(), x);
      std::fill(r.ref_hist.begin(), r.ref_hist.end(), now[i].pos_mm);
    }
    r.hist_at = (r.hist_at + 1) % ring;
    // Open loop reads no encoder (only its trace shows one).
    const double measured = (s.feedback || s.csv) ? r.encoder.read(r.x_hist[r.hist_at]) : r.x_hist[r.hist_at];
    const bool sequenced = r.sequenced;
    if (r.governor && !sequenced && now[i].move != r.move) enter_move_checked(r, now[i]);
    if (r.governor && !sequenced && t < r.rotor_hold_until_s && r.limits.feasible) degrade_now(r);
    // The slip guard: a lead of the command over the encoder larger than the belt and the rotor
    // can hold (the belt stretched at the pull-out force, the rotor at 180 deg, the backlash,
    // the latency's motion) means the rotor has slipped a whole electrical cycle. The loss is
    // taken into the controller's view of the encoder (as open loop would keep it) and given
    // back at most `recover_mm_s`; the move is degraded (the correction returns to 0), so a
    // slip never sets the feedback against the motor.
    if (r.governor && !sequenced) {
      const double lead = r.command_mm - (measured + r.slip_offset);
      if (std::abs(lead) > r.hold_lead_mm + std::abs(now[i].vel_mm_s) * r.latency_s) {
        const double cycles = std::round(lead / r.cycle_mm);
        r.slip_offset += (cycles != 0.0 ? cycles : std::copysign(1.0, lead)) * r.cycle_mm;
        ++r.res.slips_inferred;
        if (r.limits.feasible && !r.fall_back) {
          r.fall_back = true;
          r.res.fall_back_time_s = t;
        }
        r.slip_degraded_move = now[i].move;
        r.limits.feasible = false;
        r.limits.accel_lead = false;
        r.limits.max_feedback_mm = 0.0;
      }
      const double back = r.recover_mm_s * T;
      r.slip_offset = std::clamp(0.0, r.slip_offset - back, r.slip_offset + back);
    }
    ControlInput in;
    in.t_s = t;
    in.ref_mm = now[i].pos_mm;
    in.ref_vel_mm_s = now[i].vel_mm_s;
    in.ref_acc_mm_s2 = now[i].acc_mm_s2;
    in.next_ref_mm = next[i].pos_mm;
    in.next_vel_mm_s = next[i].vel_mm_s;
    in.next_acc_mm_s2 = next[i].acc_mm_s2;
    in.measured_ref_mm = r.ref_hist[r.hist_at];
    in.measured_mm = measured + r.slip_offset;
    in.command_mm = r.command_mm;
    in.command_speed_mm_s = r.period_v;
    in.steps_since_last = r.steps_last;
    in.limits = (r.governor && !sequenced) ? &r.limits : nullptr;
    in.limited = r.limited;
    const double target = r.controller->target_mm(in);
    const double current = r.controller->current_request_a();
    if (current > 0.0 && current != r.state.current_a) r.model.set_current(r.state, current);
    r.res.peak_current_a = std::max(r.res.peak_current_a, r.state.current_a);
    r.current_sum += r.state.current_a;
    // The governor: what the motor can follow.
    double v = (target - r.command_mm) / T;
    r.limited = false;
    if (r.governor && sequenced) {
      // A law that follows its own sequence: its command's acceleration and speed.
      const double a = r.governor->axis_accel_limit_mm_s2(r.period_v);
      const double vmax_c = r.governor->max_command_speed_mm_s();
      const double lim = std::clamp(std::clamp(v, r.period_v - a * T, r.period_v + a * T), -vmax_c, vmax_c);
      if (lim != v) r.limited = true;
      v = lim;
    } else if (r.governor) {
      const double lead = r.controller->lead_mm();
      // The move's limits, narrowed by the load the motor is measured to carry now, for a
      // controller that runs at a fixed current (one that scales its current to the load,
      // feedforward, keeps the margin that way: the move's figures at its largest current).
      const MoveLimits lim = current > 0.0 ? r.limits
                                           : r.governor->with_measured_load(r.limits, r.command_mm - measured,
                                                                            r.state.current_a);
      if (lim.free_step_mm < r.limits.free_step_mm) ++r.res.load_limited_periods;
      const CommandLimiter::Out o = r.limiter.next(lead, target - next[i].pos_mm - lead,
                                                   (next[i].pos_mm - now[i].pos_mm) / T, lim, T);
      r.limited = o.feedback_limited;
      // The lead cap: the command never leads the carriage by more than the rotor and the belt
      // hold at the design angle (at this speed and this period's current), the carriage
      // estimated at the period's end (the encoder's latency at the plan's speed). Open loop's
      // own command stays allowed: the cap never makes the command lead more than the plan's.
      // It is centred on the carriage, not on a count of slipped cycles: a lead of a whole
      // cycle (to win back a slip) is indistinguishable from a stretch the rotor cannot hold
      // when the belt's stretch at pull-out exceeds half a cycle, so a slipped axis keeps open
      // loop's offset rather than risk a second slip.
      double c = next[i].pos_mm + o.correction_mm;
      const double y_end = measured + now[i].vel_mm_s * r.latency_s;
      const double cap = r.governor->max_lead_mm(next[i].vel_mm_s, r.state.current_a);
      const double c_cap = std::clamp(c, std::min(y_end - cap, next[i].pos_mm),
                                      std::max(y_end + cap, next[i].pos_mm));
      if (c_cap != c) {
        r.limiter.take_back(c_cap - c);
        r.limited = true;
        ++r.res.lead_capped_periods;
        c = c_cap;
      }
      v = (c - r.command_mm) / T;
    }
    const double step = r.model.step_distance_mm();
    const double vmax = r.setup.drive.max_step_rate_hz * step;
    if (std::abs(v) > vmax) {
      v = std::copysign(vmax, v);
      ++r.res.step_rate_limited_periods;
    }
    if (r.observer && r.res.slips_inferred == 0 && !r.observer_lost) {
      // The rotor's dynamic bound: the command stays within (r / p) d_max - s / 2 of the rotor
      // the observer predicts at the period's end (inertia, belt and feedback all in it).
      const double y_mid = measured + now[i].vel_mm_s * (r.latency_s - 0.5 * T);
      const double c0 = r.command_mm;
      double c1 = c0 + v * T;
      RotorObserver::Prediction pr =
          r.observer->predict(c0, c1, y_mid, now[i].vel_mm_s, r.state.current_a, T);
      const double lim = r.observer->max_lead_mm();
      double cc = std::clamp(c1, pr.q_mm - lim, pr.q_mm + lim);
      if (cc != c1 && std::abs(cc - next[i].pos_mm) > 4.0 * r.hold_lead_mm) {
        // Held further from the plan than four times any lead belt and rotor hold: the
        // observer has lost the rotor (a slip the guard did not see, a rotor the model cannot
        // drive at this speed). The bound stops on this axis; open loop's command is kept.
        r.observer_lost = true;
        cc = c1;
      }
      if (cc != c1) {
        if (!sequenced) r.limiter.take_back(cc - c1);
        r.limited = true;
        ++r.res.rotor_capped_periods;
        if (!sequenced) {
          r.rotor_hold_until_s = t + r.rotor_hold_s;
          degrade_now(r);
        }
        c1 = cc;
        pr = r.observer->predict(c0, c1, y_mid, now[i].vel_mm_s, r.state.current_a, T);
        v = (c1 - c0) / T;
      }
      r.observer->commit(pr);
    }
    // After a slip the observer has lost the rotor (the plant slipped where the model did not,
    // or differently): the bound would hold the command to a rotor that is not there, so it
    // stops, and the fall-back (section 3.1) runs open loop's command.
    if (r.limited) ++r.res.governor_limited_periods;
    r.res.peak_step_rate_hz = std::max(r.res.peak_step_rate_hz, std::abs(v) / step);
    r.period_v = v;
    r.measured_now = measured;
    r.err_now = err;
    r.x_now = x;
    r.path_now = path;
  }
  // The physics of every axis, substep by substep with the axes interleaved (independent
  // dependency chains side by side).
  // sin, cos of the electrical angle: recomputed exactly every 16 periods, rotated by
  // advance() in between (the rotation's error, below 1e-15 a substep, stays below 1e-13).
  const bool sync = (s.ticks & 15u) == 0;
  for (AxisRun& r : s.runs) {
    if (sync) r.model.sync_angle(r.state);
    r.steps_last = 0;
  }
  for (int j = 0; j < s.substeps_per_tick; ++j) {
    for (AxisRun& r : s.runs) {
      const double step = r.model.step_distance_mm();
      const double c0 = r.command_mm;
      r.command_mm += r.period_v * h;
      // Klipper's half-step rule: step n -> n +- 1 when the command crosses (n +- 1/2) s.
      std::int64_t n = r.state.microstep;
      const std::int64_t n0 = n;
      while (r.command_mm >= (static_cast<double>(n) + 0.5) * step) ++n;
      while (r.command_mm < (static_cast<double>(n) - 0.5) * step) --n;
      if (n != n0) {
        // The steps land inside the substep: its current reference is the time-weighted mean
        // of the microsteps it held, then the last one.
        r.steps_last += static_cast<std::uint64_t>(std::llabs(n - n0));
        r.model.set_microstep_path(r.state, n0, n, c0, r.command_mm);
        r.model.advance(r.state, r.coeffs);
        r.model.set_microstep(r.state, n);
      } else {
        r.model.advance(r.state, r.coeffs);
      }
    }
  }
  std::string row;
  if (write_row) row = fmt::format("{:.6f}", t);
  for (std::size_t i = 0; i < s.runs.size(); ++i) {
    AxisRun& r = s.runs[i];
    r.res.steps += r.steps_last;
    const double angle = r.model.load_angle_rad(r.state);
    const auto slip = static_cast<std::int64_t>(std::floor(angle * (0.5 / std::numbers::pi) + 0.5));
    if (slip != r.last_slip) {
      const auto cycles = static_cast<std::uint64_t>(std::llabs(slip - r.last_slip));
      r.res.slip_events += cycles;
      r.res.lost_full_steps += 4 * cycles;
      r.res.lost_steps += cycles * static_cast<std::uint64_t>(r.model.microsteps_per_cycle());
      r.last_slip = slip;
    }
    const double d = angle - 2.0 * std::numbers::pi * static_cast<double>(slip);
    r.res.max_load_angle_deg = std::max(r.res.max_load_angle_deg, std::abs(d) * 180.0 / std::numbers::pi);
    if (write_row) {
      row += fmt::format(",{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.3f},{}", now[i].pos_mm, r.x_now,
                         r.err_now, r.command_mm, r.measured_now, d * 180.0 / std::numbers::pi,
                         r.res.lost_steps);
    }
  }
  if (write_row) {
    for (const AxisRun& r : s.runs) row += fmt::format(",{:.6f}", r.path_now);
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
    const double n = static_cast<double>(r.samples);
    a.rms_tracking_error_mm = r.samples ? std::sqrt(r.err2 / n) : 0.0;
    a.rms_path_error_mm = r.samples ? std::sqrt(r.path2 / n) : 0.0;
    a.rms_endpoint_error_mm = r.endpoints ? std::sqrt(r.endpoint2 / static_cast<double>(r.endpoints)) : 0.0;
    a.endpoints = r.endpoints;
    a.mean_current_a = r.samples ? r.current_sum / n : 0.0;
    a.encoder_rejected_frames = r.encoder.rejected_frames();
    a.commands_reached = r.controller->commands_reached();
    a.commands_left = r.controller->commands_pending();
    out.axes.push_back(a);
  }
  if (s.csv) {
    s.csv->commit();
    s.csv.reset();
  }
  return out;
}

}  // namespace amctl::closedloop
