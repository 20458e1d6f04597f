// Every real slicer file in shared/corpus/gcode (corpus_dir.hpp; skipped when absent)
// is estimated on the machines it could have been sliced for: no crash, every unknown
// command explained, totals within a sane band of the slicer's own figure.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"
#include "corpus_dir.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

namespace fs = std::filesystem;

TEST(Corpus, EveryFileEstimatesSanelyOnEveryPreset) {
  const auto corpus = test::corpus_dir();
  if (!corpus) GTEST_SKIP() << "no shared/corpus beside the clone (or set AMCTL_CORPUS_DIR)";
  const fs::path dir = *corpus / "gcode";
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".gcode") continue;
    ++files;
    std::size_t lines = 0;
    {
      std::ifstream in(entry.path());
      std::string l;
      while (std::getline(in, l)) ++lines;
    }
    for (const auto& name : machine::preset_names()) {
      const auto m = machine::preset(name);
      EstimateReport r;
      ASSERT_NO_THROW(r = estimate_file(entry.path().string(), m)) << entry.path() << " " << name;
      EXPECT_EQ(r.lines, lines) << entry.path();
      EXPECT_GT(r.moves, 10000u);
      ASSERT_TRUE(r.slicer_estimate_s.has_value()) << entry.path();
      // Within a factor of 4 of the slicer, whatever printer the file meets (a 16000 mm/s^2
      // Voron benchy on a stock Ender takes 3.8x its slicer figure).
      EXPECT_GT(r.total_time_s, *r.slicer_estimate_s / 4.0) << entry.path() << " " << name;
      EXPECT_LT(r.total_time_s, *r.slicer_estimate_s * 4.0) << entry.path() << " " << name;
      for (const auto& u : r.unknown_commands) {
        // Only printer macros may be unknown; every G/M code in these files is modelled or
        // deliberately ignored.
        EXPECT_TRUE(u.name.find('_') != std::string::npos || u.name == "M862")
            << entry.path() << ": unexplained " << u.name;
      }
      EXPECT_TRUE(r.diagnostics.warnings.size() < 20u);
    }
  }
  EXPECT_GE(files, 4u);
}

}  // namespace
}  // namespace amctl::plan
