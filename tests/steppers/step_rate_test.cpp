// The filtered peak and the sustained step rate (StepRateMeter) against independent
// computations: a steady stream's rate in closed form; a step-and-back pair that only the raw
// peak sees; and on random streams the filtered peak against StepDirFilter's released steps
// (the same rule, implemented over all steppers at once) and the sustained rate against a
// brute-force count over every window.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/steppers/step_filter.hpp"
#include "amctl/steppers/step_rate.hpp"

namespace amctl::steppers {
namespace {

TEST(StepRateMeter, SteadyStreamGivesItsRateForBothFigures) {
  // 10 000 steps/s for 0.5 s: interval 100 us, 100 steps in every 10 ms window.
  StepRateMeter m(1);
  std::vector<Step> in;
  for (int k = 0; k < 5000; ++k) in.push_back({k * 1e-4, 0, +1});
  m.push(in);
  m.finish();
  const StepRateFigures& f = m.figures()[0];
  EXPECT_NEAR(f.filtered_peak_step_rate_steps_s(), 10000.0, 1e-6);
  EXPECT_NEAR(f.sustained_step_rate_steps_s, 10000.0, 1e-6);
}

TEST(StepRateMeter, AStepAndItsStepBackRaiseOnlyTheRawPeak) {
  // 1 000 steps/s forward; at 20.5 ms a step back and 1 us later forward again (a reversal
  // within a step): the raw peak is 1 / 1 us; Klipper drops the 20 ms step and the step back
  // (500 us apart), so the 20 ms step is in effect taken at 20.501 ms and the filtered peak is
  // the rate between it and the 21 ms step: 1 / 499 us.
  StepRateMeter m(1);
  std::vector<Step> in;
  for (int k = 0; k <= 20; ++k) in.push_back({k * 1e-3, 0, +1});
  in.push_back({20.5e-3, 0, -1});
  in.push_back({20.501e-3, 0, +1});
  for (int k = 21; k <= 40; ++k) in.push_back({k * 1e-3, 0, +1});
  m.push(in);
  m.finish();
  const StepRateFigures& f = m.figures()[0];
  EXPECT_NEAR(f.filtered_min_interval_s, 21e-3 - 20.501e-3, 1e-12);
  EXPECT_NEAR(f.filtered_peak_time_s, 21e-3, 1e-15);
  // 10 steps in every 10 ms window at most: 1 000 steps/s (rounded to the window's 100 steps/s
  // resolution, never above the filtered peak).
  EXPECT_LE(f.sustained_step_rate_steps_s, 1100.0);
  EXPECT_GE(f.sustained_step_rate_steps_s, 900.0);
}

TEST(StepRateMeter, AgreesWithTheFilterAndABruteForceWindowCount) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> gap(1e-6, 2e-3);
  std::bernoulli_distribution back(0.1);
  std::uniform_int_distribution<int> which(0, 2);
  std::vector<Step> in;
  double t = 0.0;
  int dir[3] = {1, 1, 1};
  for (int k = 0; k < 20000; ++k) {
    t += gap(rng) / 3.0;
    const auto c = static_cast<std::uint32_t>(which(rng));
    if (back(rng)) dir[c] = -dir[c];
    in.push_back({t, c, dir[c]});
  }
  const double window = 0.005;
  StepRateMeter m(3, window);
  StepDirFilter filter(3);
  std::vector<Step> kept;
  // Fed in uneven chunks, as moves would.
  for (std::size_t i = 0; i < in.size(); i += 37) {
    const std::span<const Step> chunk(in.data() + i, std::min<std::size_t>(37, in.size() - i));
    m.push(chunk);
    filter.push(chunk, kept);
  }
  m.finish();
  filter.finish(kept);
  for (std::uint32_t c = 0; c < 3; ++c) {
    EXPECT_EQ(m.figures()[c].filtered_min_interval_s, filter.stats()[c].min_interval_s) << c;
    std::vector<double> times;
    for (const Step& s : kept) {
      if (s.stepper == c) times.push_back(s.time_s);
    }
    std::size_t best = 0;
    for (std::size_t j = 0; j < times.size(); ++j) {
      std::size_t n = 0;
      for (std::size_t i = 0; i <= j; ++i) n += times[i] > times[j] - window ? 1 : 0;
      best = std::max(best, n);
    }
    const double brute = std::min(static_cast<double>(best) / window,
                                  1.0 / filter.stats()[c].min_interval_s);
    EXPECT_NEAR(m.figures()[c].sustained_step_rate_steps_s, brute, 1e-9 * brute) << c;
  }
}

TEST(StepRateMeter, RefusesAWindowOrFilterTimeItCannotUse) {
  EXPECT_THROW(StepRateMeter(1, 0.0), Error);
  EXPECT_THROW(StepRateMeter(1, std::nan("")), Error);
  EXPECT_THROW(StepRateMeter(1, 0.01, -1.0), Error);
}

}  // namespace
}  // namespace amctl::steppers
