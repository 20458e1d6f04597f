// amctl against Klipper's own batch mode (klippy.py -i FILE -o /dev/null -d klipper.dict),
// run beside amctl on this project's machines; how: tests/reference/klipper/README.md.
// Inputs and printer.cfg files are in tests/reference/klipper/, Klipper's motion times in
// klipper_times.json ("motion_s": with batch mode's buffer-runout flushes switched off, as a
// real printer fed in time never runs out; "motion_stock_s": unmodified batch mode).
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "corpus_dir.hpp"

namespace amctl::plan {
namespace {

const std::string kDir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/";

nlohmann::json klipper_times() {
  std::ifstream in(kDir + "klipper_times.json");
  return nlohmann::json::parse(in);
}

class KlipperReference : public ::testing::TestWithParam<std::string> {};

TEST_P(KlipperReference, SyntheticFilesMatchKlipperToAMicrosecond) {
  const auto times = klipper_times();
  for (const char* cfg : {"v0_corexy", "ender3_cartesian"}) {
    const auto m = machine::load_machine(kDir + cfg + ".cfg");
    const std::string name = GetParam();
    const auto r = estimate_file(kDir + name + ".gcode", m);
    const double klipper_s = times.at(std::string(cfg) + "/" + name).at("motion_s").get<double>();
    EXPECT_NEAR(r.total_time_s, klipper_s, 1e-6) << cfg << " " << name;
  }
}

INSTANTIATE_TEST_SUITE_P(Files, KlipperReference,
                         ::testing::Values("syn_xy_pair", "syn_square", "syn_circle1000",
                                           "syn_dwell", "syn_velocity_limit", "syn_m220_m221",
                                           "syn_arcs"));

TEST(KlipperReference, CorpusBenchiesMatchKlipperWithinATenthOfASecond) {
  const auto corpus_root = test::corpus_dir();
  if (!corpus_root) GTEST_SKIP() << "no shared/corpus beside the clone (or set AMCTL_CORPUS_DIR)";
  const std::filesystem::path corpus = *corpus_root / "gcode";
  const auto times = klipper_times();
  for (const char* cfg : {"v0_corexy", "ender3_cartesian"}) {
    const auto m = machine::load_machine(kDir + cfg + ".cfg");
    for (const char* f : {"benchy_cura-5.3", "benchy_ideamaker-4.2",
                          "benchy_prusaslicer-2.6_cr10spro", "benchy_superslicer-2.3_klipper-v0"}) {
      const auto r = estimate_file((corpus / (std::string(f) + ".gcode")).string(), m);
      const double k = times.at(std::string(cfg) + "/" + f).at("motion_s").get<double>();
      // Measured: equal to the millisecond except the PrusaSlicer file (+0.02 s): amctl stops
      // for its G29 (bed probing), which Klipper does not know and skips.
      EXPECT_NEAR(r.total_time_s, k, 0.1) << cfg << " " << f;
    }
  }
}

// Kinematics beyond cartesian/CoreXY (klipper_times_kinematics.json, made by
// kinematics_times.py): each case is a printer.cfg of this directory, a preamble both
// programs read first, and an input (a file here or a corpus file).
TEST(KlipperReference, KinematicsMatchKlippersBatchMode) {
  std::ifstream in(kDir + "klipper_times_kinematics.json");
  const auto times = nlohmann::json::parse(in);
  const auto corpus_root = test::corpus_dir();
  int compared = 0;
  for (const auto& [key, c] : times.items()) {
    if (!c.is_object()) continue;  // klipper_commit
    const std::string input = c.at("input").get<std::string>();
    std::string path = kDir + input;
    if (input.rfind("corpus:", 0) == 0) {
      if (!corpus_root) continue;
      path = (*corpus_root / "gcode" / input.substr(7)).string();
    }
    std::ifstream g(path, std::ios::binary);
    ASSERT_TRUE(g) << path;
    std::ostringstream text;
    text << c.at("preamble").get<std::string>() << g.rdbuf();
    const auto m = machine::load_machine(kDir + c.at("cfg").get<std::string>());
    const auto r = estimate_text(text.str(), key, m);
    const double klipper_s = c.at("motion_stock_s").get<double>();
    // Measured: within 4e-7 s on every case but the deltesian benchy (0.018 s in steps of a
    // corner stop, likely batch mode's runout flush; tolerance_s 0.05 there: docs/machine.md,
    // "Deltesian").
    EXPECT_NEAR(r.total_time_s, klipper_s, c.at("tolerance_s").get<double>()) << key;
    EXPECT_FALSE(r.range_error.has_value()) << key;
    ++compared;
  }
  EXPECT_GE(compared, 1);
}

}  // namespace
}  // namespace amctl::plan
