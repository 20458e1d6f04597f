#include "amctl/thermal/fdm_heater.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "amctl/core/error.hpp"

namespace amctl::thermal {

const char* to_string(TuningRule r) {
  switch (r) {
    case TuningRule::classic_zn: return "classic_zn";
    case TuningRule::some_overshoot: return "some_overshoot";
    case TuningRule::no_overshoot: return "no_overshoot";
  }
  return "?";
}

void HeaterPlantParams::validate() const {
  require_positive("heater_power_w", heater_power_w);
  require_non_negative("core_capacity_j_k", core_capacity_j_k);
  if (core_capacity_j_k > 0) require_positive("core_to_block_w_k", core_to_block_w_k);
  require_positive("block_capacity_j_k", block_capacity_j_k);
  require_finite("ambient_c", ambient_c);
  require_positive("loss_w_k", loss_w_k);
  require_non_negative("fan_extra_loss_w_k", fan_extra_loss_w_k);
  require_non_negative("filament_j_mm3k", filament_j_mm3k);
  require_positive("sensor_time_constant_s", sensor_time_constant_s);
  require_non_negative("sensor_delay_s", sensor_delay_s);
  require_non_negative("sensor_noise_k", sensor_noise_k);
}

HeaterPlantParams HeaterPlantParams::hotend() { return HeaterPlantParams{}; }

HeaterPlantParams HeaterPlantParams::bed() {
  HeaterPlantParams p;
  p.heater_power_w = 220.0;
  p.core_capacity_j_k = 60.0;   // silicone pad, adhesive and the plate area under it
  p.core_to_block_w_k = 15.0;
  p.block_capacity_j_k = 500.0;  // 3 mm aluminium, 235 x 235 mm, plus sheet
  p.loss_w_k = 1.6;
  p.fan_extra_loss_w_k = 0.3;
  p.filament_j_mm3k = 0.0;
  p.sensor_time_constant_s = 8.0;  // thermistor under kapton in a pocket
  p.sensor_delay_s = 0.0;
  return p;
}

HeaterPlant::HeaterPlant(const HeaterPlantParams& p) : p_(p) {
  p_.validate();
  x_[0] = x_[1] = x_[2] = p_.ambient_c;
  rng_ = 0x9E3779B97F4A7C15ull ^ p_.noise_seed;
  if (p_.sensor_delay_s > 0.0) history_.emplace_back(0.0, x_[2]);
}

void HeaterPlant::deriv(const double* x, double duty, double fan, double flow, double* dx) const {
  const double power = p_.heater_power_w * duty;
  const double loss = (p_.loss_w_k + p_.fan_extra_loss_w_k * fan) * (x[1] - p_.ambient_c) +
                      p_.filament_j_mm3k * flow * (x[1] - p_.ambient_c);
  if (p_.core_capacity_j_k > 0) {
    const double q = p_.core_to_block_w_k * (x[0] - x[1]);
    dx[0] = (power - q) / p_.core_capacity_j_k;
    dx[1] = (q - loss) / p_.block_capacity_j_k;
  } else {
    dx[0] = 0.0;
    dx[1] = (power - loss) / p_.block_capacity_j_k;
  }
  dx[2] = (x[1] - x[2]) / p_.sensor_time_constant_s;
}

void HeaterPlant::step(double dt, double duty, double fan, double flow) {
  require_positive("plant time step, s", dt);
  duty = std::clamp(duty, 0.0, 1.0);
  fan = std::clamp(fan, 0.0, 1.0);
  flow = std::max(0.0, flow);
  // RK4 with internal steps no longer than 0.2 of the fastest time constant.
  double fastest = p_.sensor_time_constant_s;
  if (p_.core_capacity_j_k > 0)
    fastest = std::min(fastest, p_.core_capacity_j_k / p_.core_to_block_w_k);
  const int sub = std::max(1, int(std::ceil(dt / (0.2 * fastest))));
  const double h = dt / sub;
  for (int i = 0; i < sub; ++i) {
    double k1[3], k2[3], k3[3], k4[3], y[3];
    deriv(x_, duty, fan, flow, k1);
    for (int j = 0; j < 3; ++j) y[j] = x_[j] + 0.5 * h * k1[j];
    deriv(y, duty, fan, flow, k2);
    for (int j = 0; j < 3; ++j) y[j] = x_[j] + 0.5 * h * k2[j];
    deriv(y, duty, fan, flow, k3);
    for (int j = 0; j < 3; ++j) y[j] = x_[j] + h * k3[j];
    deriv(y, duty, fan, flow, k4);
    for (int j = 0; j < 3; ++j) x_[j] += h / 6.0 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
  }
  if (p_.core_capacity_j_k <= 0) x_[0] = x_[1];
  t_s_ += dt;
  if (p_.sensor_delay_s > 0.0) {
    history_.emplace_back(t_s_, x_[2]);
    // Keep one sample at or before t - delay for the interpolation.
    while (history_.size() > 2 && history_[1].first <= t_s_ - p_.sensor_delay_s) history_.pop_front();
  }
}

double HeaterPlant::delayed_sensor_c() const {
  if (p_.sensor_delay_s <= 0.0) return x_[2];
  const double t = t_s_ - p_.sensor_delay_s;
  // Within the first delay the sensor still reads its start.
  if (t <= history_.front().first) return history_.front().second;
  for (std::size_t i = 1; i < history_.size(); ++i) {
    if (history_[i].first >= t) {
      const auto& a = history_[i - 1];
      const auto& b = history_[i];
      return a.second + (b.second - a.second) * (t - a.first) / (b.first - a.first);
    }
  }
  return history_.back().second;
}

double HeaterPlant::measured_c() {
  const double reading = delayed_sensor_c();
  if (p_.sensor_noise_k <= 0.0) return reading;
  // Deterministic Gaussian noise: splitmix64 uniforms and Box-Muller.
  auto next = [this] {
    std::uint64_t z = (rng_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double(z >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  };
  const double u1 = next(), u2 = next();
  const double g = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  return reading + p_.sensor_noise_k * g;
}

// ---------------------------------------------------------------------------------------- PID

control::PidOptions heater_pid_options() {
  control::PidOptions o;
  o.output_min = 0.0;
  o.output_max = 1.0;
  o.anti_windup = control::AntiWindup::conditional_integration;
  o.derivative_filter_s = 1.0;
  o.full_output_band = 10.0;
  o.tracking_time_s = 5.0;
  return o;
}

// ----------------------------------------------------------------------------------- autotune

control::PidGains tuning_rule(TuningRule r, double ku, double tu) {
  require_positive("Ku", ku);
  require_positive("Tu", tu);
  double kp = 0.0, ki = 0.0, kd = 0.0;
  switch (r) {
    case TuningRule::classic_zn:  // Kp = 0.6 Ku, Ti = Tu/2, Td = Tu/8
      kp = 0.6 * ku;
      ki = 2.0 * kp / tu;
      kd = kp * tu / 8.0;
      break;
    case TuningRule::some_overshoot:  // Kp = Ku/3, Ti = Tu/2, Td = Tu/3
      kp = ku / 3.0;
      ki = 2.0 * kp / tu;
      kd = kp * tu / 3.0;
      break;
    case TuningRule::no_overshoot:  // Kp = Ku/5, Ti = Tu/2, Td = Tu/3
      kp = 0.2 * ku;
      ki = 2.0 * kp / tu;
      kd = kp * tu / 3.0;
      break;
  }
  return control::PidGains::parallel(kp, ki, kd);
}

AutotuneResult relay_autotune(HeaterPlant plant, const AutotuneOptions& o) {
  require_finite("autotune target", o.target_c);
  if (o.cycles < 3) throw Error("autotune cycles must be >= 3, got " + std::to_string(o.cycles));
  require_positive("autotune dt_s", o.dt_s);
  AutotuneResult r;
  constexpr double kMargin = 20.0 / 255.0;  // bias kept away from the rails (8-bit PWM: 20)
  double bias = 0.5, d = 0.5;
  bool heating = true;
  double duty = bias + d;
  double t1 = 0.0, t2 = 0.0, t_high = 0.0, t_low = 0.0;
  double t_max = -std::numeric_limits<double>::infinity();
  double t_min = std::numeric_limits<double>::infinity();
  int cycles = 0;
  double t = 0.0;
  while (t < o.timeout_s) {
    const double y = plant.measured_c();
    t_max = std::max(t_max, y);
    t_min = std::min(t_min, y);
    if (y > o.target_c + o.max_overshoot_k) {
      r.message = "temperature exceeded target + max_overshoot; autotune aborted";
      r.duration_s = t;
      return r;
    }
    if (heating && y > o.target_c && t - t2 > o.lockout_s) {
      heating = false;
      duty = bias - d;
      t1 = t;
      t_high = t1 - t2;
      t_max = o.target_c;
    }
    if (!heating && y < o.target_c && t - t1 > o.lockout_s) {
      heating = true;
      t2 = t;
      t_low = t2 - t1;
      if (cycles > 0) {
        // Shift the bias so the on and off times equalise (the relay then sits on the
        // power that holds the target), and keep the swing symmetric within [0, 1].
        bias += d * (t_high - t_low) / (t_low + t_high);
        bias = std::clamp(bias, kMargin, 1.0 - kMargin);
        d = bias > 0.5 ? 1.0 - bias : bias;
        if (cycles > 2) {
          const double amplitude = 0.5 * (t_max - t_min);
          r.ku = 4.0 * d / (std::numbers::pi * amplitude);
          r.tu_s = t_low + t_high;
          r.bias = bias;
          r.amplitude = d;
          r.t_max_c = t_max;
          r.t_min_c = t_min;
          r.gains = tuning_rule(o.rule, r.ku, r.tu_s);
        }
      }
      duty = bias + d;
      ++cycles;
      t_min = o.target_c;
      if (cycles > o.cycles) {
        r.ok = r.ku > 0.0;
        r.cycles = cycles - 1;
        r.message = r.ok ? "ok" : "no oscillation measured";
        r.duration_s = t;
        return r;
      }
    }
    plant.step(o.dt_s, duty, o.fan, 0.0);
    t += o.dt_s;
  }
  r.message = "autotune timed out";
  r.duration_s = t;
  return r;
}

// ---------------------------------------------------------------------------------------- MPC

MpcController::MpcController(const MpcModel& m, const MpcOptions& o, double ambient_c)
    : m_(m), o_(o), block_(ambient_c), sensor_(ambient_c), ambient_(ambient_c) {
  require_positive("MPC heater_power_w", m.heater_power_w);
  require_positive("MPC block_capacity_j_k", m.block_capacity_j_k);
  require_positive("MPC sensor_responsiveness_1_s", m.sensor_responsiveness_1_s);
  require_non_negative("MPC loss_w_k", m.loss_w_k);
  require_positive("MPC horizon_s", o.horizon_s);
}

double MpcController::update(double target, double measured, double fan, double flow, double dt) {
  require_positive("controller period dt, s", dt);
  if (first_) {
    block_ = sensor_ = measured;
    first_ = false;
  }
  const double xfer = m_.loss_w_k + m_.fan_extra_loss_w_k * fan + m_.filament_j_mm3k * flow;
  // Predict one period with the duty applied during it.
  const double dblock =
      (m_.heater_power_w * last_duty_ - xfer * (block_ - ambient_)) * dt / m_.block_capacity_j_k;
  block_ += dblock;
  sensor_ += (block_ - sensor_) * std::min(1.0, m_.sensor_responsiveness_1_s * dt);
  // Correct towards the measurement: model drift and noise are shared out slowly.
  const double delta = (measured - sensor_) * o_.smoothing;
  block_ += delta;
  sensor_ += delta;
  // Near steady state the remaining residual is blamed on the ambient estimate: this is the
  // integral action that removes steady-state error from model mismatch.
  const bool steady = (last_duty_ > 0.0 && last_duty_ < 1.0) ||
                      std::abs(dblock + delta) < o_.steady_state_k_s * dt;
  if (steady && o_.ambient_gain > 0.0) {
    const double step = o_.ambient_gain * delta;
    const double floor = o_.min_ambient_change_k_s * dt;
    ambient_ += step > 0 ? std::max(step, floor) : std::min(step, -floor);
  }
  double power = 0.0;
  if (target > 0.0) {
    power = (target - block_) * m_.block_capacity_j_k / o_.horizon_s;
    power += xfer * (block_ - ambient_);
  }
  last_duty_ = std::clamp(power / m_.heater_power_w, 0.0, 1.0);
  return last_duty_;
}

// ------------------------------------------------------------------------------ identification

IdentifyResult identify_mpc_model(HeaterPlant plant, const IdentifyOptions& o) {
  require_positive("identify sample_distance_s", o.sample_distance_s);
  require_positive("identify dt_s", o.dt_s);
  if (!(o.target_c > o.ambient_c + 20.0))
    throw Error("identify target_c must be at least 20 K above ambient_c");
  IdentifyResult r;
  const double p = plant.params().heater_power_w;
  // Phase 1: full power from ambient; sample once past a third of the rise (the sensor lag
  // transient has died out and the response is one exponential).
  const double start_temp = o.ambient_c + (o.target_c - o.ambient_c) / 3.0;
  double t = 0.0, next_sample = -1.0;
  const int steps_per_sample = std::max(1, int(std::lround(o.sample_distance_s / o.dt_s)));
  int k = 0;
  for (;;) {
    const double y = plant.measured_c();
    if (y >= o.target_c) break;
    if (next_sample < 0.0 && y >= start_temp) next_sample = t;
    if (next_sample >= 0.0 && k % steps_per_sample == 0) {
      r.sample_times_s.push_back(t);
      r.sample_temps_c.push_back(y);
    }
    if (next_sample >= 0.0) ++k;
    plant.step(o.dt_s, 1.0, 0.0, 0.0);
    t += o.dt_s;
    if (t > 3600.0) throw Error("identify: the heater never reached target_c at full power");
  }
  std::size_t n = r.sample_temps_c.size();
  if (n < 3) throw Error("identify: fewer than three heat-up samples; lower sample_distance_s");
  if (n % 2 == 0) --n;  // odd count: first, middle, last are equally spaced
  const double y1 = r.sample_temps_c[0], y2 = r.sample_temps_c[(n - 1) / 2],
               y3 = r.sample_temps_c[n - 1];
  const double t1 = r.sample_times_s[0];
  const double spacing = r.sample_times_s[(n - 1) / 2] - t1;
  // y(t) = A - B e^{-t/tau}: three equally spaced samples give A and tau in closed form.
  const double asym = (y2 * y2 - y1 * y3) / (2.0 * y2 - y1 - y3);
  const double resp = -std::log((y2 - asym) / (y1 - asym)) / spacing;
  if (!(asym > o.target_c) || !(resp > 0.0) || !std::isfinite(resp))
    throw Error("identify: heat-up curve has no usable curvature (asymptote " +
                std::to_string(asym) + " C)");
  r.asymptotic_temp_c = asym;
  r.block_responsiveness_1_s = resp;
  r.loss_from_curve_w_k = p / (asym - o.ambient_c);
  MpcModel m;
  m.heater_power_w = p;
  m.loss_w_k = r.loss_from_curve_w_k;
  m.block_capacity_j_k = r.loss_from_curve_w_k / resp;
  // Two-pole step response, late part: y = asym - K tau/(tau - tau_s) e^{-t/tau}, K = asym -
  // ambient. With A = (asym - y1) e^{t1/tau}: tau_s = tau (1 - K/A).
  const double ratio = (asym - o.ambient_c) * std::exp(-resp * t1) / (asym - y1);
  m.sensor_responsiveness_1_s = ratio < 1.0 ? resp / (1.0 - ratio) : 10.0;
  m.fan_extra_loss_w_k = 0.0;
  m.filament_j_mm3k = o.filament_j_mm3k;

  // Phases 2 and 3: hold the target with this model, measure the mean power, fan off then on.
  auto hold = [&](double fan) {
    MpcController ctl(m, MpcOptions{}, o.ambient_c);
    double sum_duty = 0.0, sum_y = 0.0;
    int cnt = 0;
    const int settle = int(std::lround(o.settle_s / o.dt_s));
    const int meas = int(std::lround(o.measure_s / o.dt_s));
    for (int i = 0; i < settle + meas; ++i) {
      const double y = plant.measured_c();
      const double duty = ctl.update(o.target_c, y, fan, 0.0, o.dt_s);
      if (i >= settle) {
        sum_duty += duty;
        sum_y += y;
        ++cnt;
      }
      plant.step(o.dt_s, duty, fan, 0.0);
    }
    return p * (sum_duty / cnt) / (sum_y / cnt - o.ambient_c);
  };
  const double loss0 = hold(0.0);
  m.loss_w_k = loss0;
  const double loss_fan = hold(1.0);
  m.fan_extra_loss_w_k = std::max(0.0, loss_fan - loss0);
  r.model = m;
  return r;
}

// ------------------------------------------------------------------------------------ scenario

HeaterRunStats run_heater_scenario(const HeaterPlantParams& pp, const HeaterScenario& sc,
                                   const HeaterController& ctl, const std::string& name) {
  require_positive("scenario dt_s", sc.dt_s);
  require_positive("scenario duration_s", sc.duration_s);
  HeaterPlant plant(pp);
  HeaterRunStats s;
  s.controller = name;
  s.heat_up_time_s = std::numeric_limits<double>::infinity();
  const int steps = int(std::lround(sc.duration_s / sc.dt_s));
  double last_out = sc.fan_on_at_s;
  double flow_min = std::numeric_limits<double>::infinity(), flow_max = -flow_min;
  double flow_sq = 0.0;
  int flow_n = 0;
  s.t_s.reserve(std::size_t(steps));
  s.measured_c.reserve(std::size_t(steps));
  s.duty.reserve(std::size_t(steps));
  for (int i = 0; i < steps; ++i) {
    const double t = i * sc.dt_s;
    const double fan = t >= sc.fan_on_at_s ? 1.0 : 0.0;
    double flow = 0.0;
    if (t >= sc.flow_start_s && t < sc.flow_end_s) {
      const int half = int((t - sc.flow_start_s) / sc.flow_half_period_s);
      flow = (half % 2 == 0) ? sc.flow_high_mm3_s : sc.flow_low_mm3_s;
    }
    const double y = plant.measured_c();
    const double truth = plant.sensor_c();  // noise-free, for the figures
    const double duty = std::clamp(ctl(sc.target_c, y, fan, flow, sc.dt_s), 0.0, 1.0);
    const double e = truth - sc.target_c;
    if (!std::isfinite(s.heat_up_time_s) && e >= -1.0) s.heat_up_time_s = t;
    if (t < sc.fan_on_at_s) s.overshoot_k = std::max(s.overshoot_k, e);
    if (t >= sc.fan_on_at_s && t < sc.flow_start_s) {
      s.fan_max_dev_k = std::max(s.fan_max_dev_k, std::abs(e));
      if (std::abs(e) > sc.band_k) last_out = t + sc.dt_s;
    }
    if (t >= sc.flow_start_s + 2 * sc.flow_half_period_s && t < sc.flow_end_s) {
      flow_min = std::min(flow_min, truth);
      flow_max = std::max(flow_max, truth);
      flow_sq += e * e;
      ++flow_n;
    }
    s.energy_j += duty * pp.heater_power_w * sc.dt_s;
    s.t_s.push_back(t);
    s.measured_c.push_back(y);
    s.duty.push_back(duty);
    plant.step(sc.dt_s, duty, fan, flow);
  }
  s.fan_recovery_s = last_out - sc.fan_on_at_s;
  s.flow_ripple_k = flow_n ? flow_max - flow_min : 0.0;
  s.flow_rms_k = flow_n ? std::sqrt(flow_sq / flow_n) : 0.0;
  return s;
}

}  // namespace amctl::thermal
