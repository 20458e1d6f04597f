// Planner-based calibration end to end on small G-code programs: durations produced by the
// planner with known limits must be explained by those limits again.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/time_calibration.hpp"

namespace pr = amctl::process;
namespace fs = std::filesystem;

namespace {

// A zig-zag of `n` moves of length `len` at 200 mm/s with 90 degree corners.
std::string zigzag(int n, double len) {
  std::string g = "G90\nM83\nG1 F12000\n";
  double x = 0, y = 0;
  for (int i = 0; i < n; ++i) {
    if (i % 2 == 0) x = (x == 0 ? len : 0);
    else y += len;
    g += "G1 X" + std::to_string(x) + " Y" + std::to_string(y) + " E0.1\n";
  }
  return g;
}

}  // namespace

TEST(TimeCalibration, LimitCommandsAreBlankedKeepingLineNumbers) {
  const std::string in = "G1 X1\nM204 S500\n  M201 X100\nM2010\nSET_VELOCITY_LIMIT ACCEL=3\nN5 M205 X8\nG1 X2";
  EXPECT_EQ(pr::strip_limit_commands(in), "G1 X1\n\n\nM2010\n\n\nG1 X2");
}

TEST(TimeCalibration, TimingsCsvResolvesPathsAndUnits) {
  const auto t = pr::CsvTable::parse("gcode,duration_min\na.gcode,2\n/abs/b.gcode,0.5\n",
                                     "/data/prints.csv");
  const auto p = pr::read_print_timings(t);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].gcode_path, "/data/a.gcode");
  EXPECT_DOUBLE_EQ(p[0].duration_s, 120.0);
  EXPECT_EQ(p[1].gcode_path, "/abs/b.gcode");
  EXPECT_THROW((void)pr::read_print_timings(pr::CsvTable::parse("gcode,duration_s\na,-3\n", "x.csv")),
               amctl::Error);
  EXPECT_THROW((void)pr::read_print_timings(pr::CsvTable::parse("gcode,seconds\na,3\n", "x.csv")),
               amctl::Error);
}

TEST(TimeCalibration, LayerNumbersBeyondALongAreErrorsNotOverflows) {
  // Found by fuzz_process_csv (UBSan): a layer of 1.4e127 was converted to long before any
  // range check. Now the cell is named.
  for (const char* layer : {"1.4e127", "3e9", "-1", "2.5"}) {
    const std::string csv = std::string("gcode,layer,duration_min\na.gcode,0,1.5\na.gcode,") +
                            layer + ",2\n";
    try {
      (void)pr::read_print_timings(pr::CsvTable::parse(csv, "t.csv"));
      ADD_FAILURE() << layer << " was accepted";
    } catch (const amctl::Error& e) {
      EXPECT_EQ(e.where().line, 3u) << e.what();
      EXPECT_EQ(e.where().column, 9u) << e.what();
      EXPECT_NE(std::string(e.what()).find("layer must be a whole number in [0, 1e9]"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(TimeCalibration, PlannerDurationsAreExplainedByTheLimitsThatMadeThem) {
  const fs::path dir = fs::temp_directory_path() / "amctl_time_calibration_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const struct { const char* name; int n; double len; } files[] = {
      {"short.gcode", 60, 2.0}, {"mid.gcode", 30, 12.0}, {"long.gcode", 10, 80.0},
      {"mixed.gcode", 40, 5.0}};
  auto truth = amctl::machine::preset("default");
  truth.max_accel_mm_s2 = 2200;
  truth.square_corner_velocity_mm_s = 7;
  truth.max_velocity_mm_s = 150;
  std::vector<pr::PrintTiming> timings;
  for (const auto& f : files) {
    const std::string g = zigzag(f.n, f.len);
    std::ofstream((dir / f.name).string()) << g;
    pr::PrintTiming t;
    t.gcode_path = (dir / f.name).string();
    t.duration_s = amctl::plan::estimate_text(g, f.name, truth).total_time_s;
    timings.push_back(t);
  }
  // Hand check: a long 80 mm move cruising at 150 mm/s takes at least 80/150 s.
  EXPECT_GT(timings[2].duration_s, 10 * 80.0 / 150.0);
  const auto start = amctl::machine::preset("default");
  const std::vector<std::string> names{"accel", "scv", "max_velocity"};
  const auto est = pr::planner_duration_estimator(start, names, timings, amctl::plan::FileLimits::ignore);
  std::vector<double> measured;
  for (const auto& t : timings) measured.push_back(t.duration_s);
  const auto r = pr::calibrate_durations(est, measured, pr::limit_parameters(start, names));
  EXPECT_NEAR(r.values[0], 2200.0, 2200.0 * 1e-3);
  EXPECT_NEAR(r.values[1], 7.0, 7.0 * 1e-3);
  EXPECT_NEAR(r.values[2], 150.0, 150.0 * 1e-3);
  EXPECT_LT(r.rms_relative, 1e-6);
  fs::remove_all(dir);
}

TEST(TimeCalibration, UnknownLimitNamesAreRejected) {
  const auto m = amctl::machine::preset("default");
  EXPECT_THROW((void)pr::limit_parameters(m, {"acceleration"}), amctl::Error);
  EXPECT_EQ(pr::default_limits_for(m), (std::vector<std::string>{"accel", "scv", "max_velocity"}));
}
