#pragma once
// The planner's output: one fully timed move. Later modules (trajectory, dynamics,
// compensation, estimation) consume a stream of these.
#include <array>
#include <cstdint>

#include "amctl/machine/machine.hpp"

namespace amctl::plan {

/// A straight move from start_mm along a fixed direction, timed as
///   [accel_t_s | cruise_t_s | decel_t_s]
/// Trapezoid: constant accel accel_mm_s2 from start_v to cruise_v, cruise, then constant
/// decel to end_v. For jerk-limited profiles (profile != trapezoid) the same three
/// phases exist but each ramp follows the profile's shape with the same end speeds;
/// accel_t_s / decel_t_s are then the ramp durations of that shape.
struct PlannedMove {
  double start_time_s = 0.0;             ///< print time at which the move starts
  std::array<double, 4> start_mm{};      ///< X, Y, Z, E at move start (machine coordinates)
  std::array<double, 4> axes_r{};        ///< per-axis displacement / distance_mm (E ratio too)
  double distance_mm = 0.0;              ///< XYZ length; |E| for an extrude-only move
  double start_v_mm_s = 0.0;
  double cruise_v_mm_s = 0.0;
  double end_v_mm_s = 0.0;
  double accel_mm_s2 = 0.0;              ///< magnitude used on both ramps
  double jerk_mm_s3 = 0.0;               ///< for scurve7; 0 for trapezoid
  double accel_t_s = 0.0;
  double cruise_t_s = 0.0;
  double decel_t_s = 0.0;
  machine::VelocityProfile profile = machine::VelocityProfile::trapezoid;
  bool extrude_only = false;             ///< no XYZ motion (retract, prime)
  std::uint64_t line = 0;                ///< G-code line that produced it (1-based)
  std::int32_t layer = -1;               ///< slicer layer index, -1 before the first
  std::uint16_t feature = 0;             ///< index into the feature-name table of the run

  [[nodiscard]] double duration_s() const { return accel_t_s + cruise_t_s + decel_t_s; }
  [[nodiscard]] double end_time_s() const { return start_time_s + duration_s(); }
  [[nodiscard]] bool is_extruding() const { return !extrude_only && axes_r[3] > 0.0; }
};

}  // namespace amctl::plan
