#include "amctl/steppers/step_filter.hpp"

#include <limits>

namespace amctl::steppers {

StepDirFilter::StepDirFilter(std::size_t channels, double window_s)
    : window_s_(window_s),
      pending_(channels, -1),
      pairs_(channels, 0),
      stats_(channels),
      last_release_s_(channels, -std::numeric_limits<double>::infinity()) {}

void StepDirFilter::release(const Held& h, std::vector<Step>& out) {
  if (h.dropped) return;
  const Step& s = h.step;
  StepperStats& st = stats_[s.stepper];
  const double interval = s.time_s - last_release_s_[s.stepper];
  if (interval < st.min_interval_s) {
    st.min_interval_s = interval;
    st.peak_time_s = s.time_s;
  }
  last_release_s_[s.stepper] = s.time_s;
  ++st.steps;
  if (s.direction > 0) ++st.steps_positive;
  else ++st.steps_negative;
  st.position_steps += s.direction;
  out.push_back(s);
}

void StepDirFilter::push(std::span<const Step> in, std::vector<Step>& out) {
  for (const Step& s : in) {
    // Steps older than the window can no longer be removed by this one or any later one.
    while (!held_.empty() && held_.front().step.time_s <= s.time_s - window_s_) {
      const std::uint64_t index = first_index_;
      release(held_.front(), out);
      if (pending_[held_.front().step.stepper] == static_cast<std::int64_t>(index)) {
        pending_[held_.front().step.stepper] = -1;
      }
      held_.pop_front();
      ++first_index_;
    }
    std::int64_t& p = pending_[s.stepper];
    if (p >= 0) {
      Held& prev = held_[static_cast<std::size_t>(p - static_cast<std::int64_t>(first_index_))];
      if (prev.step.direction != s.direction && s.time_s - prev.step.time_s < window_s_) {
        // stepcompress_append: roll the pending step back and drop this one too.
        prev.dropped = true;
        p = -1;
        ++pairs_[s.stepper];
        continue;
      }
    }
    held_.push_back({s, false});
    p = static_cast<std::int64_t>(first_index_ + held_.size() - 1);
  }
}

void StepDirFilter::finish(std::vector<Step>& out) {
  for (const Held& h : held_) release(h, out);
  first_index_ += held_.size();
  held_.clear();
  std::fill(pending_.begin(), pending_.end(), -1);
}

}  // namespace amctl::steppers
