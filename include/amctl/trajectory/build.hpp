#pragma once
// Building timed moves by hand (tests, examples, the seed 000 sweep): a straight move from
// one point to another with given start/end speeds, using plan::time_move for its phases.
// This is not a planner: junction speeds are the caller's choice.
#include <array>
#include <span>
#include <vector>

#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/velocity_profile.hpp"

namespace amctl::trajectory {

struct MoveSpec {
  std::array<double, 4> to_mm{};     ///< X, Y, Z, E target
  double max_v_mm_s = 100.0;
  double end_v_mm_s = 0.0;           ///< junction speed into the next move
  std::uint64_t line = 0;
  std::int32_t layer = -1;
  std::uint16_t feature = 0;
};

/// One timed move from `from` to spec.to_mm starting at start_time_s with speed start_v.
[[nodiscard]] plan::PlannedMove timed_move(const std::array<double, 4>& from_mm,
                                           const MoveSpec& spec, double start_v_mm_s,
                                           double start_time_s, double accel_mm_s2,
                                           plan::VelocityProfile profile, double jerk_mm_s3);

/// Chains moves from `start`, each beginning where and when the previous ended, with the
/// previous move's end speed as its start speed.
[[nodiscard]] std::vector<plan::PlannedMove> chain_moves(const std::array<double, 4>& start_mm,
                                                         std::span<const MoveSpec> specs,
                                                         double accel_mm_s2,
                                                         plan::VelocityProfile profile,
                                                         double jerk_mm_s3 = 0.0);

}  // namespace amctl::trajectory
