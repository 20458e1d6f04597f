// The CLI interface that acceptance checks use: `amctl shrink fit FILE.csv --json` prints one
// JSON object with slope/intercept/factor (one range) or a list of ranges. Runs the built
// binary; expected numbers are scipy's (tests/reference/process_shrink_reference.py).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace {

struct Run {
  int status = 0;
  std::string out;
};

Run run(const std::string& args) {
  const std::string cmd = std::string(AMCTL_BINARY_DIR) + "/apps/amctl/amctl " + args + " 2>/dev/null";
  Run r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

const std::string kTable1 = std::string(AMCTL_SOURCE_DIR) + "/examples/04_shrink_geometry1.csv";

}  // namespace

TEST(Cli, ShrinkFitJsonHasSlopeInterceptAndFactor) {
  const auto r = run("shrink fit " + kTable1 + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j.at("slope").get<double>(), -0.00309995231236014, 1e-13);
  EXPECT_NEAR(j.at("intercept").get<double>(), 0.327948993299212, 1e-12);
  EXPECT_NEAR(j.at("factor").get<double>(), 1.00310959189896, 1e-12);
}

TEST(Cli, ShrinkFitWithTwoRangesGivesAListOfFits) {
  const auto r = run("shrink fit " + kTable1 + " --ranges 2 --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.at("ranges").size(), 2u);
  for (const auto& rg : j["ranges"]) {
    const double a = rg.at("slope").get<double>();
    EXPECT_NEAR(rg.at("factor").get<double>(), 1.0 / (1.0 + a), 1e-15);
    EXPECT_TRUE(rg.contains("intercept"));
  }
}

TEST(Cli, BadInputExitsWithCodeTwoAndWritesNothing) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "amctl_process_cli_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "two.csv") << "nominal_mm,measured_mm\n5,5.1\n10,10.2\n";
  EXPECT_EQ(run("shrink fit " + (dir / "two.csv").string() + " --json").status, 2);
  std::ofstream(dir / "bad.stl") << "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n";
  const auto out = dir / "out.stl";
  EXPECT_EQ(run("shrink apply --model " + (dir / "bad.stl").string() + " --factors z=1.01 -o " +
                out.string()).status,
            2);
  EXPECT_FALSE(fs::exists(out));
  fs::remove_all(dir);
}

TEST(Cli, EstimateHasAnEmpiricalModeAndCalibrateTimeReportsEveryFile) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "amctl_process_cli_time_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  // Ten infill rasters from x = 0 to 50 stepping 5 mm in y: the first is 50 mm, the other
  // nine are diagonals of hypot(50, 5) mm; all are far longer than a link (3 widths).
  std::string g = "G90\nM83\nG1 Z0.2 F600\n;TYPE:Solid infill\n";
  for (int i = 0; i < 10; ++i) {
    g += "G1 X" + std::string(i % 2 ? "0" : "50") + " Y" + std::to_string(5.0 * i) + " E2 F3000\n";
  }
  std::ofstream(dir / "a.gcode") << g;
  auto r = run("estimate " + (dir / "a.gcode").string() + " --mode empirical --json");
  ASSERT_EQ(r.status, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  const double raster = j["features"]["raster_mm"].get<double>();
  EXPECT_NEAR(raster, 50.0 + 9.0 * std::hypot(50.0, 5.0), 1e-9);
  EXPECT_NEAR(j["features"]["time_terms_s"]["raster_pace"].get<double>(), raster / 24.34, 1e-9);

  std::ofstream(dir / "prints.csv") << "gcode,duration_s\na.gcode,30\na.gcode,32\n";
  r = run("calibrate-time " + (dir / "prints.csv").string() + " --fit accel --json");
  ASSERT_EQ(r.status, 0) << r.out;
  j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["samples"].size(), 2u);
  EXPECT_TRUE(j["parameters"][0].contains("std_error"));
  // Fewer prints than parameters: exit code 2.
  std::ofstream(dir / "one.csv") << "gcode,duration_s\na.gcode,30\n";
  EXPECT_EQ(run("calibrate-time " + (dir / "one.csv").string() + " --fit accel,scv").status, 2);
  fs::remove_all(dir);
}

TEST(Cli, ShrinkApplyReadsTheModelFileOfShrinkFitAndScalesInchGcode) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "amctl_process_cli_apply_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const auto fit = run("shrink fit " + kTable1 + " --json");
  ASSERT_EQ(fit.status, 0) << fit.out;
  std::ofstream(dir / "model.json") << fit.out;
  const double c = nlohmann::json::parse(fit.out).at("factor").get<double>();
  ASSERT_NEAR(c, 1.00310959189896, 1e-12);  // Z, as in ShrinkFitJsonHasSlopeInterceptAndFactor
  // Inches: Z0.5 in = 12.7 mm -> 12.7 C mm = 0.5 C in = 0.50155 -> "0.5016"; the extrusion
  // follows the local Z factor: 0.1 C = 0.100311 -> "0.10031". Other lines are kept.
  std::ofstream(dir / "in.gcode") << "G20\nG90\nM83\nG1 Z0.5 F600\nG1 X1 Y0 E0.1\nG4 P\nM84 X Y E\n";
  const auto r = run("shrink apply --gcode " + (dir / "in.gcode").string() + " --factors " +
                     (dir / "model.json").string() + " -o " + (dir / "out.gcode").string() +
                     " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("layers").get<int>(), 1);
  EXPECT_EQ(j.at("factors").at(2).at("factors").at(0).get<double>(), c);
  std::ifstream in(dir / "out.gcode");
  const std::string out((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(out, "G20\nG90\nM83\nG1 Z0.5016 F600\nG1 X1 Y0 E0.10031\nG4 P\nM84 X Y E\n");
  // A malformed model file: exit 2, the file named, nothing written.
  std::ofstream(dir / "bad.json") << "{\"axis\": \"Z\",\n \"factor\": \"one\"}\n";
  const auto bad = run("shrink apply --gcode " + (dir / "in.gcode").string() + " --factors " +
                       (dir / "bad.json").string() + " -o " + (dir / "bad.gcode").string());
  EXPECT_EQ(bad.status, 2);
  EXPECT_FALSE(fs::exists(dir / "bad.gcode"));
  fs::remove_all(dir);
}
