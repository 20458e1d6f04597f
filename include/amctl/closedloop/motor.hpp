#pragma once
// A hybrid stepper motor, its current-mode chopper drive and the axis it pulls through a belt
// (docs/closedloop.md, section 1). SI units inside (rad, N m, A, V, m); positions at the
// interface in mm.
//
// Two phases a, b; p = full_steps_per_rotation / 4 pole pairs; rotor angle th, electrical
// angle p th. The drive commands the electrical angle phi = n * 2 pi / (4 microsteps) of
// microstep n and regulates the phase currents towards I (cos phi, sin phi):
//   L di_a/dt = v_a - R i_a + Ke w sin(p th),   L di_b/dt = v_b - R i_b - Ke w cos(p th),
//   v = clamp(Kc (i_ref - i) + R i_ref, -V_supply, V_supply)          (averaged chopper)
//   T_m = Kt (-i_a sin(p th) + i_b cos(p th)) - T_det sin(4 p th)
// With i = I (cos phi, sin phi): T_m = Kt I sin(phi - p th), load angle d = phi - p th; the
// static pull-out torque is Kt I at d = pi/2; at speed the back-EMF Ke w and the reactance
// p w L leave less voltage for the current, so I and the pull-out torque fall. Ke = Kt (the
// same flux linkage, SI). Mechanics (belt of seed 000, dynamics::BeltParameters):
//   J th'' = T_m - b th' - r F,       F = k (r th - x) + c (r th' - x')     (belt force)
//   (with backlash B: F = k dz(r th - x) + c (r th' - x') while engaged, 0 inside the deadband
//   |r th - x| <= B/2, dz(s) = s -+ B/2; a pushing contact never pulls)
//   m x''  = F - F_c tanh(x'/v_s) - c_v x' - (F_drag tanh(x'/v_s) + c_d x') + F_ext + k_e max(0, x_e - x)
//            - F_bump tanh(x'/v_s) [x within the bump]
// r = rotation_distance / (2 pi), J = rotor + pulley inertia. A step is lost when d leaves
// (-pi, pi): the rotor settles one electrical cycle (4 full steps) further on; slip cycles are
// counted as round(d / 2 pi).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "amctl/dynamics/model.hpp"

namespace amctl::closedloop {

/// tanh(x) as 1 - 2 / (exp(2|x|) + 1) with the sign of x (absolute error below 3e-16, one exp
/// instead of libm's tanh through expm1: the friction's smoothing runs every substep, and was
/// a fifth of a whole print's simulation time); exactly +-1 beyond |x| = 20, where tanh rounds
/// to +-1 in double precision.
[[nodiscard]] inline double fast_tanh(double x) {
  const double a = x < 0.0 ? -x : x;
  if (a >= 20.0) return x < 0.0 ? -1.0 : 1.0;
  const double t = 1.0 - 2.0 / (std::exp(2.0 * a) + 1.0);
  return x < 0.0 ? -t : t;
}

/// Motor datasheet values. Defaults: a 17HS4401-class NEMA17 (1.8 deg, 40 N cm holding
/// torque two phases on at 1.7 A, 1.5 ohm, 2.8 mH, 54 g cm^2 rotor, 2.2 N cm detent), the
/// table printed on that motor's datasheet (docs/closedloop.md cites it).
struct MotorParameters {
  double holding_torque_n_m = 0.40;       ///< two phases at rated current [N m]
  double rated_current_a = 1.7;           ///< per phase [A]
  double phase_resistance_ohm = 1.5;      ///< [ohm]
  double phase_inductance_h = 2.8e-3;     ///< [H]
  double rotor_inertia_kg_m2 = 54e-7;     ///< 54 g cm^2 [kg m^2]
  double detent_torque_n_m = 0.022;       ///< amplitude of the 4-per-cycle cogging [N m]
  int full_steps_per_rotation = 200;      ///< 1.8 deg
  /// Viscous rotor damping (iron losses, bearings) [N m s/rad]: not on datasheets; 1e-3 gives
  /// the rotor resonance a damping ratio of about 0.05 (docs/closedloop.md).
  double rotor_damping_n_m_s_per_rad = 1.0e-3;

