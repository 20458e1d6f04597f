// Shaped evaluation of the plan (shaped_trajectory.hpp).
#include "amctl/shaping/shaped_trajectory.hpp"

#include <algorithm>

#include "amctl/core/error.hpp"

namespace amctl::shaping {

AppliedPulses applied_pulses(const Shaper& shaper) {
  AppliedPulses p;
  p.weights = shaper.normalized_amplitudes();
  double ts = 0.0;
  for (std::size_t i = 0; i < p.weights.size(); ++i) ts += p.weights[i] * shaper.times_s[i];
  p.delays_s.reserve(p.weights.size());
  for (double t : shaper.times_s) p.delays_s.push_back(t - ts);
  return p;
}

ShapedCursor::ShapedCursor(std::span<const plan::PlannedMove> moves, const AxisShapers& shapers) {
  const auto tap_at = [&](double delay) -> Tap& {
    for (Tap& t : taps_) {
      if (t.delay_s == delay) return t;
    }
    taps_.push_back(Tap{delay, {}, trajectory::Cursor(moves)});
    return taps_.back();
  };
  // Every Tap owns a Cursor that points into itself once used: reserve so none ever moves.
  std::size_t most = 1;
  for (const auto& s : shapers.xyz) most += s ? s->amplitudes.size() : 0;
  taps_.reserve(most);
  for (std::size_t axis = 0; axis < trajectory::kAxes; ++axis) {
    const Shaper* s = axis < 3 && shapers.xyz[axis] ? &*shapers.xyz[axis] : nullptr;
    if (s == nullptr) {
      tap_at(0.0).weight[axis] += 1.0;
      continue;
    }
    const AppliedPulses p = applied_pulses(*s);
    for (std::size_t i = 0; i < p.weights.size(); ++i) tap_at(p.delays_s[i]).weight[axis] += p.weights[i];
  }
  AMCTL_CHECK(!taps_.empty(), "every axis has at least one tap");
  for (const Tap& t : taps_) {
    max_delay_s_ = std::max(max_delay_s_, t.delay_s);
    min_delay_s_ = std::min(min_delay_s_, t.delay_s);
  }
}

trajectory::AxisState ShapedCursor::evaluate(double t_s) {
  trajectory::AxisState out;
  out.t_s = t_s;
  for (Tap& tap : taps_) {
    const trajectory::AxisState s = tap.cursor.evaluate(t_s - tap.delay_s);
    for (std::size_t i = 0; i < trajectory::kAxes; ++i) {
      const double w = tap.weight[i];
      if (w == 0.0) continue;
      out.pos_mm[i] += w * s.pos_mm[i];
      out.vel_mm_s[i] += w * s.vel_mm_s[i];
      out.acc_mm_s2[i] += w * s.acc_mm_s2[i];
      out.jerk_mm_s3[i] += w * s.jerk_mm_s3[i];
    }
  }
  return out;
}

}  // namespace amctl::shaping
