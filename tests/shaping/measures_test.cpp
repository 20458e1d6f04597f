// Smoothing, max accel and remaining vibration against closed forms.
#include "amctl/shaping/measures.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl::shaping {
namespace {

TEST(Smoothing, UndampedZvHasClosedForms) {
  // zeta = 0: a = [1/2, 1/2] at [0, T1], centre T1/2. With h = T1/2:
  //   offset_90 = sqrt2 / 2 (scv + accel h / 2) h,  offset_180 = accel h^2 / 2.
  const double f = 20.0;
  const Shaper s = make_shaper("zv", f, 0.0);
  const double h = 0.25 / f;
  for (double accel : {500.0, 3000.0, 5000.0, 12000.0}) {
    for (double scv : {0.0, 5.0, 20.0}) {
      const double o90 = std::numbers::sqrt2 / 2.0 * (scv + 0.5 * accel * h) * h;
      const double o180 = 0.5 * accel * h * h;
      EXPECT_NEAR(smoothing_mm(s, accel, scv), std::max(o90, o180), 1e-15) << accel << " " << scv;
    }
  }
}

TEST(MaxAccel, UndampedZvSolvesTheSmoothingEquation) {
  // The accel where max(offset_90, offset_180) reaches 0.12 mm: the smaller of the roots of
  // offset_90(a) = 0.12 (linear in a) and offset_180(a) = 0.12.
  for (double f : {20.0, 35.0, 60.0}) {
    const Shaper s = make_shaper("zv", f, 0.0);
    const double h = 0.25 / f;
    for (double scv : {0.0, 5.0, 10.0}) {
      const double a90 = (0.12 / (std::numbers::sqrt2 / 2.0 * h) - scv) / (0.5 * h);
      const double a180 = 0.12 / (0.5 * h * h);
      const double expect = std::min(a90, a180);
      EXPECT_NEAR(max_accel_mm_s2(s, scv), expect, 1e-6 * expect) << f << " " << scv;
      EXPECT_LE(smoothing_mm(s, max_accel_mm_s2(s, scv), scv), 0.12);
    }
  }
}

TEST(MaxAccel, ZeroWhenEvenATinyAccelSmoothsTooMuch) {
  // At 5 Hz a ZV shaper lasts 0.1 s: scv alone rounds a corner by more than a micrometre.
  const Shaper s = make_shaper("zv", 5.0, 0.1);
  EXPECT_EQ(max_accel_mm_s2(s, 5.0, 1e-3), 0.0);
}

TEST(RemainingVibration, IsOneForASingleImpulseAndNearlyOneFarBelowTheShaper) {
  // A single impulse leaves everything; far below the design frequency a shaper is a short
  // delay and leaves nearly all (less only the decay zeta w T_last over its duration).
  Shaper one;
  one.amplitudes = {1.0};
  one.times_s = {0.0};
  EXPECT_DOUBLE_EQ(remaining_vibration(one, 37.0, 0.1), 1.0);
  EXPECT_NEAR(remaining_vibration(make_shaper("mzv", 50.0, 0.1), 0.01, 0.1), 1.0, 1e-4);
}

TEST(VibrationCurve, RejectsBadFrequenciesAndDampingNamingTheParameter) {
  const Shaper s = make_shaper("zv", 40.0, 0.1);
  const std::vector<double> good = {10.0, 40.0};
  const auto c = vibration_curve(s, good, 0.1);
  ASSERT_EQ(c.remaining_fraction.size(), 2u);
  EXPECT_LT(c.remaining_fraction[1], 1e-13);
  const std::vector<double> bad = {10.0, 0.0};
  EXPECT_THROW((void)vibration_curve(s, bad, 0.1), Error);
  try {
    (void)vibration_curve(s, good, 1.0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("test_damping_ratio must be"), std::string::npos);
  }
}

}  // namespace
}  // namespace amctl::shaping