  /// Kt = holding torque / (sqrt(2) rated current): the holding torque is measured with both
  /// phases at rated current, a current vector sqrt(2) I long. [N m/A] = Ke [V s/rad]
  [[nodiscard]] double torque_constant_n_m_per_a() const;
  [[nodiscard]] int pole_pairs() const { return full_steps_per_rotation / 4; }
  /// Throws amctl::Error naming `prefix`.field when one is not positive (detent, damping: >= 0).
  void validate(const char* prefix = "motor") const;
};

/// The driver (TMC2209-class current-mode chopper on a 24 V supply).
struct DriveParameters {
  double supply_voltage_v = 24.0;         ///< [V]
  /// Peak of the sine/cosine phase currents [A] (the run current: Klipper's run_current is
  /// RMS, this is sqrt(2) times it).
  double current_amplitude_a = 1.7;
  /// Largest amplitude a controller may request while the motor is loaded (a closed-loop
  /// drive's current boost) [A]; 0 = the motor's rated current.
  double max_current_a = 0.0;
  /// Bandwidth of the averaged current loop: Kc = 2 pi f L [ohm]. A real chopper switches at
  /// 20-40 kHz and reaches its target as fast as the voltage allows.
  double current_loop_bandwidth_hz = 5000.0;
  int microsteps = 16;
  /// Highest step rate the driver (and the MCU feeding it) can take [steps/s].
  double max_step_rate_hz = 200000.0;
  void validate(const char* prefix = "drive") const;
};

/// The axis the motor moves.
struct AxisMechanics {
  double rotation_distance_mm = 40.0;     ///< belt travel per motor turn (GT2, 20 teeth)
  double pulley_inertia_kg_m2 = 1.5e-7;   ///< aluminium GT2 20T pulley [kg m^2]
  /// Carriage mass and belt (seed 000 model, amctl::dynamics): default 0.5 kg on a belt of
  /// 40 Hz, damping ratio 0.1 (the dynamics default).
  dynamics::BeltParameters belt{0.5, 0.5 * 6.283185307179586 * 40.0 * 6.283185307179586 * 40.0,
                                2.0 * 0.1 * 6.283185307179586 * 40.0 * 0.5};
  double coulomb_friction_n = 2.0;        ///< rail friction [N]
  double viscous_friction_n_s_per_m = 2.0;  ///< [N s/m]
  double drag_force_n = 0.0;              ///< extra load opposing motion (cable, nozzle) [N]
  /// Extra load growing with speed (a nozzle ploughing through material) [N s/m]. Unlike the
  /// rail's viscous friction, a load: controllers do not know it.
  double drag_n_s_per_m = 0.0;
  double external_force_n = 0.0;          ///< constant force along +x (gravity on a Z) [N]
  /// A load near one end of the travel (a cable chain or bowden tube pulled taut): below
  /// end_load_start_mm it pushes back towards +x with end_load_n_per_mm per mm of the way in.
  double end_load_n_per_mm = 0.0;
  double end_load_start_mm = 0.0;
  /// A bump (a curled edge the nozzle scrapes, a tight spot of the rail): an extra drag
  /// bump_force_n opposing motion while the carriage is within bump_half_width_mm of
  /// bump_position_mm. 0 = none.
  double bump_force_n = 0.0;
  double bump_position_mm = 0.0;
  double bump_half_width_mm = 0.0;
  /// Backlash: total lost motion between the pulley and the carriage at a reversal of the belt
  /// force (pulley teeth, a loose set screw) [mm]. 0 = none.
  double backlash_mm = 0.0;
  /// Speed below which Coulomb friction is smoothed (tanh(v / v_s)) [m/s].
  double friction_smoothing_m_s = 1.0e-3;
  void validate(const char* prefix = "axis") const;
  [[nodiscard]] double pulley_radius_m() const;
};

/// The state of one axis.
struct MotorState {
  double theta_rad = 0.0;       ///< rotor angle (0 = step 0 aligned)
  double omega_rad_s = 0.0;
  double x_m = 0.0;             ///< carriage position, x = r theta when the belt is relaxed
  double v_m_s = 0.0;
  double i_a = 0.0, i_b = 0.0;  ///< phase currents [A]
  std::int64_t microstep = 0;   ///< commanded microstep n
  double current_a = 0.0;       ///< commanded current amplitude I [A]
  double ref_a = 0.0, ref_b = 0.0;  ///< I cos(phi), I sin(phi) of that microstep [A]
  double torque_n_m = 0.0;      ///< motor torque of the last step
  /// sin, cos of the electrical angle p theta, carried from substep to substep by the fast
  /// path (StepperAxisModel::advance); sync_angle() recomputes them exactly.
  double sin_e = 0.0, cos_e = 1.0;
};

/// The constants of one integration substep of h seconds (StepperAxisModel::substep).
struct SubstepCoefficients {
  double h_s = 0.0;
  // Phase current, exact for inputs held over the substep: unsaturated i1 = ci0 i0 + cref ref
  // - ce e, its mean over the step gi0 i0 + gref ref - ge e; saturated i1 = si0 i0 + sv (+-V - e).
  double ci0 = 0.0, cref = 0.0, ce = 0.0, gi0 = 0.0, gref = 0.0, ge = 0.0, si0 = 0.0, sv = 0.0;
  double h_over_j = 0.0, h_over_m = 0.0;
};

/// The model: immutable, precomputed constants; state lives in MotorState.
class StepperAxisModel {
 public:
  StepperAxisModel(const MotorParameters& motor, const DriveParameters& drive,
                   const AxisMechanics& axis);

