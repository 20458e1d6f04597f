#pragma once
// The closed-loop stepper simulator (docs/closedloop.md, section 4): every axis's motor and
// drive (StepperAxisModel), its AS5311 encoder and its controller, stepped together. Each
// control period T the controller reads the encoder (latency rounded to whole periods) and
// sets a target for the motor command; the command governor (governor.hpp) limits it to what
// the motor can follow; the command ramps there over the period and is quantised into
// microsteps with Klipper's half-step rule; the physics is integrated with a fixed substep h
// (T / h whole). Two errors are sampled at every control period: the tracking error
// (carriage - the time-based reference) and the path error (the carriage's distance from the
// segment, on this axis, of the command under way: the move at that time, or for the
// encoder-sequenced law the command it is executing).
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "amctl/closedloop/controller.hpp"
#include "amctl/closedloop/encoder.hpp"
#include "amctl/closedloop/motor.hpp"
#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planned_move.hpp"

namespace amctl::closedloop {

/// One simulated axis (one motor).
struct AxisSetup {
  std::string name;  ///< "x", "y"
  MotorParameters motor;
  DriveParameters drive;
  AxisMechanics mechanics;
  /// Which motor that is: the preset name ("17hs4401"), and where it came from ("the
  /// machine's stepper_x.motor", "the default: the machine names no motor", ...).
  std::string motor_name = "17hs4401";
  std::string motor_source = "the default: the machine names no motor";
};

struct SimulationOptions {
  ControllerKind controller = ControllerKind::open;
  ControllerParameters gains;
  EncoderParameters encoder;
  GovernorParameters governor;
  /// The gains are the defaults (not the user's): fitted to each axis (fit_default_gains) where
  /// they would make its loop unstable, and said so in the notes; the user's are refused.
  bool default_gains = true;
  double substep_s = 50e-6;   ///< physics step h; control period / h must be whole
  double settle_s = 0.05;     ///< simulated past the end of the reference
  std::string csv_path;       ///< traces, "" = none
  double csv_rate_hz = 1000.0;
  void validate() const;
};

/// The reference of one axis at one time, and the move under way.
struct RefSample {
  double pos_mm = 0.0, vel_mm_s = 0.0, acc_mm_s2 = 0.0;
  std::uint64_t move = 0;              ///< changes when a new move starts (0: none, holding)
  double move_speed_mm_s = 0.0;        ///< the move's peak speed along this axis
  double move_accel_mm_s2 = 0.0;       ///< the move's acceleration along this axis
  double move_jump_mm_s = 0.0;         ///< the step of this axis's speed where the move starts
  double seg_from_mm = 0.0, seg_to_mm = 0.0;  ///< the move's start and end on this axis
  std::uint64_t line = 0;              ///< its G-code line
};

/// Per-axis outcome.
struct AxisResult {
  std::string name;
  double max_tracking_error_mm = 0.0;
  double max_error_time_s = 0.0;
  double rms_tracking_error_mm = 0.0;
  double final_error_mm = 0.0;
  std::uint64_t lost_steps = 0;        ///< microsteps slipped (4 x microsteps per cycle)
  std::uint64_t lost_full_steps = 0;   ///< 4 per electrical cycle slipped
  std::uint64_t slip_events = 0;       ///< electrical cycles slipped
  double max_load_angle_deg = 0.0;     ///< largest |load angle| not counting whole slips
  std::uint64_t steps = 0;             ///< microsteps commanded
  double peak_step_rate_hz = 0.0;      ///< of the command, over a control period
  std::uint64_t step_rate_limited_periods = 0;  ///< periods clipped to drive.max_step_rate_hz
  std::uint64_t encoder_rejected_frames = 0;
  double pull_out_torque_n_m = 0.0;    ///< static, Kt I at the run current
  double peak_current_a = 0.0;         ///< largest commanded current amplitude
  double mean_current_a = 0.0;         ///< mean commanded current amplitude (heating)
  double gain_scale = 1.0;             ///< the default gains' factor on this axis (1: as documented)
  double max_path_error_mm = 0.0;      ///< distance from the command's segment on this axis
  double max_path_error_time_s = 0.0;
  double rms_path_error_mm = 0.0;
  /// Where the axis is when each command of its sequence ends, against the point commanded
  /// (time-referenced controllers: at the plan's end of the move; encoder-sequenced: when its
  /// position judgement moves on): max and rms over the commands that move this axis.
  double max_endpoint_error_mm = 0.0, rms_endpoint_error_mm = 0.0;
  std::uint64_t endpoints = 0;
  /// The governor: periods whose command it held short of the controller's, moves it
  /// degraded to open loop (the plan leaves no torque margin, or runs faster than the motor
  /// can be corrected at), the first such move's line and why, and moves whose acceleration
  /// lead it dropped (it would ring the belt).
  std::uint64_t governor_limited_periods = 0;
  std::uint64_t degraded_moves = 0;
  std::uint64_t first_degraded_line = 0;
  std::string first_degraded_reason;
  std::uint64_t accel_lead_dropped_moves = 0;
  /// Periods whose correction limits the load the motor was measured to carry narrowed (a
  /// load the model does not know).
  std::uint64_t load_limited_periods = 0;
  /// Slips the governor inferred from the encoder (a lead over it no belt and rotor can hold):
  /// each degraded the move and took the lost cycle out of the controller's view, given back
  /// at 1 mm/s.
  std::uint64_t slips_inferred = 0;
  /// Periods in which the lead cap held the command back (its lead over the carriage at what
  /// the rotor and the belt hold at the design angle).
  std::uint64_t lead_capped_periods = 0;
  /// Periods the rotor's dynamic bound (RotorObserver) held the command to the rotor.
  std::uint64_t rotor_capped_periods = 0;
  /// When the axis fell back to open loop's command for the rest of the run (a slip on a move
  /// the governor found feasible); negative: never.
  double fall_back_time_s = -1.0;
  std::uint64_t moves = 0;             ///< moves of this axis checked by the governor
  std::uint64_t commands_reached = 0;  ///< encoder-sequenced: commands of the sequence reached
  std::uint64_t commands_left = 0;     ///< encoder-sequenced: commands not reached at the end
  // The motor, drive and axis simulated (the assumed motor is printed).
  std::string motor_name, motor_source;
  MotorParameters motor;
  DriveParameters drive;
  AxisMechanics mechanics;
  double max_current_a = 0.0;          ///< the largest current a controller may request
};

struct SimulationResult {
  std::string source;                  ///< file name or "scenario reversing-strokes"
  std::string controller;
  std::vector<std::string> notes;      ///< what the user should know (aliases, defaults, ...)
  double speed_mm_s = 0.0;             ///< scenario speed (0 for a file)
  bool load = false;
  double duration_s = 0.0;             ///< simulated time
  std::uint64_t substeps = 0;
  std::vector<AxisResult> axes;
};

/// The engine: owns the axes' states, controllers and encoders.
class ClosedLoopSimulator {
 public:
  /// Validates everything and checks the loop's stability on every axis (amctl::Error).
  ClosedLoopSimulator(std::vector<AxisSetup> axes, const SimulationOptions& options,
                      std::span<const double> start_mm);
  ~ClosedLoopSimulator();
  ClosedLoopSimulator(const ClosedLoopSimulator&) = delete;
  ClosedLoopSimulator& operator=(const ClosedLoopSimulator&) = delete;

