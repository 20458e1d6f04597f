#pragma once
// Shapes of one speed change ("ramp") v0 -> v1 and the timing of a whole move built from
// two ramps and a cruise. Pure functions on values; no dependency on the rest of plan.
//
//  trapezoid : constant acceleration a.            T = |dv|/a,  d = (v0+v1)/2 T
//  scurve7   : jerk-limited, accel <= a, jerk <= j  (three phases +j, 0, -j; the constant-accel
//              phase vanishes when |dv| < a^2/j, leaving two phases per ramp, so a whole
//              move has 5 phases instead of 7: Yu et al. 2020).
//              T = |dv|/a + a/j  (|dv| >= a^2/j) or 2 sqrt(|dv|/j) otherwise; d = (v0+v1)/2 T
//  bezier5   : Marlin S_CURVE_ACCELERATION. Same duration and distance as the trapezoid
//              (T = |dv|/a), velocity v(u) = v0 + dv (10u^3 - 15u^4 + 6u^5), u = t/T, so the
//              peak acceleration is 15/8 a and the peak jerk (10/sqrt 3) a^2/|dv|.
// Units: mm, s, mm/s, mm/s^2, mm/s^3. See docs/trajectory.md for the derivations.
#include <array>
#include <cstddef>

#include "amctl/machine/machine.hpp"

namespace amctl::plan {

using machine::VelocityProfile;

/// Highest degree of the path-distance polynomial s(t) of any piece (bezier5: v quintic).
inline constexpr int kMaxPieceDegree = 6;

/// One polynomial piece of a ramp or move: s(tau) = sum_k c[k] tau^k for 0 <= tau <= duration_s,
/// s measured from the start of the move (c[0] is the distance already travelled).
struct PathPiece {
  double duration_s = 0.0;
  std::array<double, kMaxPieceDegree + 1> c{};
  int degree = 0;
};

/// Shape of one speed change from v0 to v1 (either direction).
struct Ramp {
  VelocityProfile profile = VelocityProfile::trapezoid;
  double v0_mm_s = 0.0;
  double v1_mm_s = 0.0;
  double accel_mm_s2 = 0.0;   ///< trapezoid/bezier5: mean accel; scurve7: accel limit
  double jerk_mm_s3 = 0.0;    ///< scurve7 jerk limit; 0 otherwise
  double duration_s = 0.0;
  double distance_mm = 0.0;
  double jerk_phase_t_s = 0.0;         ///< scurve7: duration of each of the two jerk phases
  double const_accel_t_s = 0.0;        ///< scurve7: constant-accel phase (0 = reduced form)
  double peak_accel_mm_s2 = 0.0;
  double peak_jerk_mm_s3 = 0.0;        ///< trapezoid: 0 inside the ramp (infinite at its ends)
};

/// Kinematic state inside a ramp or move at one time.
struct PathState {
  double s_mm = 0.0;
  double v_mm_s = 0.0;
  double a_mm_s2 = 0.0;
  double j_mm_s3 = 0.0;
};

/// Builds the ramp v0 -> v1. Throws amctl::Error naming the parameter for negative speeds,
/// accel <= 0, or (scurve7) jerk <= 0.
[[nodiscard]] Ramp make_ramp(VelocityProfile profile, double v0_mm_s, double v1_mm_s,
                             double accel_mm_s2, double jerk_mm_s3 = 0.0);

/// Duration of the ramp v0 -> v1 [s].
[[nodiscard]] double ramp_duration_s(VelocityProfile profile, double v0_mm_s, double v1_mm_s,
                                     double accel_mm_s2, double jerk_mm_s3 = 0.0);

/// Minimum distance needed to change speed from v0 to v1 under the profile's limits [mm].
/// Symmetric in v0 and v1 (every profile here is time-reversible).
[[nodiscard]] double ramp_distance_mm(VelocityProfile profile, double v0_mm_s, double v1_mm_s,
                                      double accel_mm_s2, double jerk_mm_s3 = 0.0);

/// Largest speed reachable from v0 within distance_mm (accelerating). By symmetry also the
/// largest speed from which v0 can be reached by braking within distance_mm. [mm/s]
[[nodiscard]] double max_reachable_speed_mm_s(VelocityProfile profile, double v0_mm_s,
                                              double distance_mm, double accel_mm_s2,
                                              double jerk_mm_s3 = 0.0);

/// Highest cruise speed vc, max(v0, v1) <= vc <= max_v, whose ramps v0 -> vc and vc -> v1 fit
/// in distance_mm: ramp_distance(v0, vc) + ramp_distance(vc, v1) <= distance_mm. Trapezoid and
/// bezier5: (3.1) v = sqrt((v0^2 + v1^2)/2 + a D). scurve7: exact root of the quadratic when both
/// ramps reach the accel limit, otherwise a bracketed Newton iteration (bisection fallback) on
/// the increasing function ramp_distance(v0, v) + ramp_distance(v, v1) - D, converged to ~1e-13
/// relative. Returns max(v0, v1) when even the direct ramp v0 -> v1 does not fit. No input
/// checks (hot path of the planner): speeds >= 0, distance > 0, accel, jerk > 0.
[[nodiscard]] double peak_speed_mm_s(VelocityProfile profile, double v0_mm_s, double v1_mm_s,
                                     double distance_mm, double accel_mm_s2, double jerk_mm_s3,
                                     double max_v_mm_s);

/// State at time t (clamped to [0, duration]) inside the ramp; s from the ramp start.
[[nodiscard]] PathState evaluate_ramp(const Ramp& ramp, double t_s);

/// Splits the ramp into polynomial pieces, s offset by s0_mm. Returns the number written
/// (0 for a ramp of zero duration, at most 3).
std::size_t ramp_pieces(const Ramp& ramp, double s0_mm, std::array<PathPiece, 3>& out);

/// Timing of one move of length distance_mm that starts at start_v, ends at end_v and may
/// cruise at up to max_v: accelerate to cruise_v, cruise, decelerate.
struct MoveTiming {
  double start_v_mm_s = 0.0;
  double cruise_v_mm_s = 0.0;
  double end_v_mm_s = 0.0;
  double accel_t_s = 0.0;
  double cruise_t_s = 0.0;
  double decel_t_s = 0.0;
  Ramp accel;
  Ramp decel;
  [[nodiscard]] double duration_s() const { return accel_t_s + cruise_t_s + decel_t_s; }
};

/// The fastest timing of a move whose start/end speeds are reachable within the distance.
/// Throws amctl::Error naming the field when the end speeds cannot be joined within the
/// distance (more than 1e-9 relative), or for non-positive distance/accel/max speed.
[[nodiscard]] MoveTiming time_move(VelocityProfile profile, double distance_mm,
                                   double start_v_mm_s, double max_v_mm_s, double end_v_mm_s,
                                   double accel_mm_s2, double jerk_mm_s3 = 0.0);

/// Polynomial pieces of a whole timed move (accel ramp, cruise, decel ramp), at most 7.
std::size_t move_pieces(const MoveTiming& timing, std::array<PathPiece, 7>& out);

}  // namespace amctl::plan
