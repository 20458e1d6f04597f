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

SweepIdentification identify(const SyntheticSweep& s, int modes = 0) {
  const AccelFile f = parse_accel_text(synthetic_sweep_csv(s), "synthetic");
  return identify_sweep(f.record, s.axis, SweepExcitation{s.f0_hz, s.f1_hz, s.rate_hz_s, s.accel_mm_s2}, modes);
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
  for (const ModeEstimate& e : id.model.modes) {
    std::printf("  mode f_n %.4f Hz, zeta %.5f, g %.4f, peak %.3f; BIC %s\n", e.natural_frequency_hz, e.damping_ratio,
                e.gain, e.peak_gain, ::testing::PrintToString(id.model.bic).c_str());
  }
  EXPECT_NEAR(id.model.natural_frequency_hz, c.f_hz, 0.01 * c.f_hz);
  EXPECT_NEAR(id.model.damping_ratio, c.zeta, 0.1 * c.zeta);
  EXPECT_NEAR(id.model.gain, 1.0, 0.05);
  EXPECT_EQ(id.model.kind, ModeKind::base_damped);
  // BIC keeps one mode on a one-mode record.
  EXPECT_EQ(id.model.modes.size(), 1u);
  EXPECT_EQ(id.model.selection, ModeSelection::bic);
  EXPECT_GE(id.model.bic.size(), 1u);  // BIC(N) of the resolved N-mode fits found
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

TEST(Sweep, OneModeAskedIsTheOneModeFit) {
  const SyntheticSweep s = test::reference_synthetic();
  const SweepIdentification a = identify(s, 1);
  const SweepIdentification b = identify(s, 0);
  EXPECT_EQ(a.model.selection, ModeSelection::asked);
  ASSERT_EQ(a.model.modes.size(), 1u);
  EXPECT_EQ(a.model.bic.size(), 1u);
  EXPECT_EQ(a.model.natural_frequency_hz, b.model.natural_frequency_hz);
  EXPECT_EQ(a.model.damping_ratio, b.model.damping_ratio);
  EXPECT_EQ(a.model.modes[0].natural_frequency_hz, a.model.natural_frequency_hz);
  EXPECT_EQ(model_gain(a.model, 30.0), b.model.gain * model_gain(ModalFit{a.model.kind, a.model.natural_frequency_hz, 0,
                                                                          a.model.damping_ratio, 0, 1.0},
                                                                 30.0));
  const AccelFile f = parse_accel_text(synthetic_sweep_csv(s), "synthetic");
  for (const int bad : {-1, 4}) {
    try {
      (void)identify_sweep(f.record, 'x', SweepExcitation{s.f0_hz, s.f1_hz, s.rate_hz_s, s.accel_mm_s2}, bad);
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--modes"), std::string::npos) << e.what();
    }
  }
}

struct TwoModeCase {
  double f1_hz, zeta1, f2_hz, zeta2, gain2, noise;
  char axis;
  double rate_hz_s;
};

class SyntheticTwoModes : public ::testing::TestWithParam<TwoModeCase> {};

TEST_P(SyntheticTwoModes, RecoveredWithin1And10PercentAndBicPicksTwo) {
  const TwoModeCase c = GetParam();
  SyntheticSweep s = test::reference_synthetic();
  s.natural_freq_hz = c.f1_hz;
  s.damping_ratio = c.zeta1;
  s.extra_modes = {SyntheticMode{c.f2_hz, c.zeta2, c.gain2}};
  s.noise_mm_s2 = c.noise;
  s.axis = c.axis;
  s.rate_hz_s = c.rate_hz_s;
  for (const int asked : {0, 2}) {
    const SweepIdentification id = identify(s, asked);
    const ModalFit& m = id.model;
    ASSERT_EQ(m.modes.size(), 2u) << "asked " << asked << " bic " << ::testing::PrintToString(m.bic);
    EXPECT_EQ(m.selection, asked == 0 ? ModeSelection::bic : ModeSelection::asked);
    for (std::size_t i = 0; i < 2; ++i) {
      const ModeEstimate& e = m.modes[i];
      const double f = i == 0 ? c.f1_hz : c.f2_hz;
      const double z = i == 0 ? c.zeta1 : c.zeta2;
      const double g = i == 0 ? 1.0 : c.gain2;
      std::printf("two modes (%.0f Hz %.3f, %.0f Hz %.3f x %.2f): mode %zu f_n %.4f +- %.4f Hz, zeta %.5f +- %.5f, "
                  "g %.4f +- %.4f, %s, rms %.3f, BIC %s\n",
                  c.f1_hz, c.zeta1, c.f2_hz, c.zeta2, c.gain2, i, e.natural_frequency_hz, e.natural_frequency_std_hz,
                  e.damping_ratio, e.damping_ratio_std, e.gain, e.gain_std, std::string(to_string(m.kind)).c_str(),
                  m.rms_residual, ::testing::PrintToString(m.bic).c_str());
      EXPECT_NEAR(e.natural_frequency_hz, f, 0.01 * f) << i;
      EXPECT_NEAR(e.damping_ratio, z, 0.1 * z) << i;
      EXPECT_NEAR(e.gain, g, 0.1 * g) << i;
    }
    EXPECT_EQ(m.kind, ModeKind::base_damped);
    // The dominant mode (largest peak gain) carries the one-mode keys.
    const ModeEstimate& dom = m.modes[m.dominant_mode];
    EXPECT_EQ(m.natural_frequency_hz, dom.natural_frequency_hz);
    EXPECT_EQ(m.damping_ratio, dom.damping_ratio);
    for (const ModeEstimate& e : m.modes) EXPECT_LE(e.peak_gain, dom.peak_gain);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Modes, SyntheticTwoModes,
    ::testing::Values(TwoModeCase{35.0, 0.06, 70.0, 0.05, 0.5, 50.0, 'x', 5.0},
                      TwoModeCase{28.0, 0.08, 52.0, 0.10, 0.8, 100.0, 'y', 5.0},
                      TwoModeCase{45.0, 0.05, 90.0, 0.04, 0.3, 50.0, 'x', 4.0}));

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
    const SweepIdentification id = identify_sweep(f.record, 'y', parse_sweep("5,80,4,4000"), 1);
    // docs/resonance.md §6: a heavily damped mode near 43 Hz (its gain peaks near 40 Hz); the
    // record's clock runs 1.7 % fast against the sweep's.
    EXPECT_NEAR(id.model.natural_frequency_hz, 43.0, 1.0) << i;
    EXPECT_NEAR(id.model.damping_ratio, 0.24, 0.03) << i;
    EXPECT_EQ(id.model.kind, ModeKind::ground_damped) << i;
    EXPECT_NEAR(id.time_scale, 1.017, 0.002) << i;
    EXPECT_NEAR(id.sweep_start_s, 2.45, 0.1) << i;
  }
}

