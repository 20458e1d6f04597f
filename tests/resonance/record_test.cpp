// Readers of accelerometer records and PSD tables: formats, quality figures, bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "amctl/core/error.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/record.hpp"
#include "test_support.hpp"

namespace amctl::resonance {
namespace {

/// n rows at rate fs of a 40 Hz sine on x with header `header`.
std::string sine_csv(const std::string& header, std::size_t n, double fs) {
  std::string s = header + "\n";
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / fs;
    s += std::to_string(t) + "," + std::to_string(1000.0 * std::sin(2 * 3.141592653589793 * 40 * t)) +
         ",0,9810\n";
  }
  return s;
}

std::string message_of(const std::string& text, const std::string& source = "in.csv") {
  try {
    (void)parse_accel_text(text, source);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Reader, TellsTheThreeFormatsApart) {
  const AccelFile raw = parse_accel_text(sine_csv("#time,accel_x,accel_y,accel_z", 2000, 1600), "a");
  EXPECT_EQ(raw.format, RecordFormat::klipper_raw);
  EXPECT_EQ(raw.record.size(), 2000u);
  const AccelFile corpus = parse_accel_text(
      sine_csv("#time_s,accel_x_mm_s2,accel_y_mm_s2,accel_z_mm_s2", 2000, 1600), "b");
  EXPECT_EQ(corpus.format, RecordFormat::corpus);
  EXPECT_DOUBLE_EQ(corpus.record.accel_z_mm_s2[5], 9810.0);
  const AccelFile psd = parse_accel_text("freq,psd_x,psd_y,psd_z,psd_xyz\n0,1,2,3,6\n1.5,2,3,4,9\n", "c");
  EXPECT_EQ(psd.format, RecordFormat::klipper_psd);
  EXPECT_FALSE(psd.psd.normalized);
  EXPECT_EQ(psd.psd.psd_xyz[1], 9.0);
  // calibrate_shaper.py --csv: already normalised, with one column per shaper after a blank.
  const AccelFile shaped = parse_accel_text(
      "freq,psd_x,psd_y,psd_z,psd_xyz,shapers:,zv(40.0)\n0.0,1,2,3,6,,0.5\n1.6,2,3,4,9,,0.4\n", "d");
  EXPECT_TRUE(shaped.psd.normalized);
}

TEST(Reader, AcceptsAByteOrderMark) {
  const AccelFile f = parse_accel_text(
      "\xEF\xBB\xBF" + sine_csv("#time_s,accel_x_mm_s2,accel_y_mm_s2,accel_z_mm_s2", 1500, 1600), "bom");
  EXPECT_EQ(f.format, RecordFormat::corpus);
}

TEST(Reader, SkipsCommentsBlankLinesAndCrLf) {
  const AccelFile f = parse_accel_text(
      "# recorded by x\r\n#time,accel_x,accel_y,accel_z\r\n\r\n" +
          sine_csv("# rows", 1500, 1600).substr(7),
      "e");
  EXPECT_EQ(f.record.size(), 1500u);
}

TEST(Reader, BadInputNamesFileLineWhatAndExpected) {
  const std::string h = "#time,accel_x,accel_y,accel_z\n";
  EXPECT_EQ(message_of(h + "0,1,2,3\n0.001,nan,2,3\n"),
            "in.csv:3: column 2 (accel_x) is 'nan', expected a finite number");
  EXPECT_EQ(message_of(h + "0,1,2,3\n0.001,abc,2,3\n"),
            "in.csv:3: column 2 (accel_x) is 'abc', expected a number");
  EXPECT_EQ(message_of(h + "0,1,2,3\n0.001,1,2\n"),
            "in.csv:3: 3 columns, expected 4 (time,accel_x,accel_y,accel_z)");
  EXPECT_EQ(message_of(h + "0,1,2,3\n0.001,1,2,3,4\n"),
            "in.csv:3: 5 columns, expected 4 (time,accel_x,accel_y,accel_z)");
  EXPECT_EQ(message_of(h + "0,1,2,3\n0.002,1,2,3\n0.001,1,2,3\n"),
            "in.csv:4: time 0.001 is not after 0.002 on line 3, expected time to increase");
  EXPECT_NE(message_of(h + "0,1,2,3\n0.001,1,2,3\n").find("in.csv:3: 2 samples over 0.001 s"),
            std::string::npos);
  EXPECT_NE(message_of(sine_csv("#time,accel_x,accel_y,accel_z", 800, 1600))
                .find("in.csv:801: 800 samples over 0.499375 s (1602 Hz), expected more than 1024"),
            std::string::npos);
  EXPECT_NE(message_of("#t,x,y,z\n0,1,2,3\n").find("in.csv:1: header '#t,x,y,z', expected"),
            std::string::npos);
  EXPECT_NE(message_of("#time,accel_x,accel_y\n0,1,2\n").find("in.csv:1: header"),
            std::string::npos);
  EXPECT_NE(message_of("0,1,2,3\n").find("in.csv:1: header '0,1,2,3', expected"), std::string::npos);
  EXPECT_NE(message_of("freq,psd_x,psd_y\n").find("in.csv:1: header"), std::string::npos);
  EXPECT_EQ(message_of("freq,psd_x,psd_y,psd_z,psd_xyz\n0,1,2,3,6\n"),
            "in.csv:2: 1 PSD row, expected at least 2");
  EXPECT_EQ(message_of("freq,psd_x,psd_y,psd_z,psd_xyz\n0,1,2,3,6\n0,1,2,3,6\n"),
            "in.csv:3: freq 0 is not after 0 on line 2, expected frequency to increase");
}

TEST(Reader, EmptyAndBinaryFilesAreNamed) {
  EXPECT_NE(message_of("", "rec.csv").find("rec.csv: empty file, expected an accelerometer CSV"),
            std::string::npos);
  EXPECT_NE(message_of("\n \n", "rec.csv").find("rec.csv: empty file"), std::string::npos);
  EXPECT_NE(message_of(std::string("PK\x03\x04\0\0", 6), "rec.zip")
                .find("rec.zip: binary file (byte 0x03 at offset 2), expected an accelerometer CSV"),
            std::string::npos);
  EXPECT_NE(message_of("#time,accel_x,accel_y,accel_z\n", "h.csv").find("h.csv:1: 0 samples"),
            std::string::npos);
  try {
    (void)read_accel_file("/nonexistent/dir/x.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/dir/x.csv: no such file; expected an accelerometer CSV");
  }
}

TEST(Quality, SampleRateJitterGapsAndClipping) {
  AccelRecord r;
  r.source = "q";
  const double dt = 1.0 / 1000.0;
  double t = 0.0;
  for (int i = 0; i < 3000; ++i) {
    // intervals cycling through 0.99, 1.00, 1.01 ms; one 5-interval gap at i = 1000.
    const double step = dt * (0.99 + 0.01 * (i % 3)) + (i == 1000 ? 4 * dt : 0.0);
    t += step;
    r.time_s.push_back(t);
    double x = 100.0 * std::sin(0.05 * i);
    if (i >= 200 && i < 205) x = 500.0;   // a run of 5 at the maximum
    if (i >= 300 && i < 302) x = -500.0;  // 2 at the minimum: too short to count
    r.accel_x_mm_s2.push_back(x);
    r.accel_y_mm_s2.push_back(0.01 * i);
    r.accel_z_mm_s2.push_back(9810.0);
  }
  const RecordQuality q = assess_record(r);
  EXPECT_EQ(q.samples, 3000u);
  EXPECT_NEAR(q.sample_rate_hz, 1000.0, 1e-6);  // the median interval
  EXPECT_NEAR(q.jitter, 0.01 * std::sqrt(2.0 / 3.0), 1e-6);
  EXPECT_NEAR(q.max_interval_deviation, 0.01, 1e-6);
  EXPECT_EQ(q.gaps, 1u);
  EXPECT_NEAR(q.largest_gap_s, 5.0e-3, 1e-4);
  EXPECT_EQ(q.clip_x.runs, 1u);
  EXPECT_EQ(q.clip_x.samples, 5u);
  EXPECT_EQ(q.clip_x.max_mm_s2, 500.0);
  EXPECT_EQ(q.clip_y.samples, 0u);
  EXPECT_EQ(q.clip_z.runs, 1u);  // a constant axis is one run at its extreme
}

TEST(Quality, CorpusRecordsAreClean) {
  const auto dir = test::corpus_accel_dir();
  if (!dir) GTEST_SKIP() << "corpus absent (../shared/corpus/accel or $AMCTL_CORPUS_DIR/accel)";
  const AccelFile f = read_accel_file((*dir / "ender3v2neo_y_sweep_1.csv").string());
  const RecordQuality q = assess_record(f.record);
  EXPECT_NEAR(q.sample_rate_hz, 1600.0, 1e-6);
  EXPECT_LT(q.jitter, 1e-9);
  EXPECT_EQ(q.gaps, 0u);
}

}  // namespace
}  // namespace amctl::resonance
