#pragma once
// Position controllers of one stepper axis behind one interface (docs/closedloop.md,
// section 3). Every control period T the controller receives the reference, the encoder's
// latest good reading and the motor command, and returns the motor command position it wants
// reached at the end of the period; the simulator ramps the step command there (velocity
// (target - command) / T, limited by the driver's step rate).
//   open     the plan itself: target = p_ref(t + T)
//   seed003  seed 003 (5)-(11): at each step event, dp = p - p_ref (the reference at the
//            measured instant), vbar = v_ref - alpha dp, D = vbar - v, v += clamp(D, +-D*)
//   pid      position PID on the encoder (control::PidController), feedforward of the
//            reference's velocity (target follows p_ref(t+T)) and acceleration (belt
//            stretch m a / k)
//   best     model feedforward of where the motor must lead the carriage (belt stretch and
//            rotor load angle for the reference's acceleration, friction and speed) and a
//            stiffer PID on the latency-aligned error
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "amctl/closedloop/motor.hpp"
#include "amctl/control/pid.hpp"

namespace amctl::closedloop {

enum class ControllerKind { open, seed003, pid, best };
[[nodiscard]] const char* to_string(ControllerKind k);
/// "open", "seed003", "pid", "best"; throws amctl::Error naming "--controller" otherwise.
[[nodiscard]] ControllerKind controller_from_string(std::string_view name);

/// Gains and timing. Defaults are the ones docs/closedloop.md defends.
struct ControllerParameters {
  double period_s = 100e-6;       ///< control period T (the encoder read rate, 10 kHz)
  // seed003
  double alpha_per_s = 0.6;       ///< seed 003's alpha [1/s] (velocity correction per mm)
  /// D* [mm/s]: largest change of the commanded speed per step event. <= 0: derived as
  /// sqrt(2 a_max s), the speed reached from rest over one microstep s at the axis's max
  /// acceleration a_max.
  double max_speed_change_mm_s = 0.0;
  double max_accel_mm_s2 = 3000.0;  ///< a_max for D*
  // pid (position form, command [mm] per error [mm])
  double kp = 2.0;                ///< [-]
  double ki_per_s = 200.0;        ///< [1/s]
  double kd_s = 0.001;            ///< [s]
  double output_limit_mm = 2.0;   ///< correction limit, integral clamped inside it
  // best
  double best_kp = 3.0;           ///< [-]
  double best_ki_per_s = 250.0;   ///< [1/s]
  double best_kd_s = 0.001;       ///< [s]
  /// best: adaptation gain of the learned drag (a Coulomb-like load opposing motion that the
  /// model does not know), N of drag per (N of force error . s) [1/s]. 0: not learned.
  double best_drag_gain_per_s = 20.0;
  /// best: the load angle the current is sized for [deg]: I = tau / (Kt sin(angle)), between
  /// the run current and the drive's max_current (a closed-loop drive's current boost). 0 or
  /// >= 90: the run current always.
  double best_load_angle_deg = 45.0;
  /// best: the reference speed over which the direction of the drag and of the backlash flips
  /// in the feedforward (tanh(v / v_flip)) [mm/s].
  double best_flip_speed_mm_s = 2.0;
  /// best: how far the model it believes is off the true axis, as factors on the carriage mass
  /// and on the belt stiffness (1 = the true values; robustness studies).
  double best_model_mass_scale = 1.0;
  double best_model_stiffness_scale = 1.0;
  /// Encoder latency the controller aligns its reference with [s].
  double latency_s = 100e-6;
  void validate() const;
};

/// What a controller sees each period.
struct ControlInput {
  double t_s = 0.0;
  double ref_mm = 0.0, ref_vel_mm_s = 0.0, ref_acc_mm_s2 = 0.0;  ///< at t
  double next_ref_mm = 0.0, next_vel_mm_s = 0.0, next_acc_mm_s2 = 0.0;  ///< at t + T
  double measured_ref_mm = 0.0;  ///< the reference at the instant the measurement was sensed
  double measured_mm = 0.0;      ///< encoder, last good frame
  double command_mm = 0.0;       ///< motor command position now (exact, before quantising)
  std::uint64_t steps_since_last = 0;  ///< steps issued during the last period
};

class Controller {
 public:
  virtual ~Controller() = default;
  /// The motor command position wanted at t + T [mm].
  virtual double target_mm(const ControlInput& in) = 0;
  /// The current amplitude wanted for the next period [A], computed by target_mm; 0 = the
  /// drive's run current (every controller but best).
  [[nodiscard]] virtual double current_request_a() const { return 0.0; }
  [[nodiscard]] virtual ControllerKind kind() const = 0;
};

/// Builds a controller for one axis; validates the gains and rejects a gain that makes the
/// linearised loop unstable (require_stable_loop) before anything is simulated.
[[nodiscard]] std::unique_ptr<Controller> make_controller(ControllerKind kind,
                                                          const ControllerParameters& p,
                                                          const StepperAxisModel& model);

/// The linearised closed loop of a controller around an axis: rotor on its magnetic spring
/// (stiffness StepperAxisModel::magnetic_stiffness), belt, carriage with viscous friction,
/// the command held over each period (ZOH), the encoder latency as whole periods, and the
/// controller's linear part (seed003 without its D* limit, pid and best without limits).
struct LoopAnalysis {
  double spectral_radius = 0.0;   ///< max |eigenvalue| of the discrete closed loop
  bool stable = false;            ///< spectral_radius < 1
  int states = 0;
};
[[nodiscard]] LoopAnalysis analyse_loop(ControllerKind kind, const ControllerParameters& p,
                                        const StepperAxisModel& model);
/// Throws amctl::Error naming the gains of `kind` when analyse_loop finds the loop unstable.
void require_stable_loop(ControllerKind kind, const ControllerParameters& p,
                         const StepperAxisModel& model, const std::string& axis_name);

}  // namespace amctl::closedloop
