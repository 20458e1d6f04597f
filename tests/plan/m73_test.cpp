#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

TEST(WriteM73, InsertsProgressAtCheckpointsAndDropsOldOnes) {
  const std::string in = ::testing::TempDir() + "/m73_in.gcode";
  const std::string out = ::testing::TempDir() + "/m73_out.gcode";
  {
    std::ofstream f(in);
    f << "M73 P0 R99\nG1 F6000\n";
    for (int i = 1; i <= 100; ++i) f << "G1 X" << (i % 2) * 10 << "\n";  // 100 moves of 0.12 s
  }
  machine::Machine m;
  m.square_corner_velocity_mm_s = 0;
  m.max_accel_mm_s2 = 5000;
  EstimateOptions o;
  o.checkpoint_interval_s = 3.0;
  const auto r = estimate_file(in, m, o);
  ASSERT_NEAR(r.total_time_s, 12.0, 1e-9);
  const std::size_t n = write_m73(in, out, r);
  EXPECT_EQ(n, r.checkpoints.size() + 1);
  std::ifstream f(out);
  std::vector<std::string> m73;
  std::string l;
  std::size_t lines = 0;
  while (std::getline(f, l)) {
    ++lines;
    if (l.rfind("M73", 0) == 0) m73.push_back(l);
  }
  // Checkpoints at 0, 3, 6, 9 s of a 12 s print: 0/25/50/75 % and 12/9/6/3 s -> 1 min.
  ASSERT_EQ(m73.size(), 5u);
  EXPECT_EQ(m73[0], "M73 P0 R1");
  EXPECT_EQ(m73[1], "M73 P25 R1");
  EXPECT_EQ(m73[3], "M73 P75 R1");
  EXPECT_EQ(m73[4], "M73 P100 R0");
  EXPECT_EQ(lines, 102u - 1u + 5u);  // input lines minus the old M73 plus the new ones
  EXPECT_THROW(write_m73(in, in, r), Error);
  EXPECT_THROW(write_m73(in, "/nonexistent-dir/x.gcode", r), Error);
}

}  // namespace
}  // namespace amctl::plan