  /// A state at rest at position x_mm, microstep matching, currents at their reference.
  [[nodiscard]] MotorState rest_state(double x_mm) const;
  /// Commands microstep n (updates the current reference).
  void set_microstep(MotorState& s, std::int64_t n) const;
  /// For the next step only: the current reference held at microstep n0 until fraction f1 of
  /// the step, then n0 + dir until f2, ... and n1 for the rest (the time-weighted mean of the
  /// references, the current loop's input averaged over the step: steps land between substeps).
  /// Call set_microstep(s, n1) after the step.
  void set_microstep_path(MotorState& s, std::int64_t n0, std::int64_t n1, double c0_mm,
                          double c1_mm) const;
  /// Commands the current amplitude, clamped to (0, max_current_a()] (updates the reference).
  void set_current(MotorState& s, double amplitude_a) const;
  /// The largest current a controller may request: drive.max_current_a, or the motor's rated
  /// current when that is 0 [A].
  [[nodiscard]] double max_current_a() const;
  /// One integration step of h seconds. Electrical side: the current loop's exact solution for
  /// inputs held over the step (its pole (R + Kc)/L ~ 3e4 1/s is stiff), the back-EMF at the
  /// step's middle angle; mechanics: semi-implicit (symplectic) Euler, stable for h well under
  /// 2/w_max with w_max the rotor's magnetic-spring frequency (~1.8e3 rad/s).
  void step(MotorState& s, double h_s) const;
  /// The constants of a substep of h seconds, for advance().
  [[nodiscard]] SubstepCoefficients substep(double h_s) const;
  /// Recomputes s.sin_e, s.cos_e from s.theta_rad (after setting theta from outside).
  void sync_angle(MotorState& s) const;
  /// The same integration step as step(s, h), the fast path: the sine and cosine of the
  /// electrical angle are rotated by the substep's increment p w h (Taylor polynomials, error
  /// below 2.5e-9 a step for p w h < 0.2 rad) instead of recomputed; call sync_angle() every
  /// few tens of steps to keep them exact.
  void advance(MotorState& s, const SubstepCoefficients& k) const;

