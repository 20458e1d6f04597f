// The excitation caveat of `resonance calibrate`: Klipper's rule assumes its own test (pulses
// of accel_per_hz * f). The same mode excited by a constant-amplitude sweep and by Klipper's
// pattern (the synthetic records differ only in the excitation): Klipper's rule on the sweep's
// PSD reweighted by f^2 picks what the rule picks on Klipper's own excitation, and not what it
// picks on the sweep as recorded.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/synthetic.hpp"

namespace amctl::resonance {
namespace {

CalibrationReport run(const SyntheticSweep& s, bool with_sweep) {
  CalibrateOptions o;
  o.axis = s.axis;
  if (with_sweep) o.sweep = SweepExcitation{s.f0_hz, s.f1_hz, s.rate_hz_s, s.accel_mm_s2};
  return calibrate(parse_accel_text(synthetic_sweep_csv(s), "synthetic"), "synthetic", o);
}

TEST(ExcitationCaveat, ReweightedSweepPicksWhatKlipperPicksOnItsOwnExcitation) {
  SyntheticSweep sweep;  // 42 Hz, damping 0.08, 5 -> 120 Hz at 10 Hz/s
  sweep.natural_freq_hz = 40.0;
  sweep.damping_ratio = 0.2;
  sweep.accel_mm_s2 = 4000.0;
  SyntheticSweep klipper = sweep;
  klipper.accel_per_hz_mm_s2 = 60.0;  // Klipper's pattern: a = 60 f

  const CalibrationReport own = run(klipper, false);      // a Klipper raw record: no caveat
  EXPECT_FALSE(own.caveat.has_value());
  const CalibrationReport rec = run(sweep, true);
  ASSERT_TRUE(rec.caveat.has_value());
  EXPECT_EQ(rec.caveat->excitation, "constant_amplitude_sweep");
  ASSERT_TRUE(rec.caveat->reweighted.has_value());
  const ShaperFit& want = own.klipper.recommended;
  const ShaperFit& got = rec.caveat->reweighted->recommended;
  EXPECT_EQ(got.name, want.name);
  EXPECT_NEAR(got.freq_hz, want.freq_hz, 1.0);  // 5 steps of Klipper's 0.2 Hz grid (measured: equal,
                                                // 3hump_ei at 68.6 Hz; the sweep as recorded: mzv 26.4 Hz)
  // The rule on the sweep as recorded is biased low.
  EXPECT_LT(rec.klipper.recommended.freq_hz, want.freq_hz - 3.0);
}

TEST(ExcitationCaveat, ForeignFormatWithoutSweepSaysTheExcitationIsUnknown) {
  const std::string corpus = "#time_s,accel_x_mm_s2,accel_y_mm_s2,accel_z_mm_s2\n";
  std::string text = corpus;
  for (int i = 0; i < 4000; ++i) {
    const double t = i / 1600.0;
    text += std::to_string(t) + "," + std::to_string(100 * std::sin(2 * M_PI * 40 * t)) + ",0,9800\n";
  }
  CalibrateOptions o;
  const CalibrationReport r = calibrate(parse_accel_text(text, "c.csv"), "c.csv", o);
  ASSERT_EQ(r.format, RecordFormat::corpus);
  ASSERT_TRUE(r.caveat.has_value());
  EXPECT_EQ(r.caveat->excitation, "unknown");
  EXPECT_FALSE(r.caveat->reweighted.has_value());
  EXPECT_NE(to_text(r).find("--sweep F0,F1,RATE,ACCEL"), std::string::npos);
  EXPECT_TRUE(to_json(r)["excitation_caveat"]["klipper_rule_on_reweighted_psd"].is_null());
}

}  // namespace
}  // namespace amctl::resonance
