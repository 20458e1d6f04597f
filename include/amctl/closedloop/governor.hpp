#pragma once
// Stability by construction (docs/closedloop.md, section 3.1): what a feedback controller may
// add to the plan's own motor command, checked against the motor's torque-speed curve, the
// drive's step-rate limit and the belt mode, on every move.
//
// A feedback controller commands c = p_ref + L + u: the plan's position, a model lead L (the
// belt stretch and load angle the plan's forces need: an open-loop signal) and a feedback
// correction u. Open loop is L = u = 0. The plan alone needs the torque
//   tau_plan = r (m |a| + F_c + c_v |v|) + J |a| / r + b |w|          (w = v / r)
// and the motor gives at most T_po(w, I) (the pull-out torque at that speed and current,
// StepperAxisModel::pull_out_torque_at_n_m). The governor keeps the load angle below a design
// angle d_max (60 deg by default) by budgeting the margin M = T_po(w, I) sin(d_max) - tau_plan
// at the move's peak speed and acceleration:
//   - the lead is shaped: it reaches the wanted lead in minimum time under |L''| <= A_c =
//     r M / (2 (J + m r^2)) (the axis, rotor and carriage through a belt taken as rigid, is
//     pushed with at most half the margin: a step of acceleration overshoots the static lag up
//     to twice), plus at most s_free at once;
//   - the feedback may step by at most s_free = (r / p) (d_max - d_plan) / 4 per period,
//     d_plan = asin(tau_plan / T_po) (a command step of s_free rings the rotor by at most half
//     the angle margin; encoder noise through the loop stays below it). Its size is not
//     bounded: u makes up for loads the model does not know (which hold the carriage back
//     whatever the command) and for electrical cycles the rotor slipped (a whole cycle of lead
//     is no force); the current scaling, not a smaller u, answers a load;
//   - the command's speed |c'| <= V_c: the lower of 90 % of the drive's step rate and the
//     speed at which T_po(w, I) sin(d_max) still covers the plan's cruise torque;
//   - the acceleration part of the lead (m dA / k for a change dA of the plan's acceleration)
//     ramps in over t_r = 2 sqrt(m dA / (k A_c)); against the belt mode w_b it leaves a
//     residual ringing |1 - sinc(x) e^{-ix}|, x = w_b t_r / 2, of open loop's, below 1 only
//     while x < 1.166; the acceleration lead is used on a move only when x <= 0.8 (residual
//     <= 0.75).
// A move whose plan leaves no margin (M <= 0), runs faster than V_c or starts with a step of
// the axis's speed the rotor cannot absorb (a lag step dv / w_r beyond a quarter of the angle
// margin) is *degraded*: the controller's lead and feedback are brought back to 0 within the
// same budgets (held where there is no margin), so the motor sees open loop's command.
#include <cstdint>
#include <string>

#include "amctl/closedloop/motor.hpp"

namespace amctl::closedloop {

struct GovernorParameters {
  bool enabled = true;                  ///< off: controllers command what they want (studies)
  double max_load_angle_deg = 60.0;     ///< d_max, the design load angle (0, 90]
  double step_rate_fraction = 0.9;      ///< highest command step rate / drive.max_step_rate_hz
  /// Largest x = w_b t_r / 2 at which the acceleration lead is used (0.8: residual ringing
  /// 0.75 of open loop's; 1.166 is where it would equal open loop's).
  double belt_phase_limit = 0.8;
  /// The rotor's dynamic bound (RotorObserver): the largest load angle the observed rotor may
  /// be commanded to, (0, 90]; above the design angle by what the observer's model may be off
  /// (20 % in the belt's force is 10-12 deg near 60).
  double rotor_angle_limit_deg = 70.0;
  /// After the bound held the command, the axis runs open loop's command (degraded) this long:
  /// two periods of a 40 Hz belt mode, so a swing the machine cannot follow is not restarted.
  double rotor_hold_s = 0.05;
  void validate() const;
};

/// The limits on one move for one axis.
struct MoveLimits {
  bool feasible = true;                 ///< false: degraded, the correction is ramped to 0
  bool accel_lead = true;               ///< the acceleration feed-forward fits the belt mode
  double max_command_speed_mm_s = 0.0;  ///< V_c
  double correction_accel_mm_s2 = 0.0;  ///< A_c (0 when degraded and no margin is left)
  double free_step_mm = 0.0;            ///< s_free
  double max_feedback_mm = 0.0;         ///< the feedback's size (infinite: unbounded; 0 degraded)
  double plan_torque_n_m = 0.0;         ///< tau_plan at the move's peak
  double pull_out_n_m = 0.0;            ///< T_po at the move's peak speed and current
};

/// Why a move was degraded (for reports).
enum class DegradeReason { none, torque, speed, jump };

class CommandGovernor {
 public:
  /// `model` is the axis as configured (the drive knows the motor, the belt, the carriage and
  /// the rail friction; not the loads). `current_a` the largest current the controller runs.
  CommandGovernor(const StepperAxisModel& model, const GovernorParameters& p, double current_a);

