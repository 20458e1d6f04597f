#include "amctl/steppers/step_rate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "amctl/core/error.hpp"

namespace amctl::steppers {

StepRateMeter::StepRateMeter(std::size_t channels, double window_s, double filter_s)
    : window_s_(window_s), filter_s_(filter_s), channels_(channels), figures_(channels) {
  if (!(window_s > 0.0) || !std::isfinite(window_s)) {
    throw Error(fmt::format("step-rate window must be a finite time > 0 s, got {}", window_s));
  }
  if (!(filter_s >= 0.0) || !std::isfinite(filter_s)) {
    throw Error(fmt::format("step+back filter time must be a finite time >= 0 s, got {}", filter_s));
  }
}

void StepRateMeter::release(std::size_t c, double t) {
  Channel& ch = channels_[c];
  StepRateFigures& f = figures_[c];
  const double interval = t - ch.last_t;
  if (interval < f.filtered_min_interval_s) {
    f.filtered_min_interval_s = interval;
    f.filtered_peak_time_s = t;
  }
  ch.last_t = t;
  // The window (t - window, t]: a step exactly one window earlier is outside, so a steady
  // rate r counts r * window steps.
  // (A relative 1e-9 of the window keeps a step exactly one window back outside despite
  // round-off in the step times.)
  const double start = t - window_s_ * (1.0 - 1e-9);
  std::size_t mask = ch.ring.size() - 1;
  while (ch.count > 0 && ch.ring[ch.head] <= start) {
    ch.head = (ch.head + 1) & mask;
    --ch.count;
  }
  if (ch.count == ch.ring.size()) {  // full: unroll into a ring twice the size
    std::vector<double> bigger(2 * ch.ring.size());
    for (std::size_t i = 0; i < ch.count; ++i) bigger[i] = ch.ring[(ch.head + i) & mask];
    ch.ring.swap(bigger);
    ch.head = 0;
    mask = ch.ring.size() - 1;
  }
  ch.ring[(ch.head + ch.count) & mask] = t;
  ++ch.count;
  if (static_cast<double>(ch.count) <= f.sustained_step_rate_steps_s * window_s_) return;
  // A count over a window resolves the rate to 1 / window and can round a steady rate up by
  // that much; no window's mean exceeds the shortest interval's rate, so that bounds it.
  const double rate = std::min(static_cast<double>(ch.count) / window_s_,
                               1.0 / f.filtered_min_interval_s);
  if (rate > f.sustained_step_rate_steps_s) {
    f.sustained_step_rate_steps_s = rate;
    f.sustained_time_s = t;
  }
}

void StepRateMeter::push(std::span<const Step> steps) {
  for (const Step& s : steps) {
    Channel& ch = channels_[s.stepper];
    if (ch.pending) {
      // StepDirFilter's rule for one stepper: the pending step and this one going back within
      // the filter time both vanish; otherwise the pending step is final.
      if (s.direction != ch.pending_dir && s.time_s - ch.pending_t < filter_s_) {
        ch.pending = false;
        continue;
      }
      release(s.stepper, ch.pending_t);
    }
    ch.pending = true;
    ch.pending_t = s.time_s;
    ch.pending_dir = s.direction;
  }
}

void StepRateMeter::finish() {
  for (std::size_t c = 0; c < channels_.size(); ++c) {
    if (channels_[c].pending) {
      channels_[c].pending = false;
      release(c, channels_[c].pending_t);
    }
  }
}

}  // namespace amctl::steppers
