// Klipper's resonance files as Klipper reads them, and several records in one fit, against
// Klipper's own numbers (tests/reference/resonance/klipper_files.json, made by
// klipper_calibrate_files.py at the commit of README.md): the older calibration_data_*.csv
// with one column per shaper, the several-record PSD file calibrate_shaper.py --csv writes,
// and calibrate_shaper.py A.csv B.csv C.csv on the corpus sweeps.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "amctl/core/error.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "test_support.hpp"

namespace amctl::resonance {
namespace {

void expect_same_fit(const CalibrationReport& r, const nlohmann::json& ref) {
  const auto& shapers = ref.at("shapers");
  ASSERT_EQ(r.klipper.shapers.size(), shapers.size());
  for (std::size_t i = 0; i < shapers.size(); ++i) {
    const ShaperFit& f = r.klipper.shapers[i];
    const auto& k = shapers[i];
    const std::string name = k.at("name").get<std::string>();
    EXPECT_EQ(f.name, name);
    EXPECT_EQ(f.freq_hz, k.at("freq_hz").get<double>()) << name;  // the same grid point
    for (const auto& [mine, key] : {std::pair{f.vibrations, "vibrations"}, std::pair{f.smoothing_mm, "smoothing"},
                                    std::pair{f.score, "score"}, std::pair{f.max_accel_mm_s2, "max_accel_mm_s2"}}) {
      const double want = k.at(key).get<double>();
      EXPECT_LE(std::abs(mine - want), 1e-6 * std::abs(want)) << name << " " << key << ": amctl " << mine
                                                              << ", Klipper " << want;
    }
  }
  EXPECT_EQ(r.klipper.recommended.name, ref.at("recommended").at("name").get<std::string>());
  EXPECT_EQ(r.klipper.recommended.freq_hz, ref.at("recommended").at("freq_hz").get<double>());
}

nlohmann::json case_of(const char* name) {
  return test::read_json(test::reference_dir() / "klipper_files.json").at(name);
}

TEST(KlipperFiles, OlderCalibrationDataWithOneColumnPerShaperIsANormalisedPsd) {
  const auto ref = case_of("older_calibration_data");
  CalibrateOptions o;
  o.axis = 0;  // as calibrate_shaper.py: no axis
  const CalibrationReport r =
      calibrate_files({(test::reference_dir() / "calibration_data_y_sweep_1.csv").string()}, o);
  EXPECT_EQ(r.format, RecordFormat::klipper_psd);
  EXPECT_TRUE(r.psd.normalized);
  EXPECT_TRUE(std::isnan(r.peak_axis_hz));
  expect_same_fit(r, ref);
  // Klipper since October 2025 normalises it once more (it looks for ",shapers:"): a
  // different answer, which amctl does not give.
  EXPECT_NE(case_of("older_calibration_data_reread").at("recommended").at("freq_hz").get<double>(),
            r.klipper.recommended.freq_hz);
}

TEST(KlipperFiles, SeveralRecordPsdFileIsOneRecordPerColumn) {
  const auto ref = case_of("several_record_psd");
  CalibrateOptions o;
  o.axis = 'y';
  const CalibrationReport r =
      calibrate_files({(test::reference_dir() / "calibration_data_y_sweeps_1_2_3.csv").string()}, o);
  ASSERT_EQ(r.sources.size(), 3u);
  EXPECT_EQ(r.sources[1], "ender3v2neo_y_sweep_2.csv");
  EXPECT_TRUE(std::isnan(r.peak_axis_hz));  // per-axis PSDs are not in such a file
  expect_same_fit(r, ref);
}

TEST(KlipperFiles, SeveralRecordsJoinOneFitAsCalibrateShaperDoes) {
  const auto dir = test::corpus_accel_dir();
  if (!dir) GTEST_SKIP() << "corpus absent (../shared/corpus/accel or $AMCTL_CORPUS_DIR/accel)";
  const auto ref = case_of("sweeps_1_2_3");
  std::vector<std::string> files;
  for (const auto& f : ref.at("files")) files.push_back((*dir / f.get<std::string>()).string());
  CalibrateOptions o;
  o.axis = 'y';
  const CalibrationReport r = calibrate_files(files, o);
  EXPECT_EQ(r.sources, files);
  expect_same_fit(r, ref);
  // The fit over three records is never better than over one: the worst of them counts.
  const CalibrationReport one = calibrate_files({files[0]}, o);
  for (std::size_t i = 0; i < r.klipper.shapers.size(); ++i) {
    EXPECT_GE(r.klipper.shapers[i].vibrations + 1e-12, 0.0);
  }
  EXPECT_EQ(one.sources.size(), 1u);
}

TEST(KlipperFiles, HeadersThatAreNoneOfThemAreErrors) {
  auto error_of = [](const std::string& text) {
    try {
      (void)parse_accel_text(text, "p.csv");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error_of("freq,psd_x,psd_y,psd_z,psd_xyz,bogus\n1,1,1,1,3,1\n2,1,1,1,3,1\n").find("column 6 is 'bogus'"),
            std::string::npos);
  EXPECT_NE(error_of("freq,psd_x\n1,2\n").find("expected"), std::string::npos);
  // A several-record file whose row lacks a record's value.
  EXPECT_NE(error_of("freq,a.csv,b.csv\n1,1,2\n2,1\n").find("p.csv:3: 2 columns, expected 3"), std::string::npos)
      << error_of("freq,a.csv,b.csv\n1,1,2\n2,1\n");
  // Quoted names (Klipper quotes a name with a comma).
  const AccelFile f = parse_accel_text("freq,\"a,1.csv\",b.csv\n1,1,2\n2,3,4\n", "p.csv");
  EXPECT_EQ(f.psd.name, "a,1.csv");
  ASSERT_EQ(f.more_psd.size(), 1u);
  EXPECT_EQ(f.more_psd[0].psd_xyz, (std::vector<double>{2, 4}));
  EXPECT_FALSE(f.psd.normalized);
}

}  // namespace
}  // namespace amctl::resonance
