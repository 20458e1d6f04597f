// Identification with the sweep known: synthetic records with a known mode are recovered
// within 1 % (frequency) and 10 % (damping ratio), as issue 9 asks.
#include <gtest/gtest.h>

#include <cstdio>

#include "amctl/core/error.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/sweep.hpp"
#include "amctl/resonance/synthetic.hpp"
#include "test_support.hpp"

namespace amctl::resonance {
namespace {

SweepIdentification identify(const SyntheticSweep& s) {
  const AccelFile f = parse_accel_text(synthetic_sweep_csv(s), "synthetic");
  return identify_sweep(f.record, s.axis, SweepExcitation{s.f0_hz, s.f1_hz, s.rate_hz_s, s.accel_mm_s2});
}

TEST(Sweep, ParsesAndRejects) {
  const SweepExcitation s = parse_sweep("5,80,4,4000");
  EXPECT_EQ(s.f0_hz, 5.0);
  EXPECT_EQ(s.f1_hz, 80.0);
  EXPECT_EQ(s.rate_hz_s, 4.0);
  EXPECT_EQ(s.accel_mm_s2, 4000.0);
  EXPECT_THROW((void)parse_sweep("5,80,4"), Error);
  EXPECT_THROW((void)parse_sweep("5,80,x,4000"), Error);
  EXPECT_THROW((void)parse_sweep("80,5,4,4000"), Error);
  EXPECT_THROW((void)parse_sweep("5,80,4,-1"), Error);
}

struct Case {
  double f_hz;
  double zeta;
  double fs_hz;
  double noise;
  char axis;
  double rate_hz_s;
};

class SyntheticModes : public ::testing::TestWithParam<Case> {};

TEST_P(SyntheticModes, RecoveredWithin1And10Percent) {
  const Case c = GetParam();
  SyntheticSweep s = test::reference_synthetic();
  s.natural_freq_hz = c.f_hz;
  s.damping_ratio = c.zeta;
  s.sample_rate_hz = c.fs_hz;
  s.noise_mm_s2 = c.noise;
  s.axis = c.axis;
  s.rate_hz_s = c.rate_hz_s;
  s.f1_hz = std::min(120.0, 0.4 * c.fs_hz);
  const SweepIdentification id = identify(s);
  SCOPED_TRACE(::testing::Message() << "t0 " << id.sweep_start_s << " k " << id.time_scale
                                    << " corr " << id.alignment_peak << " f " << id.model.natural_frequency_hz
                                    << " zeta " << id.model.damping_ratio << " kind "
                                    << to_string(id.model.kind) << " bins "
                                    << id.model.bins_used << " rms " << id.model.rms_residual);
  std::printf("mode %.1f Hz zeta %.3f at %.0f Hz: f_n %.4f +- %.4f Hz, zeta %.5f +- %.5f, g %.4f, %s\n",
              c.f_hz, c.zeta, c.fs_hz, id.model.natural_frequency_hz, id.model.natural_frequency_std_hz,
              id.model.damping_ratio, id.model.damping_ratio_std, id.model.gain,
              std::string(to_string(id.model.kind)).c_str());
  EXPECT_NEAR(id.model.natural_frequency_hz, c.f_hz, 0.01 * c.f_hz);
  EXPECT_NEAR(id.model.damping_ratio, c.zeta, 0.1 * c.zeta);
  EXPECT_NEAR(id.model.gain, 1.0, 0.05);
  EXPECT_EQ(id.model.kind, ModeKind::base_damped);
  EXPECT_NEAR(id.sweep_start_s, s.lead_s, 0.05);
  // The stated uncertainty is consistent with the error (within 5 sigma, or 0.2 %).
  EXPECT_LE(std::abs(id.model.natural_frequency_hz - c.f_hz),
            std::max(5.0 * id.model.natural_frequency_std_hz, 0.002 * c.f_hz));
}

INSTANTIATE_TEST_SUITE_P(
    Modes, SyntheticModes,
    // A lightly damped mode needs a slow sweep (here 2 Hz/s for zeta 0.03: the sweep crosses
    // the half-power band 2 zeta f in about 20 ring-down times 1 / (zeta w)).
    ::testing::Values(Case{42.0, 0.08, 3200.0, 50.0, 'x', 10.0}, Case{25.0, 0.05, 1600.0, 50.0, 'y', 10.0},
                      Case{60.0, 0.15, 3200.0, 200.0, 'x', 10.0}, Case{38.0, 0.03, 1600.0, 20.0, 'y', 2.0}));

TEST(Sweep, RejectsASweepLongerThanTheRecord) {
  SyntheticSweep s = test::reference_synthetic();
  const AccelFile f = parse_accel_text(synthetic_sweep_csv(s), "synthetic");
  EXPECT_THROW((void)identify_sweep(f.record, 'x', SweepExcitation{5, 120, 1, 3000}), Error);
  EXPECT_THROW((void)identify_sweep(f.record, 'x', SweepExcitation{5, 2000, 10, 3000}), Error);
}

TEST(Sweep, EnderRepeatsAgree) {
  const auto dir = test::corpus_accel_dir();
  if (!dir) GTEST_SKIP() << "corpus absent (../shared/corpus/accel or $AMCTL_CORPUS_DIR/accel)";
  for (int i = 1; i <= 3; ++i) {
    const AccelFile f = read_accel_file((*dir / ("ender3v2neo_y_sweep_" + std::to_string(i) + ".csv")).string());
    const SweepIdentification id = identify_sweep(f.record, 'y', parse_sweep("5,80,4,4000"));
    // docs/resonance.md §6: a heavily damped mode near 43 Hz (its gain peaks near 40 Hz); the
    // record's clock runs 1.7 % fast against the sweep's.
    EXPECT_NEAR(id.model.natural_frequency_hz, 43.0, 1.0) << i;
    EXPECT_NEAR(id.model.damping_ratio, 0.24, 0.03) << i;
    EXPECT_EQ(id.model.kind, ModeKind::ground_damped) << i;
    EXPECT_NEAR(id.time_scale, 1.017, 0.002) << i;
    EXPECT_NEAR(id.sweep_start_s, 2.45, 0.1) << i;
  }
}

}  // namespace
}  // namespace amctl::resonance
