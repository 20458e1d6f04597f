#pragma once
// Step rates a drive has to sustain, beside the raw peak of StepperStats.
//
// The raw peak (1 / the shortest interval between two consecutive steps) is dominated by a step
// and its step back: where a motor reverses within a fraction of a step (an extruder's tiny
// retract, a corner's rounding), two steps can be a microsecond apart although the motion asks
// for no speed. Two figures say what the motion needs:
//
//  - the filtered peak: the same shortest interval, over the stream Klipper sends its MCU (a step
//    and the step back within 750 us both dropped, StepDirFilter's rule applied per stepper);
//  - the sustained rate: the largest number of those steps in any window of `window_s`
//    (10 ms by default), divided by the window.
//
// Streaming: steps arrive in time order (all steppers interleaved); memory is one pending step
// per stepper plus the steps of the last window.
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "amctl/steppers/step_filter.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {

class StepRateMeter {
 public:
  /// `window_s` > 0: the sustained window; `filter_s` >= 0: the step+back filter time (0: none).
  explicit StepRateMeter(std::size_t channels, double window_s = kSustainedWindowS,
                         double filter_s = kKlipperSdsFilterTimeS);

  /// Feeds steps in time order.
  void push(std::span<const Step> steps);
  /// The end of the stream: releases the steps still pending.
  void finish();

  [[nodiscard]] double window_s() const { return window_s_; }
  [[nodiscard]] const std::vector<StepRateFigures>& figures() const { return figures_; }

 private:
  struct Channel {
    bool pending = false;
    double pending_t = 0.0;
    std::int32_t pending_dir = 0;
    double last_t = -std::numeric_limits<double>::infinity();
    /// Times of the released steps in the current window: a ring of 2^k slots.
    std::vector<double> ring = std::vector<double>(64);
    std::size_t head = 0;  ///< slot of the oldest
    std::size_t count = 0;
  };
  void release(std::size_t c, double t);

  double window_s_;
  double filter_s_;
  std::vector<Channel> channels_;
  std::vector<StepRateFigures> figures_;
};

}  // namespace amctl::steppers
