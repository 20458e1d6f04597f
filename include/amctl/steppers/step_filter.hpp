#pragma once
// Klipper's step+direction+step filter (klippy/chelper/stepcompress.c, stepcompress_append,
// read at 84104bbb; docs/steppers.md section 7): the MCU gets a step only once the next step of
// the same stepper is known; when that next step goes the other way less than SDS_FILTER_TIME
// (750 us) later, both are dropped, so a motor at a reversal does not step forward and back
// within a fraction of a millisecond. amctl's exact steps keep such pairs; this filter gives the
// stream Klipper sends (`amctl steps --step-filter klipper`).
//
// Streaming: steps arrive in time order (all steppers interleaved) and leave in time order once
// no later step can remove them (750 us behind the newest input); memory is the steps of the
// last 750 us.
#include <cstdint>
#include <deque>
#include <span>
#include <vector>

#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {

inline constexpr double kKlipperSdsFilterTimeS = 750e-6;  ///< stepcompress.c SDS_FILTER_TIME

class StepDirFilter {
 public:
  explicit StepDirFilter(std::size_t channels, double window_s = kKlipperSdsFilterTimeS);

  /// Feeds steps in time order; appends to `out`, in time order, those no later input can
  /// remove any more.
  void push(std::span<const Step> in, std::vector<Step>& out);
  /// Releases every step still held (the end of the stream).
  void finish(std::vector<Step>& out);

  /// Step pairs removed per channel.
  [[nodiscard]] const std::vector<std::uint64_t>& pairs_removed() const { return pairs_; }
  /// Counts, position and peak rate of what was released, per channel.
  [[nodiscard]] const std::vector<StepperStats>& stats() const { return stats_; }

 private:
  struct Held {
    Step step;
    bool dropped = false;
  };
  void release(const Held& h, std::vector<Step>& out);

  double window_s_;
  std::deque<Held> held_;
  std::uint64_t first_index_ = 0;                 ///< index of held_.front() since the start
  std::vector<std::int64_t> pending_;             ///< index of each channel's last kept step, -1
  std::vector<std::uint64_t> pairs_;
  std::vector<StepperStats> stats_;
  std::vector<double> last_release_s_;
};

}  // namespace amctl::steppers