  /// The limits on a move whose axis reaches |v| <= peak_speed and |a| <= accel, its speed
  /// stepping by `jump` where it starts (a step the rotor takes as a lag jump / w_r: beyond
  /// w_r (r / p) (d_max - d_plan) / 4 the move is degraded).
  [[nodiscard]] MoveLimits limits(double peak_speed_mm_s, double accel_mm_s2, double jump_mm_s = 0.0) const;
  [[nodiscard]] DegradeReason reason(const MoveLimits& l, double peak_speed_mm_s, double jump_mm_s = 0.0) const;
  /// The move's limits with the torque the motor is measured to carry now: r k |c - y| (the
  /// command's lead over the encoder times the belt stiffness; it includes the rotor's lag, so
  /// it errs high) where it exceeds the plan's. A load the model does not know shrinks the
  /// correction's acceleration and steps with the margin it leaves (down to a tenth); the
  /// steady lead that balances the load is kept (the load is carried whatever the command).
  /// `current_a`: the current commanded now (the pull-out it gives).
  [[nodiscard]] MoveLimits with_measured_load(const MoveLimits& l, double lead_over_encoder_mm,
                                              double current_a) const;
  /// The torque the plan needs at speed v and acceleration a (the model above) [N m].
  [[nodiscard]] double plan_torque_n_m(double v_mm_s, double a_mm_s2) const;
  /// Time for the acceleration lead m dA / k to ramp in at A_c, times w_b / 2 (see above).
  [[nodiscard]] double belt_phase(double accel_change_mm_s2, double correction_accel_mm_s2) const;
  /// For a controller that follows its own sequence (encoder-sequenced): the acceleration the
  /// motor can give the whole axis (rotor and carriage, J + m r^2) at speed v within the
  /// design angle, r (T_po(w, I) sin(d_max) - tau_plan(v, 0)) / (J + m r^2) [mm/s^2], and the
  /// highest command speed at no acceleration (V_c) [mm/s].
  [[nodiscard]] double axis_accel_limit_mm_s2(double v_mm_s) const;
  /// The largest lead of the motor command over the carriage the rotor and the belt hold with
  /// the rotor at the design angle, at speed v and phase current I [mm]:
  ///   L = T_po(w, I) sin(d_max) / (r k) + (r / p) d_max + B / 2 - s / 2
  /// (the belt stretched by the force the rotor gives at d_max, the rotor's own angle, half the
  /// backlash, less half a microstep of quantisation). The rotor (its inertia small beside the
  /// carriage's) shares c - y with the belt in quasi-equilibrium, Kt I sin(d) = r k (r th - y),
  /// and c - y grows monotonically with d: |c - y| <= L keeps d <= d_max.
  [[nodiscard]] double max_lead_mm(double v_mm_s, double current_a) const;
  [[nodiscard]] double max_command_speed_mm_s() const { return v_cruise_max_; }
  [[nodiscard]] const GovernorParameters& parameters() const { return p_; }
  [[nodiscard]] double belt_frequency_rad_s() const { return wb_; }

