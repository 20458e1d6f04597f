// Klipper's Welch PSD and normalisation, and the PSD CSV written whole and read back.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "amctl/core/error.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "test_support.hpp"

namespace amctl::resonance {
namespace {

TEST(Welch, SegmentLengthIsKlippers) {
  // 1 << int(fs * 0.5 - 1).bit_length()
  EXPECT_EQ(klipper_segment_samples(1600.0), 1024u);
  EXPECT_EQ(klipper_segment_samples(3200.0), 2048u);
  EXPECT_EQ(klipper_segment_samples(1600.04), 1024u);
  EXPECT_EQ(klipper_segment_samples(2050.0), 2048u);  // int(1024.0) = 1024: 11 bits
  EXPECT_EQ(klipper_segment_samples(2048.0), 1024u);  // int(1023.0): 10 bits
}

TEST(Welch, SineGivesItsPowerAtItsFrequency) {
  AccelRecord r;
  r.source = "sine";
  const double fs = 1000.0;
  const double f = 62.5;  // on a bin: M = 512, bin 1.953125 Hz -> bin 32
  const double amp = 300.0;
  for (int i = 0; i < 20000; ++i) {
    const double t = i / fs;
    r.time_s.push_back(t);
    r.accel_x_mm_s2.push_back(amp * std::sin(2 * M_PI * f * t));
    r.accel_y_mm_s2.push_back(0.0);
    r.accel_z_mm_s2.push_back(9810.0);
  }
  const WelchPsd w = klipper_psd(r);
  EXPECT_EQ(w.segment_samples, 512u);
  EXPECT_EQ(w.segments, (20000u - 256u) / 256u);
  std::size_t peak = 0;
  double total = 0.0;
  for (std::size_t k = 0; k < w.table.psd_x.size(); ++k) {
    if (w.table.psd_x[k] > w.table.psd_x[peak]) peak = k;
    total += w.table.psd_x[k];
  }
  EXPECT_NEAR(w.table.freq_hz[peak], f, 0.1);
  // One-sided PSD integrates to the variance amp^2 / 2 (with fs = N / duration, off by 1/N).
  const double bin = w.table.freq_hz[1];
  EXPECT_NEAR(total * bin, amp * amp / 2, 1e-3 * amp * amp / 2);
  EXPECT_EQ(w.table.psd_z[3], 0.0);  // a constant is removed by the per-segment detrend
}

TEST(Welch, NormalisationIsKlippers) {
  PsdTable t;
  t.freq_hz = {0.0, 5.0, 9.99, 10.0, 50.0};
  for (std::vector<double>* v : {&t.psd_x, &t.psd_y, &t.psd_z, &t.psd_xyz}) *v = {1, 1, 1, 1, 1};
  normalize_to_frequencies(t);
  EXPECT_DOUBLE_EQ(t.psd_x[0], 1.0 / 0.1 * std::exp(-(10 / 0.1) * (10 / 0.1) + 1));
  EXPECT_DOUBLE_EQ(t.psd_y[1], 1.0 / 5.1 * std::exp(-(10 / 5.1) * (10 / 5.1) + 1));
  EXPECT_DOUBLE_EQ(t.psd_z[3], 1.0 / 10.1);
  EXPECT_DOUBLE_EQ(t.psd_xyz[4], 1.0 / 50.1);
  normalize_to_frequencies(t);  // once only
  EXPECT_DOUBLE_EQ(t.psd_xyz[4], 1.0 / 50.1);
}

TEST(PsdCsv, WrittenWholeAndReadBackGivesTheSameCalibration) {
  const std::string text = synthetic_sweep_csv(test::reference_synthetic());
  CalibrateOptions o;
  o.axis = 'x';
  const CalibrationReport a = calibrate(parse_accel_text(text, "synthetic"), "synthetic", o);
  const auto path = test::temp_path("psd.csv");
  write_psd_csv(a, path.string());
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".tmp"));
  const CalibrationReport b = calibrate_file(path.string(), o);
  std::filesystem::remove(path);
  EXPECT_EQ(b.format, RecordFormat::klipper_psd);
  ASSERT_EQ(a.klipper.shapers.size(), b.klipper.shapers.size());
  for (std::size_t i = 0; i < a.klipper.shapers.size(); ++i) {
    EXPECT_EQ(a.klipper.shapers[i].freq_hz, b.klipper.shapers[i].freq_hz);
    EXPECT_EQ(a.klipper.shapers[i].vibrations, b.klipper.shapers[i].vibrations);
  }
  EXPECT_EQ(a.klipper.recommended.name, b.klipper.recommended.name);
  // An unwritable path: an error naming it, nothing left behind.
  EXPECT_THROW(write_psd_csv(a, "/nonexistent/dir/psd.csv"), Error);
}

TEST(Calibrate, RejectsBadOptions) {
  const std::string text = synthetic_sweep_csv(test::reference_synthetic());
  const AccelFile f = parse_accel_text(text, "s");
  CalibrateOptions o;
  o.axis = 'z';
  EXPECT_THROW((void)calibrate(f, "s", o), Error);
  o.axis = 'x';
  o.klipper.shapers = {"zvx"};
  EXPECT_THROW((void)calibrate(f, "s", o), Error);
}

TEST(Calibrate, FindsTheSyntheticResonance) {
  // The 42 Hz mode: the PSD peak lies within a bin or two of it (3200 Hz / 2048 = 1.56 Hz
  // bins, divided by f + 0.1), and ZV, whose one notch must sit on the mode, lands near it.
  const std::string text = synthetic_sweep_csv(test::reference_synthetic());
  CalibrateOptions o;
  o.axis = 'x';
  const CalibrationReport r = calibrate(parse_accel_text(text, "s"), "s", o);
  EXPECT_NEAR(r.peak_axis_hz, 42.0, 2.0);
  EXPECT_NEAR(r.klipper.shapers.front().freq_hz, 42.0, 2.0);
}

}  // namespace
}  // namespace amctl::resonance
