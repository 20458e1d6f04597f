#pragma once
// Speed over print time at a bounded level of detail (docs/report.md, "Level of detail").
//
// A sink of the plan stream that keeps, for each of at most max_buckets equal time buckets
// over the whole print, the minimum and maximum XYZ speed of the nozzle in the bucket and the
// feature that took most of its time, and the distance travelled (its mean speed). The print's length is not known while streaming, so
// the bucket width starts small and doubles (merging neighbours pairwise) whenever the print
// outgrows max_buckets buckets: at the end there are between max_buckets/2 and max_buckets
// buckets, whatever the length of the print. Memory: O(max_buckets x features per bucket).
//
// Within a move each phase (accel ramp, cruise, decel ramp) is monotone in speed, so the
// extremes over a bucket's share of a phase are the speeds at the clipped phase ends (ramp
// speeds evaluated exactly with plan::evaluate_ramp). Time not covered by any move (dwells,
// gaps) counts as speed 0. Extrude-only moves (retract, prime) have XYZ speed 0.
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "amctl/plan/stream.hpp"

namespace amctl::report {

struct SpeedBucket {
  float min_speed_mm_s = 0.0F;
  float max_speed_mm_s = 0.0F;
  double covered_s = 0.0;  ///< time covered by moves (the rest of the bucket is standing still)
  /// XYZ distance travelled in the bucket [mm] (the speed's integral: exact on linear ramps
  /// and cruise, the trapezoid rule between bucket edges on S-curve ramps): the bucket's mean
  /// speed is distance_mm / the bucket's width.
  double distance_mm = 0.0;
  /// Time per feature (PlannedMove::feature) of the moves in the bucket; a handful at most.
  std::vector<std::pair<std::uint16_t, float>> feature_time_s;
  [[nodiscard]] bool empty() const { return covered_s <= 0.0; }
  /// The feature with most time, -1 for a bucket without moves.
  [[nodiscard]] int dominant_feature() const;
};

class SpeedLodSink final : public plan::Sink {
 public:
  /// max_buckets >= 2 (even); initial_bucket_s > 0 is the finest width ever used.
  explicit SpeedLodSink(std::size_t max_buckets = 4096, double initial_bucket_s = 0.01);
  void consume(const plan::PlanBatch& batch) override;
  void finish(const plan::StreamSummary& summary) override;

  /// Width of every bucket [s]; bucket k covers [k w, (k+1) w).
  [[nodiscard]] double bucket_s() const { return bucket_s_; }
  /// The buckets up to the end of the print (complete after finish()): empty buckets and
  /// the uncovered part of a bucket count as speed 0 there.
  [[nodiscard]] const std::vector<SpeedBucket>& buckets() const { return buckets_; }
  [[nodiscard]] std::size_t max_buckets() const { return max_buckets_; }
  [[nodiscard]] double end_time_s() const { return end_time_s_; }

 private:
  void add_move(const plan::PlannedMove& m);
  void add_span(double t0_s, double t1_s, double v0_mm_s, double v1_mm_s, std::uint16_t feature,
                const plan::PlannedMove& m, int phase);
  void touch(std::size_t k, float vmin, float vmax, double dt_s, double distance_mm, std::uint16_t feature);
  void grow_to(double t_s);

  std::size_t max_buckets_;
  double bucket_s_;
  double end_time_s_ = 0.0;
  std::vector<SpeedBucket> buckets_;
};

/// Speed [mm/s] of move m at time t_s into phase `phase` (0 accel, 1 cruise, 2 decel).
[[nodiscard]] double speed_in_phase(const plan::PlannedMove& m, int phase, double t_s);

}  // namespace amctl::report