  /// One control period from time() to time() + T: `now` holds the reference of each axis at
  /// time(), `next` at time() + T.
  void tick(std::span<const RefSample> now, std::span<const RefSample> next);
  /// The next command of axis i's own command sequence (the encoder-sequenced law; other
  /// controllers ignore it). Commands come in the plan's order, ahead of the ticks.
  void push_command(std::size_t axis, const AxisCommand& c);
  /// Every axis's controller has reached its last command and stopped (always true for the
  /// time-referenced controllers).
  [[nodiscard]] bool finished() const;
  [[nodiscard]] double time_s() const;
  [[nodiscard]] double period_s() const;
  [[nodiscard]] std::size_t axes() const;
  /// The results; writes the CSV's last rows and renames it into place. Call once, at the end.
  [[nodiscard]] SimulationResult finish();
  /// The model of axis i (tests).
  [[nodiscard]] const StepperAxisModel& model(std::size_t i) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The closed-loop stepper paper's experiment: each axis (x, then y, run side by side) goes
/// 0 -> -30 mm -> 0 three times at `speed_mm_s` with the machine's max_accel; `load` adds the
/// drag that makes open loop lose steps near the reversals (docs/closedloop.md, section 4).
/// The scenario's name is "reversing-strokes" ("seed003" is accepted for one release).
struct ReversingStrokesScenario {
  double speed_mm_s = 90.0;
  bool load = true;
  double stroke_mm = 30.0;
  int strokes = 6;
  /// The load: a drag opposing motion that grows with speed (a nozzle ploughing through an
  /// over-extruded, curled layer; a stiff cable chain), drag_force_n + drag_n_s_per_m v.
  double drag_force_n = 12.0;
  double drag_n_s_per_m = 150.0;
  double end_load_n_per_mm = 0.0;   ///< a cable pulled taut near the -30 mm end [N/mm]
  double end_load_start_mm = -25.0;
  /// A curled edge scraped just before the reversal at -30 mm: drag bump_force_n within
  /// +-bump_half_width_mm of bump_position_mm (0 = none; a sudden load no controller acting
  /// through the belt can follow, docs/closedloop.md).
  double bump_force_n = 0.0;
  double bump_position_mm = -29.0;
  double bump_half_width_mm = 0.3;
  /// The paper's printer class where the machine's [stepper_x|y] give no run_current,
  /// supply_voltage or backlash: Klipper run_current 0.8 A RMS (phase current amplitude
  /// sqrt(2) 0.8 = 1.13 A), 12 V, 0.05 mm of lost motion at each reversal of the belt force.
  double default_run_current_a = 0.8;   ///< RMS, as Klipper's run_current
  double default_supply_voltage_v = 12.0;
  double default_backlash_mm = 0.05;
  /// Overrides of both the machine and the defaults (the CLI's flags) [A RMS, V, mm].
  std::optional<double> run_current_a, supply_voltage_v, backlash_mm;
  double max_current_a = 0.0;     ///< closed-loop boost limit, amplitude [A]; 0 = the motor's rated
  double x_mass_kg = 0.5;         ///< X carriage
  double y_mass_kg = 0.8;         ///< Y (a bed slinger's bed)
};
using Seed003Scenario = ReversingStrokesScenario;  ///< the old name, for one release

/// The axes of a machine ([stepper_x], [stepper_y]: rotation_distance, microsteps,
/// full_steps_per_rotation, the motor preset and the motor keys; the default motor, drive
/// and belt otherwise). Throws amctl::Error naming a missing section, a bad parameter, a run
/// current above the motor's rating or a motor whose step angle the section contradicts.
[[nodiscard]] std::vector<AxisSetup> machine_axes(const machine::Machine& m);

/// The scenario. A machine without [stepper_x] / [stepper_y] (the default preset) runs on the
/// default drive train (rotation_distance 40, 16 microsteps) and says so in the notes.
[[nodiscard]] SimulationResult simulate_reversing_strokes(const machine::Machine& m,
                                                          const ReversingStrokesScenario& scenario,
                                                          const SimulationOptions& options);
[[deprecated("simulate_reversing_strokes")]] inline SimulationResult simulate_seed003(
    const machine::Machine& m, const ReversingStrokesScenario& scenario,
    const SimulationOptions& options) {
  return simulate_reversing_strokes(m, scenario, options);
}
/// A G-code file's plan through the closed loop (PlanSource -> sink; memory: one batch).
/// CoreXY: the motors (A, B) are simulated, each pulling its own belt.
[[nodiscard]] SimulationResult simulate_file(const std::string& gcode_path,
                                             const machine::Machine& m,
                                             const SimulationOptions& options);

/// Planned moves (time-ordered, e.g. a benchmark's synthetic print) through the closed loop,
/// as simulate_file does with the batches of a file.
[[nodiscard]] SimulationResult simulate_moves(std::span<const plan::PlannedMove> moves,
                                              const machine::Machine& m,
                                              const SimulationOptions& options);

/// What `amctl stepper simulate` asks for (the CLI and the Python binding fill it).
struct SimulateRequest {
  std::string file;             ///< G-code file, or "" with scenario
  std::string scenario;         ///< "reversing-strokes" (alias "seed003") or ""
  std::string controller = "open";
  double speed_mm_s = 90.0;
  bool load = true;
  std::string csv_path;
  /// Overrides (unset: default; a negative or non-finite value is an error naming the flag):
  /// kp and ki/kd apply to pid and best, alpha to seed003, drag_gain and load_angle to best;
  /// the load, backlash and currents to the scenario (run_current RMS, max_current peak).
  std::optional<double> kp, ki_per_s, kd_s, alpha_per_s;
  /// The paper's D*, the largest change of the commanded speed per step event [mm/s] (> 0).
  std::optional<double> speed_change_mm_s;
  std::optional<double> drag_force_n, bump_force_n, end_load_n_per_mm, drag_n_s_per_m;
  std::optional<double> backlash_mm, run_current_a, max_current_a;
  std::optional<double> drag_gain_per_s, load_angle_deg;
  /// feedforward's model error: factors on the mass and belt stiffness it believes (> 0).
  std::optional<double> model_mass_scale, model_stiffness_scale;
  double corrupt_probability = 0.0;
  /// The encoder: its frame rate (the control period is 1 / rate; a whole number of 20 us
  /// substeps, at most the AS5311's 50 kHz SSI limit) and its resolution [um] (no finer than
  /// the AS5311's 0.488 um, no coarser than half a microstep).
  std::optional<double> encoder_rate_hz, encoder_resolution_um;
  bool governor = true;         ///< false: no command governor (studies of the raw laws)
};
/// Validates the request (amctl::Error naming the flag), then simulate_seed003 or
/// simulate_file; the controller's max_accel is the machine's.
[[nodiscard]] SimulationResult stepper_simulate(const machine::Machine& m, const SimulateRequest& r);

/// JSON: source, controller, speed_mm_s, load, duration_s, axes.{x,y}.{...}.
[[nodiscard]] Json to_json(const SimulationResult& r);

/// Speed sweep of the reversing-strokes scenario: one row per (controller, speed).
struct SweepRow {
  std::string controller;
  double speed_mm_s = 0.0;
  AxisResult x, y;
};
[[nodiscard]] std::vector<SweepRow> sweep_reversing_strokes(const machine::Machine& m,
                                                  std::span<const ControllerKind> controllers,
                                                  std::span<const double> speeds_mm_s,
                                                  bool load, const SimulationOptions& options);
/// `amctl stepper sweep`: every controller at 30, 60, 90, 120 and 150 mm/s, with or without
/// the load, on the machine (its max_accel for the strokes and for D*).
[[nodiscard]] std::vector<SweepRow> stepper_sweep(const machine::Machine& m, bool load);
/// JSON: a list of {controller, speed_mm_s, x: {...}, y: {...}} (the axes as in to_json).
[[nodiscard]] Json sweep_json(std::span<const SweepRow> rows);
/// CSV: controller,speed_mm_s,x_max_error_mm,x_rms_error_mm,x_lost_steps,y_...
[[nodiscard]] std::string sweep_csv(std::span<const SweepRow> rows);

}  // namespace amctl::closedloop