  /// Load angle d = phi - p theta [rad] (unwrapped).
  [[nodiscard]] double load_angle_rad(const MotorState& s) const;
  /// Whole electrical cycles slipped, round(d / 2 pi) (positive: rotor behind the command).
  [[nodiscard]] std::int64_t slip_cycles(const MotorState& s) const;
  [[nodiscard]] double step_distance_mm() const { return step_mm_; }
  [[nodiscard]] int microsteps_per_cycle() const { return 4 * drive_.microsteps; }
  /// Static pull-out torque Kt I [N m].
  [[nodiscard]] double pull_out_torque_n_m() const { return kt_ * drive_.current_amplitude_a; }
  /// Stiffness of the magnetic spring at d = 0 around a detent-aligned step: p (Kt I + 4 T_det).
  [[nodiscard]] double magnetic_stiffness_n_m_per_rad() const;
  /// Rotor + pulley inertia [kg m^2].
  [[nodiscard]] double inertia_kg_m2() const { return j_; }
  [[nodiscard]] double pulley_radius_m() const { return r_; }
  /// Steady pull-out torque at a constant speed w [rad/s] (phasor of the current loop with
  /// the back-EMF and the voltage limit): the torque falls with speed.
  [[nodiscard]] double pull_out_torque_at_n_m(double omega_rad_s) const;
  /// The same at a commanded current amplitude [A].
  [[nodiscard]] double pull_out_torque_at_n_m(double omega_rad_s, double current_a) const;
  [[nodiscard]] const MotorParameters& motor() const { return motor_; }
  [[nodiscard]] const DriveParameters& drive() const { return drive_; }
  [[nodiscard]] const AxisMechanics& axis() const { return axis_; }
  /// Carriage position [mm].
  [[nodiscard]] static double position_mm(const MotorState& s) { return s.x_m * 1e3; }