 private:
  StepperAxisModel m_;
  GovernorParameters p_;
  double current_a_ = 0.0, sin_max_ = 0.0, wb_ = 0.0, v_step_max_ = 0.0, v_cruise_max_ = 0.0;
  double wr_ = 0.0;  ///< the rotor's natural frequency on its magnetic spring [rad/s]
  [[nodiscard]] double torque_speed_limit_mm_s() const;
};

/// Applies MoveLimits period by period: the lead through a second-order limiter (a smooth part
/// S reaching the wanted lead in minimum time without overshoot under |S''| <= A_c, plus at
/// most s_free of what is left, never accumulated), the feedback through a step limit (s_free
/// per period; max_feedback_mm bounds its size where set); both brought back to 0 on a
/// degraded move; the command's speed within +-V_c.
class CommandLimiter {
 public:
  struct Out {
    double correction_mm = 0.0;  ///< L + u at the end of the period (c - p_ref)
    bool feedback_limited = false;  ///< u was held short of the controller's
  };
  /// `lead_mm`, `feedback_mm`: what the controller wants at the end of the period;
  /// `ref_speed_mm_s` the plan's speed over the period.
  Out next(double lead_mm, double feedback_mm, double ref_speed_mm_s, const MoveLimits& l,
           double period_s);
  void reset(double correction_mm) { lead_ = smooth_ = correction_mm; u_ = rate_ = 0.0; }
  /// The command was moved by `delta_mm` after next() (the lead cap): the feedback takes the
  /// change first, as for the speed room, so neither winds up against the cap.
  void take_back(double delta_mm) { u_ += delta_mm; }
  /// The lead as applied at the end of the last period.
  [[nodiscard]] double lead_mm() const { return lead_; }

 private:
  double lead_ = 0.0, smooth_ = 0.0, rate_ = 0.0, u_ = 0.0;
};


/// The rotor's dynamic bound (docs/closedloop.md, section 3.2). The lead cap above balances the
/// rotor and the belt statically; at the belt mode (65-80 Hz swings of the command) the torque
/// the rotor's own inertia takes, J th'', is as large as the belt's. This observer integrates the
/// rotor from what the drive knows, the command c and the encoder's carriage y:
///   J th'' = T_po(w, I) sin(p (c / r - th)) - r F - b w,   F = k dz(r th - y) + c_b (r w - y')
/// (dz the backlash's deadband, the contact push-only), so its load angle counts the torque
/// available at speed minus the torque that accelerates the rotor and the torque the belt
/// takes, the feedback's share included (the command is the sum). Every period the command is
/// kept within (r / p) d_lim - s / 2 of the rotor predicted at the period's end: the load angle
/// stays below d_lim (the motor then gives at most T_po sin(d_lim)); where the belt asks more,
/// the command is pulled back with the rotor instead of slipping.
class RotorObserver {
 public:
  struct Prediction {
    double q_mm = 0.0;      ///< the rotor's position as belt travel, r th [mm]
    double qd_mm_s = 0.0;   ///< its speed [mm/s]
  };
  RotorObserver(const StepperAxisModel& model, double max_angle_deg, double start_mm);
  /// The rotor at the end of a period of length T whose command ramps from c0 to c1, the
  /// carriage at y (mid-period estimate) moving at yd, phase current amplitude I.
  [[nodiscard]] Prediction predict(double c0_mm, double c1_mm, double y_mm, double yd_mm_s,
                                   double current_a, double period_s) const;
  void commit(const Prediction& p) { now_ = p; }
  /// The largest lead of the command over the rotor: (r / p) d_lim - s / 2 [mm].
  [[nodiscard]] double max_lead_mm() const { return lead_mm_; }
  [[nodiscard]] const Prediction& state() const { return now_; }

 private:
  StepperAxisModel m_;
  Prediction now_;
  double lead_mm_ = 0.0;
};

}  // namespace amctl::closedloop
