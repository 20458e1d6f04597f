#pragma once
// One discrete PI/PID controller with output limits and anti-windup, and its continuous
// transfer function. Used by the thermal loops (SLS powder bed, FDM hotend and bed) and meant
// for feedforward compensation and closed-loop steppers. See docs/control.md for the law and
// the anti-windup rules.
//
// Units: the error e = setpoint - measurement is in the caller's measurement unit [E] (K,
// mm, ...), the output u in the actuator unit [U] (duty fraction, W/m^2, A, ...). Gains carry
// [U/E]; time is in seconds.
#include <complex>
#include <limits>
#include <optional>
#include <string_view>

namespace amctl::control {

/// What the integrator does while the output is limited.
enum class AntiWindup {
  none,                     ///< integrate always (the integral may wind up)
  clamp_integral,           ///< integrate, then clamp the integral state into [min, max]
  conditional_integration,  ///< integrate only when unsaturated or when e drives out of saturation
  back_calculation,         ///< integrate e plus (u - u_unsat)/Tt (Astrom & Hagglund)
};

[[nodiscard]] const char* to_string(AntiWindup a);
/// "none", "clamp_integral", "conditional_integration" or "back_calculation"; nullopt else.
[[nodiscard]] std::optional<AntiWindup> anti_windup_from_string(std::string_view name);

/// Gains of a PI/PID law, kept in the form they were given in so that no conversion rounds
/// them (a parallel ki is not recomputed from Ti, nor a standard Ti from ki):
///   parallel:  C(s) = kp + ki/s + kd s
///   standard (ISA "ideal"):  C(s) = kp (1 + 1/(Ti s) + Td s) = kp (Ti s + 1)/(Ti s) + kp Td s
/// A value type; the factories validate. Default: all zero (no action).
class PidGains {
 public:
  enum class Form { parallel, standard };

  PidGains() = default;
  /// kp [U/E], ki_per_s [U/(E s)], kd_s [U s/E]. Throws amctl::Error naming the gain unless
  /// each is finite and >= 0.
  [[nodiscard]] static PidGains parallel(double kp, double ki_per_s, double kd_s = 0.0);
  /// kp [U/E] finite and >= 0, integral time Ti [s] > 0 (+inf: no integral action),
  /// derivative time Td [s] finite and >= 0. Throws amctl::Error naming the bad one.
  [[nodiscard]] static PidGains standard(double kp, double integral_time_s,
                                         double derivative_time_s = 0.0);

  [[nodiscard]] Form form() const { return form_; }
  [[nodiscard]] double kp() const { return kp_; }
  /// Integral gain [U/(E s)]: as given (parallel) or kp / Ti (standard; 0 for Ti = inf).
  [[nodiscard]] double ki_per_s() const;
  /// Derivative gain [U s/E]: as given (parallel) or kp Td (standard).
  [[nodiscard]] double kd_s() const;
  /// Ti [s]: as given (standard) or kp / ki (parallel; +inf for ki = 0).
  [[nodiscard]] double integral_time_s() const;
  /// Td [s]: as given (standard) or kd / kp (parallel; 0 for kd = 0).
  [[nodiscard]] double derivative_time_s() const;

  /// C(s) from the error to the output at complex s [rad/s], derivative filtered by
  /// 1/(Tf s + 1) when derivative_filter_s = Tf > 0 (the discrete law applies its derivative to
  /// the measurement only: C(s) is the loop transfer, not the reference transfer).
  [[nodiscard]] std::complex<double> transfer(std::complex<double> s,
                                              double derivative_filter_s = 0.0) const;

 private:
  Form form_ = Form::parallel;
  double kp_ = 0.0;
  double a_ = 0.0;  // ki (parallel) or Ti (standard)
  double b_ = 0.0;  // kd (parallel) or Td (standard)
};

/// Limits and anti-windup of the discrete law. Defaults: no limits, no anti-windup, no
/// derivative filter, no full-output band.
struct PidOptions {
  double output_min = -std::numeric_limits<double>::infinity();  ///< [U]
  double output_max = std::numeric_limits<double>::infinity();   ///< [U], > output_min
  AntiWindup anti_windup = AntiWindup::none;
  double tracking_time_s = 1.0;      ///< Tt of back-calculation, > 0 (used only there)
  double derivative_filter_s = 0.0;  ///< Tf of the first-order filter on the measurement, >= 0
  /// |e| above this [E]: output at the limit (max for e > 0), integral reset to 0, like
  /// Marlin's PID_FUNCTIONAL_RANGE. <= 0 disables it.
  double full_output_band = 0.0;

  /// Throws amctl::Error naming the first bad field.
  void validate() const;
};

/// What one controller update produced.
struct PidStep {
  double output = 0.0;              ///< u, within [output_min, output_max] [U]
  double unsaturated_output = 0.0;  ///< u before the limits (= output in the full-output band)
  bool saturated = false;           ///< output != unsaturated_output
};

/// Discrete PID, derivative on the (filtered) measurement, executed every period_s:
///   e = r - y,  u_unsat = kp e + I - kd dy_f/dt,  u = clamp(u_unsat, min, max),
///   I += ki e T  (subject to the anti-windup rule).
/// Owns only its own state (integral, filter); copy it to fork a run.
class PidController {
 public:
  /// Throws amctl::Error for bad options (PidOptions::validate).
  PidController(const PidGains& gains, const PidOptions& options);

  /// One period: setpoint and measurement finite, in [E]; period_s > 0. Throws amctl::Error
  /// naming the bad argument.
  PidStep step(double setpoint, double measurement, double period_s);
  /// step(...).output.
  double update(double setpoint, double measurement, double period_s) {
    return step(setpoint, measurement, period_s).output;
  }
  /// Clears the integral and restarts the derivative filter at the next measurement.
  void reset();

  [[nodiscard]] double integral() const { return integral_; }  ///< I [U]
  [[nodiscard]] const PidGains& gains() const { return gains_; }
  [[nodiscard]] const PidOptions& options() const { return options_; }

 private:
  PidGains gains_;
  PidOptions options_;
  double kp_ = 0.0, ki_ = 0.0, kd_ = 0.0;  // parallel gains, computed once
  double integral_ = 0.0, y_filt_ = 0.0, y_filt_prev_ = 0.0;
  bool first_ = true;
};

}  // namespace amctl::control
