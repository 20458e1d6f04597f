#pragma once
// Peak acceleration and jerk of the ramps a plan commands: the one rule used by
// `estimate --compare-profiles` and `simulate` (docs/planner.md, "Jerk-limited profiles").
//  - Only toolhead (XYZ) ramps count: extrude-only moves are left out (Klipper gives them an
//    acceleration of 1e8 mm/s^2, which would say nothing about the machine).
//  - A speed change below round-off (|dv| <= 1e-9 max(1, v0, v1)) is not a ramp: a Bezier
//    over it would claim a huge jerk.
//  - A trapezoid's jerk is a step: unbounded, reported as +infinity (null in JSON).
#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::plan {

struct ProfilePeaks {
  double peak_accel_mm_s2 = 0.0;  ///< largest acceleration inside any XYZ ramp
  double peak_jerk_mm_s3 = 0.0;   ///< largest jerk inside any XYZ ramp; +inf for trapezoid steps
  std::uint64_t ramps = 0;        ///< ramps counted

  /// Adds the (up to two) ramps of one move.
  void add(const PlannedMove& move);
};

/// ProfilePeaks over the stream.
class ProfilePeaksSink final : public Sink {
 public:
  void consume(const PlanBatch& batch) override {
    for (const PlannedMove& m : batch.moves) peaks_.add(m);
  }
  [[nodiscard]] const ProfilePeaks& peaks() const { return peaks_; }

 private:
  ProfilePeaks peaks_;
};

}  // namespace amctl::plan
