#pragma once
// Position controllers of one stepper axis behind one interface (docs/closedloop.md,
// section 3). Every control period T the controller receives the reference, the encoder's
// latest good reading and the motor command, and returns the motor command position it wants
// reached at the end of the period; the simulator passes it through the command governor
// (governor.hpp: the motor's torque-speed curve, the step-rate limit, the belt mode) and
// ramps the step command there.
//   open               the plan itself: target = p_ref(t + T)
//   encoder-sequenced  the closed-loop stepper paper's law as published, eqs. (5)-(11): the
//                      axis reads its own command sequence (p*(h), v*(h)) and moves to the
//                      next command only when the encoder reads p = p*(h); per step event
//                      dp = p - p*(h), vbar = v*(h) - alpha dp, D = vbar - v, v(k+1) = vbar
//                      if |D| <= D*, else v(k) + sgn(D) D*, v(k) the measured speed
//   speed-tracking     the same speed law read as a tracking controller against the
//                      time-based reference: dp = p - p_ref(t_measured), v* = v_ref
//   pid                position PID on the encoder, feed-forward of the reference's speed and
//                      of the belt stretch m a / k
//   feedforward        model feed-forward of the lead the motor needs (belt stretch, rotor
//                      load angle, backlash), a PID on the latency-aligned error, a learned
//                      drag and closed-loop current scaling
// The old names "seed003" (speed-tracking) and "best" (feedforward) are accepted as aliases
// for one release.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

#include "amctl/closedloop/governor.hpp"
#include "amctl/closedloop/motor.hpp"

