#include "amctl/control/pid.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::control {

const char* to_string(AntiWindup a) {
  switch (a) {
    case AntiWindup::none: return "none";
    case AntiWindup::clamp_integral: return "clamp_integral";
    case AntiWindup::conditional_integration: return "conditional_integration";
    case AntiWindup::back_calculation: return "back_calculation";
  }
  return "?";
}

std::optional<AntiWindup> anti_windup_from_string(std::string_view name) {
  for (AntiWindup a : {AntiWindup::none, AntiWindup::clamp_integral,
                       AntiWindup::conditional_integration, AntiWindup::back_calculation})
    if (name == to_string(a)) return a;
  return std::nullopt;
}

// ------------------------------------------------------------------------------------ gains

PidGains PidGains::parallel(double kp, double ki_per_s, double kd_s) {
  require_non_negative("kp (proportional gain)", kp);
  require_non_negative("ki (integral gain, per s)", ki_per_s);
  require_non_negative("kd (derivative gain, s)", kd_s);
  PidGains g;
  g.form_ = Form::parallel;
  g.kp_ = kp;
  g.a_ = ki_per_s;
  g.b_ = kd_s;
  return g;
}

PidGains PidGains::standard(double kp, double integral_time_s, double derivative_time_s) {
  require_non_negative("kp (proportional gain)", kp);
  if (std::isnan(integral_time_s) || integral_time_s <= 0.0)
    throw Error(fmt::format("integral time Ti must be > 0 s (+inf for no integral action), "
                            "got {}",
                            integral_time_s));
  require_non_negative("derivative time Td, s", derivative_time_s);
  PidGains g;
  g.form_ = Form::standard;
  g.kp_ = kp;
  g.a_ = integral_time_s;
  g.b_ = derivative_time_s;
  return g;
}

double PidGains::ki_per_s() const {
  if (form_ == Form::parallel) return a_;
  return std::isinf(a_) ? 0.0 : kp_ / a_;
}

double PidGains::kd_s() const { return form_ == Form::parallel ? b_ : kp_ * b_; }

double PidGains::integral_time_s() const {
  if (form_ == Form::standard) return a_;
  return a_ == 0.0 ? std::numeric_limits<double>::infinity() : kp_ / a_;
}

double PidGains::derivative_time_s() const {
  if (form_ == Form::standard) return b_;
  return b_ == 0.0 ? 0.0 : b_ / kp_;
}

std::complex<double> PidGains::transfer(std::complex<double> s, double derivative_filter_s) const {
  require_non_negative("derivative_filter_s", derivative_filter_s);
  std::complex<double> c;
  if (form_ == Form::standard) {
    c = std::isinf(a_) ? std::complex<double>(kp_, 0.0) : kp_ * (a_ * s + 1.0) / (a_ * s);
  } else {
    c = kp_;
    if (a_ != 0.0) c += a_ / s;
  }
  const double kd = kd_s();
  if (kd != 0.0) c += kd * s / (derivative_filter_s * s + 1.0);
  return c;
}

// -------------------------------------------------------------------------------- controller

void PidOptions::validate() const {
  if (std::isnan(output_min) || std::isnan(output_max) || !(output_max > output_min))
    throw Error(fmt::format("output limits must satisfy output_min < output_max, got [{}, {}]",
                            output_min, output_max));
  if (anti_windup == AntiWindup::back_calculation)
    require_positive("tracking_time_s (back-calculation Tt)", tracking_time_s);
  require_non_negative("derivative_filter_s", derivative_filter_s);
  if (std::isnan(full_output_band))
    throw Error("full_output_band must be a number (<= 0 disables it), got NaN");
}

PidController::PidController(const PidGains& gains, const PidOptions& options)
    : gains_(gains), options_(options) {
  options_.validate();
  kp_ = gains_.kp();
  ki_ = gains_.ki_per_s();
  kd_ = gains_.kd_s();
}

void PidController::reset() {
  integral_ = 0.0;
  first_ = true;
}

PidStep PidController::step(double setpoint, double y, double dt) {
  require_positive("controller period dt, s", dt);
  require_finite("controller setpoint", setpoint);
  require_finite("controller measurement", y);
  const double e = setpoint - y;
  if (first_) {
    y_filt_ = y_filt_prev_ = y;
    first_ = false;
  }
  const double a = dt / (options_.derivative_filter_s + dt);
  y_filt_ += a * (y - y_filt_);
  const double dy = (y_filt_ - y_filt_prev_) / dt;
  y_filt_prev_ = y_filt_;
  const double band = options_.full_output_band;
  if (band > 0.0 && (e > band || e < -band)) {
    integral_ = 0.0;
    const double u = e > 0.0 ? options_.output_max : options_.output_min;
    return PidStep{u, u, false};
  }
  double u_raw = kp_ * e + integral_;
  if (kd_ != 0.0) u_raw -= kd_ * dy;
  const double lo = options_.output_min, hi = options_.output_max;
  const double u = std::clamp(u_raw, lo, hi);
  const double di = ki_ * e * dt;
  switch (options_.anti_windup) {
    case AntiWindup::none:
      integral_ += di;
      break;
    case AntiWindup::clamp_integral:
      integral_ = std::clamp(integral_ + di, lo, hi);
      break;
    case AntiWindup::conditional_integration:
      // Integrate unless saturated with the error driving further into saturation.
      if (u == u_raw || (u_raw > hi && e < 0.0) || (u_raw < lo && e > 0.0)) integral_ += di;
      break;
    case AntiWindup::back_calculation:
      integral_ += di + (u - u_raw) * dt / options_.tracking_time_s;
      break;
  }
  return PidStep{u, u_raw, u != u_raw};
}

}  // namespace amctl::control
