// amctl's calibration against Klipper's own (calibrate_shaper.py at the commit named in each
// reference file; tests/reference/resonance/README.md has the commands). Every shaper's fitted
// frequency must be the same point of Klipper's grid; vibrations, smoothing and max accel
// agree to 1e-6 relative; the recommended shaper is the same.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include "amctl/resonance/calibrate.hpp"
#include "test_support.hpp"

namespace amctl::resonance {
namespace {

void expect_rel(double got, double want, double rel, const std::string& what) {
  EXPECT_LE(std::abs(got - want), rel * std::abs(want)) << what << ": amctl " << got << ", Klipper " << want;
}

void compare(const CalibrationReport& r, const nlohmann::json& ref) {
  const auto& shapers = ref.at("shapers");
  ASSERT_EQ(r.klipper.shapers.size(), shapers.size());
  for (std::size_t i = 0; i < shapers.size(); ++i) {
    const ShaperFit& f = r.klipper.shapers[i];
    const auto& k = shapers[i];
    const std::string name = k.at("name").get<std::string>();
    EXPECT_EQ(f.name, name);
    // The same grid point: numpy.arange's values are reproduced bit for bit.
    EXPECT_EQ(f.freq_hz, k.at("freq_hz").get<double>()) << name;
    expect_rel(f.vibrations, k.at("vibrations").get<double>(), 1e-6, name + " vibrations");
    expect_rel(f.smoothing_mm, k.at("smoothing").get<double>(), 1e-6, name + " smoothing");
    expect_rel(f.score, k.at("score").get<double>(), 1e-6, name + " score");
    expect_rel(f.max_accel_mm_s2, k.at("max_accel_mm_s2").get<double>(), 1e-6, name + " max accel");
  }
  EXPECT_EQ(r.klipper.recommended.name, ref.at("recommended").at("name").get<std::string>());
  EXPECT_EQ(r.klipper.recommended.freq_hz, ref.at("recommended").at("freq_hz").get<double>());
  // The normalised PSD Klipper fitted (bins up to 200 Hz).
  const auto& psd = ref.at("psd");
  const auto& fk = psd.at("freq_hz");
  ASSERT_LE(fk.size(), r.psd.freq_hz.size());
  for (std::size_t b = 0; b < fk.size(); ++b) {
    EXPECT_EQ(r.psd.freq_hz[b], fk[b].get<double>()) << "bin " << b;
    for (const char* col : {"psd_x", "psd_y", "psd_z", "psd_xyz"}) {
      const std::vector<double>& mine = std::string(col) == "psd_x"   ? r.psd.psd_x
                                        : std::string(col) == "psd_y" ? r.psd.psd_y
                                        : std::string(col) == "psd_z" ? r.psd.psd_z
                                                                      : r.psd.psd_xyz;
      const double want = psd.at(col)[b].get<double>();
      EXPECT_LE(std::abs(mine[b] - want), 1e-9 * std::abs(want) + 1e-300) << col << " bin " << b;
    }
  }
}

class CorpusSweep : public ::testing::TestWithParam<int> {};

TEST_P(CorpusSweep, EqualsKlipper) {
  const auto dir = test::corpus_accel_dir();
  if (!dir) GTEST_SKIP() << "corpus absent (../shared/corpus/accel or $AMCTL_CORPUS_DIR/accel)";
  const std::string name = "ender3v2neo_y_sweep_" + std::to_string(GetParam());
  const auto ref = test::read_json(test::reference_dir() / (name + ".json"));
  CalibrateOptions o;
  o.axis = 'y';
  const CalibrationReport r = calibrate_file((*dir / (name + ".csv")).string(), o);
  compare(r, ref);
}

INSTANTIATE_TEST_SUITE_P(Ender3, CorpusSweep, ::testing::Values(1, 2, 3));

TEST(SyntheticSweep, EqualsKlipper) {
  const std::string text = synthetic_sweep_csv(test::reference_synthetic());
  if (const char* out = std::getenv("AMCTL_RESONANCE_WRITE_SYNTHETIC"); out && *out) {
    std::ofstream(out) << text;  // the file given to Klipper (README.md)
  }
  const auto ref = test::read_json(test::reference_dir() / "synthetic_x_42hz.json");
  CalibrateOptions o;
  o.axis = 'x';
  const CalibrationReport r = calibrate(parse_accel_text(text, "synthetic"), "synthetic", o);
  compare(r, ref);
}

TEST(SyntheticSweep, AccelPerHzEqualsKlipper) {
  const std::string text = synthetic_sweep_csv(test::reference_synthetic_per_hz());
  if (const char* out = std::getenv("AMCTL_RESONANCE_WRITE_SYNTHETIC_PER_HZ"); out && *out) {
    std::ofstream(out) << text;
  }
  const auto ref = test::read_json(test::reference_dir() / "synthetic_x_42hz_per_hz.json");
  CalibrateOptions o;
  o.axis = 'x';
  const CalibrationReport r = calibrate(parse_accel_text(text, "synthetic"), "synthetic", o);
  compare(r, ref);
  // Excited as Klipper's test excites, the pick lands on the mode.
  EXPECT_NEAR(r.klipper.recommended.freq_hz, 42.0, 1.0);
}

}  // namespace
}  // namespace amctl::resonance