namespace amctl::closedloop {

enum class ControllerKind { open, encoder_sequenced, speed_tracking, pid, feedforward };
/// "open", "encoder-sequenced", "speed-tracking", "pid", "feedforward".
[[nodiscard]] const char* to_string(ControllerKind k);
/// The names above and the aliases "seed003" (speed-tracking) and "best" (feedforward);
/// throws amctl::Error naming "--controller" otherwise.
[[nodiscard]] ControllerKind controller_from_string(std::string_view name);
/// For an alias, the note the CLI prints ("'best' is now 'feedforward' ..."); nullopt for a
/// current name.
[[nodiscard]] std::optional<std::string> controller_alias_note(std::string_view name);
/// Every controller, in the order of the reports.
[[nodiscard]] std::span<const ControllerKind> all_controllers();
/// Whether the controller uses the encoder (every one but open).
[[nodiscard]] inline bool is_feedback(ControllerKind k) { return k != ControllerKind::open; }

/// Gains and timing. Defaults are the ones docs/closedloop.md defends.
struct ControllerParameters {
  double period_s = 100e-6;       ///< control period T (the encoder read rate, 10 kHz)
  // encoder-sequenced and speed-tracking (the paper's speed law)
  double alpha_per_s = 0.6;       ///< the paper's alpha, phi(x) = -alpha x [mm/s per mm = 1/s]
  /// D* [mm/s]: the largest change of the commanded speed per step event. <= 0: derived as
  /// sqrt(2 a_max s), the speed reached from rest over one microstep s at the axis's max
  /// acceleration a_max.
  double max_speed_change_mm_s = 0.0;
  double max_accel_mm_s2 = 3000.0;  ///< a_max for D*
  // pid (position form, command [mm] per error [mm])
  double kp = 2.0;                ///< [-]
  double ki_per_s = 100.0;        ///< [1/s]
  double kd_s = 0.003;            ///< [s]
  double output_limit_mm = 2.0;   ///< correction limit, integral clamped inside it
  /// pid and feedforward: time constant of the first-order filter on the derivative's error [s]
  double derivative_filter_s = 1e-3;
  // feedforward
  double ff_kp = 3.0;             ///< [-]
  double ff_ki_per_s = 250.0;     ///< [1/s]
  double ff_kd_s = 0.001;         ///< [s]
  /// Adaptation gain of the learned drag (a Coulomb-like load opposing motion that the model
  /// does not know), N of drag per (N of force error . s) [1/s]. 0: not learned.
  double ff_drag_gain_per_s = 20.0;
  /// The load angle the current is sized for [deg]: I = tau / (Kt sin(angle)), between the run
  /// current and the drive's max_current (a closed-loop drive's current boost). 0 or >= 90:
  /// the run current always.
  double ff_load_angle_deg = 40.0;
  /// The reference speed over which the direction of the drag and of the backlash flips in
  /// the feed-forward (tanh(v / v_flip)) [mm/s].
  double ff_flip_speed_mm_s = 2.0;
  /// How far the model it believes is off the true axis, as factors on the carriage mass and
  /// on the belt stiffness (1 = the true values; robustness studies).
  double ff_model_mass_scale = 1.0;
  double ff_model_stiffness_scale = 1.0;
  /// Encoder latency the controller aligns its reference with [s].
  double latency_s = 100e-6;
  void validate() const;
};

/// One command of an axis's own command sequence (encoder-sequenced): where the command ends
/// on this axis and the speed it is to be executed at.
struct AxisCommand {
  double target_mm = 0.0;          ///< p*(h)
  double speed_mm_s = 0.0;         ///< |v*(h)|, the move's speed along this axis
  std::uint64_t line = 0;          ///< G-code line (0 for a scenario)
};

/// What a controller sees each period.
struct ControlInput {
  double t_s = 0.0;
  double ref_mm = 0.0, ref_vel_mm_s = 0.0, ref_acc_mm_s2 = 0.0;  ///< at t
  double next_ref_mm = 0.0, next_vel_mm_s = 0.0, next_acc_mm_s2 = 0.0;  ///< at t + T
  double measured_ref_mm = 0.0;  ///< the reference at the instant the measurement was sensed
  double measured_mm = 0.0;      ///< encoder, last good frame
  double command_mm = 0.0;       ///< motor command position now (exact, before quantising)
  double command_speed_mm_s = 0.0;  ///< the command's speed over the last period
  std::uint64_t steps_since_last = 0;  ///< steps issued during the last period
  /// The governor's limits on the move under way (nullptr: no governor). A controller drops
  /// its acceleration lead where !accel_lead and holds its integral where !feasible.
  const MoveLimits* limits = nullptr;
  /// The governor held the last period's command short of what the controller wanted (the
  /// integral is not advanced then: conditional integration).
  bool limited = false;
};

class Controller {
 public:
  virtual ~Controller() = default;
  /// The motor command position wanted at t + T [mm].
  virtual double target_mm(const ControlInput& in) = 0;
  /// The current amplitude wanted for the next period [A], computed by target_mm; 0 = the
  /// drive's run current (every controller but feedforward).
  [[nodiscard]] virtual double current_request_a() const { return 0.0; }
  [[nodiscard]] virtual ControllerKind kind() const = 0;
  /// The model lead of the last target [mm]: its open-loop part beyond p_ref(t + T) (belt
  /// stretch, load angle, backlash for the plan's forces); the rest is feedback. The governor
  /// shapes the two differently.
  [[nodiscard]] virtual double lead_mm() const { return 0.0; }
  /// Sequenced controllers (encoder-sequenced): the next command of the axis's sequence.
  virtual void push_command(const AxisCommand& c) { (void)c; }
  /// Sequenced controllers: every command pushed has been reached and the axis has stopped.
  [[nodiscard]] virtual bool finished() const { return true; }
  /// Sequenced controllers: the segment of the command under way [from, to] on this axis (for
  /// the path error); nullopt: the simulator's time-based segment.
  [[nodiscard]] virtual std::optional<std::pair<double, double>> active_segment() const {
    return std::nullopt;
  }
  /// Sequenced controllers: commands reached so far.
  [[nodiscard]] virtual std::uint64_t commands_reached() const { return 0; }
  /// Sequenced controllers: commands pushed and not yet reached.
  [[nodiscard]] virtual std::uint64_t commands_pending() const { return 0; }
  /// Whether the controller follows its own command sequence instead of the time-based
  /// reference (the governor then limits its speed and acceleration, not a correction).
  [[nodiscard]] virtual bool sequenced() const { return false; }
};

/// Builds a controller for one axis; validates the gains and rejects a gain that makes the
/// linearised loop unstable (require_stable_loop) before anything is simulated.
/// `start_mm`: where the axis starts (the encoder-sequenced law's first segment begins there).
[[nodiscard]] std::unique_ptr<Controller> make_controller(ControllerKind kind,
                                                          const ControllerParameters& p,
                                                          const StepperAxisModel& model,
                                                          double start_mm = 0.0);

/// The linearised closed loop of a controller around an axis: rotor on its magnetic spring
/// (stiffness StepperAxisModel::magnetic_stiffness), belt, carriage with viscous friction,
/// the command held over each period (ZOH), the encoder latency as whole periods, and the
/// controller's linear part (the speed laws without their D* limit, pid and feedforward
/// without limits). The encoder-sequenced law is linearised around a command far ahead
/// (dp = p - p*, p* constant within the command): the same loop as speed-tracking's.
struct LoopAnalysis {
  double spectral_radius = 0.0;   ///< max |eigenvalue| of the discrete closed loop
  /// max |eigenvalue| over its oscillatory modes (|arg| above 2 pi 5 Hz T): how slowly the
  /// loop's slowest ringing (the belt's, the rotor's) dies away.
  double oscillatory_radius = 0.0;
  bool stable = false;            ///< spectral_radius < 1
  int states = 0;
};
/// `load_angle_rad`: the rotor's operating load angle (its magnetic spring softens as
/// p Kt I cos d, the detent's ripple averaging out along a move); 0: the spring at rest in a
/// detent, p (Kt I + 4 T_det).
[[nodiscard]] LoopAnalysis analyse_loop(ControllerKind kind, const ControllerParameters& p,
                                        const StepperAxisModel& model, double load_angle_rad = 0.0);
/// The gain margin the default gains keep on every plant of the uncertainty set: the loop with
/// every gain multiplied by it is still stable (1.5, 3.5 dB, for what the linearisation leaves
/// out; docs/closedloop.md 3.1).
inline constexpr double kGainMargin = 1.5;
/// The uncertainty of the axis's carriage mass and belt stiffness the default gains are robust
/// to (a fraction of the nominal; the feed-forward's robustness is measured at the same 20 %).
inline constexpr double kModelUncertainty = 0.2;
/// The default gains fitted to an axis: kp and ki (and alpha) scaled down together by factors
/// of 0.9 until the linearised loop with kp, ki, kd and alpha times kGainMargin has a spectral
/// radius below 0.9995 at rest and at the design load angle, with the carriage mass and the
/// belt stiffness at their nominal values and at the four corners of +-kModelUncertainty;
/// `scale` returns the factor (1: the defaults as they are; 0: none found).
[[nodiscard]] ControllerParameters fit_default_gains(ControllerKind kind, const ControllerParameters& p,
                                                     const StepperAxisModel& model,
                                                     double design_load_angle_rad, double& scale);
/// Throws amctl::Error naming the gains of `kind` when analyse_loop finds the loop unstable at
/// rest or at the design load angle (the governor's max_load_angle_deg, in rad).
void require_stable_loop(ControllerKind kind, const ControllerParameters& p,
                         const StepperAxisModel& model, const std::string& axis_name,
                         double design_load_angle_rad = 60.0 * 3.14159265358979323846 / 180.0);

}  // namespace amctl::closedloop