 private:
  MotorParameters motor_;
  DriveParameters drive_;
  AxisMechanics axis_;
  int p_ = 50;
  double kt_ = 0, r_ = 0, j_ = 0, kc_ = 0, step_mm_ = 0, rad_per_micro_ = 0;
  double inv_m_ = 0, k_ = 0, c_ = 0, half_backlash_ = 0, end_k_ = 0, end_x_ = 0, bump_lo_ = 0, bump_hi_ = 0;
  double coulomb_plus_drag_n_ = 0, viscous_plus_drag_ = 0, inv_vs_ = 0;
  double vmax_ = 0, r_ohm_ = 0, detent_ = 0, damping_ = 0, f_ext_ = 0, bump_f_ = 0;
  /// cos, sin of the electrical angle of each microstep in a cycle (4 microsteps entries).
  std::vector<double> micro_cos_, micro_sin_;
  std::int64_t cycle_mask_ = -1;  ///< cycle - 1 when the cycle is a power of two, else -1
  /// The body of a step: s.sin_e, s.cos_e hold the electrical angle at the start.
  void integrate(MotorState& s, const SubstepCoefficients& k) const;
};

// The integration step, inline: the simulator's hot path (docs/closedloop.md, section 1).
inline void StepperAxisModel::advance(MotorState& s, const SubstepCoefficients& k) const {
  integrate(s, k);
  // Rotate (sin, cos) of p theta by d = p (theta1 - theta0) = p h w1: Taylor polynomials of
  // sin d and cos d to the 5th and 6th order (truncation below d^7 / 5040 = 2.5e-9 for
  // d < 0.2 rad; the simulator recomputes them exactly every 16 periods).
  const double d = p_ * k.h_s * s.omega_rad_s;
  const double d2 = d * d, d4 = d2 * d2;
  constexpr double c6 = 1.0 / 6.0, c120 = 1.0 / 120.0, c24 = 1.0 / 24.0, c720 = 1.0 / 720.0;
  const double sd = d * ((1.0 - d2 * c6) + d4 * c120);
  const double cd = (1.0 - 0.5 * d2) + d4 * (c24 - d2 * c720);
  const double sn = s.sin_e * cd + s.cos_e * sd;
  const double cs = s.cos_e * cd - s.sin_e * sd;
  s.sin_e = sn;
  s.cos_e = cs;
}

inline void StepperAxisModel::integrate(MotorState& s, const SubstepCoefficients& k) const {
  const double sn = s.sin_e, cs = s.cos_e;
  const double vmax = vmax_;
  const double R = r_ohm_;
  // Back-EMF as a voltage drop e (L di/dt = v - R i - e), at the middle of the step's rotation
  // (first order in d = p w h).
  const double half = 0.5 * p_ * k.h_s * s.omega_rad_s;
  const double e_a = -kt_ * s.omega_rad_s * (sn + half * cs);
  const double e_b = kt_ * s.omega_rad_s * (cs - half * sn);
  // The chopper applies v = Kc (i_ref - i) + R i_ref (it holds the current at standstill
  // exactly, as a hysteresis chopper does): L di/dt = v - R i - e, solved exactly over the
  // step; where the mean v would exceed the supply, the chopper saturates: L di/dt = +-V - R i
  // - e, again exactly.
  auto phase = [&](double i0, double ref, double e) {
    double i1 = k.ci0 * i0 + k.cref * ref - k.ce * e;
    const double i_mean = k.gi0 * i0 + k.gref * ref - k.ge * e;
    const double v = kc_ * (ref - i_mean) + R * ref;
    if (v > vmax || v < -vmax) {
      const double vs = v > 0 ? vmax : -vmax;
      i1 = k.si0 * i0 + k.sv * (vs - e);
    }
    return i1;
  };
  s.i_a = phase(s.i_a, s.ref_a, e_a);
  s.i_b = phase(s.i_b, s.ref_b, e_b);
  // sin(4 p th) from sin, cos of p th (double angle twice).
  const double s2 = 2.0 * sn * cs, c2 = cs * cs - sn * sn;
  const double s4 = 2.0 * s2 * c2;
  const double tm = kt_ * (-s.i_a * sn + s.i_b * cs) - detent_ * s4;
  s.torque_n_m = tm;
  const double stretch = r_ * s.theta_rad - s.x_m;
  const double stretch_rate = r_ * s.omega_rad_s - s.v_m_s;
  double f_belt = 0.0;
  if (half_backlash_ == 0.0) {
    f_belt = k_ * stretch + c_ * stretch_rate;
  } else if (stretch > half_backlash_) {  // engaged pulling +x: a contact pushes, never pulls
    f_belt = std::max(0.0, k_ * (stretch - half_backlash_) + c_ * stretch_rate);
  } else if (stretch < -half_backlash_) {
    f_belt = std::min(0.0, k_ * (stretch + half_backlash_) + c_ * stretch_rate);
  }
  const double t_rotor = tm - damping_ * s.omega_rad_s - r_ * f_belt;
  const double sgn = fast_tanh(s.v_m_s * inv_vs_);
  double f_cart = f_belt - coulomb_plus_drag_n_ * sgn - viscous_plus_drag_ * s.v_m_s +
                  f_ext_;
  if (end_k_ != 0.0) f_cart += end_k_ * std::max(0.0, end_x_ - s.x_m);
  if (s.x_m >= bump_lo_ && s.x_m <= bump_hi_) f_cart -= bump_f_ * sgn;
  // Semi-implicit Euler: velocities first, positions with the new velocities.
  s.omega_rad_s += k.h_over_j * t_rotor;
  s.v_m_s += k.h_over_m * f_cart;
  s.theta_rad += k.h_s * s.omega_rad_s;
  s.x_m += k.h_s * s.v_m_s;
}

}  // namespace amctl::closedloop