TEST(Sweep, EnderModesByBic) {
  const auto dir = test::corpus_accel_dir();
  if (!dir) GTEST_SKIP() << "corpus absent (../shared/corpus/accel or $AMCTL_CORPUS_DIR/accel)";
  for (int i = 1; i <= 3; ++i) {
    const AccelFile f = read_accel_file((*dir / ("ender3v2neo_y_sweep_" + std::to_string(i) + ".csv")).string());
    for (const int asked : {0, 2, 3}) {
      const SweepIdentification id = identify_sweep(f.record, 'y', parse_sweep("5,80,4,4000"), asked);
      const ModalFit& m = id.model;
      std::printf("Ender repeat %d, modes %d (%s): kind %s rms %.3f BIC %s\n", i, static_cast<int>(m.modes.size()),
                  std::string(to_string(m.selection)).c_str(), std::string(to_string(m.kind)).c_str(), m.rms_residual,
                  ::testing::PrintToString(m.bic).c_str());
      if (asked == 0) {  // docs/resonance.md §6: one mode on every repeat
        EXPECT_EQ(m.modes.size(), 1u) << i;
        EXPECT_NEAR(m.natural_frequency_hz, 43.0, 1.0) << i;
      } else {
        EXPECT_EQ(m.modes.size(), static_cast<std::size_t>(asked)) << i;
      }
      for (const ModeEstimate& e : m.modes) {
        std::printf("  f_n %.3f +- %.3f Hz, zeta %.4f +- %.4f, g %.4f +- %.4f, peak %.3f\n", e.natural_frequency_hz,
                    e.natural_frequency_std_hz, e.damping_ratio, e.damping_ratio_std, e.gain, e.gain_std, e.peak_gain);
      }
    }
  }
}

}  // namespace
}  // namespace amctl::resonance
