// Empirical estimator (seed 004 section 3). Expected values are hand calculations from the
// G-code written here and the seed's Table 3 (examples/04_head_speeds.csv).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/empirical_time.hpp"

namespace pr = amctl::process;

namespace {

// One layer 0.2 mm high: a 20 mm square perimeter, three 20 mm infill rasters joined by two
// 0.5 mm links, a 30 mm travel, a retraction and a wipe. E for a bead of width w and height h:
// A = (w - h) h + pi h^2 / 4, E = A L / (pi 1.75^2 / 4).
std::string layer_gcode(double w) {
  const double h = 0.2;
  const double area = (w - h) * h + std::numbers::pi * h * h / 4.0;
  const double fa = std::numbers::pi * 1.75 * 1.75 / 4.0;
  auto e = [&](double L) { return std::to_string(area * L / fa); };
  std::string g = "G90\nM83\nG1 Z0.2 F600\n;TYPE:External perimeter\n";
  g += "G1 X20 Y0 E" + e(20) + "\nG1 X20 Y20 E" + e(20) + "\nG1 X0 Y20 E" + e(20) +
       "\nG1 X0 Y0 E" + e(20) + "\n";
  g += ";TYPE:Solid infill\nG1 X20 Y0.5 E" + e(std::hypot(20, 0.5)) + "\n";
  g += "G1 X20 Y1.0 E" + e(0.5) + "\nG1 X0 Y1.0 E" + e(20) + "\nG1 X0 Y1.5 E" + e(0.5) +
       "\nG1 X20 Y1.5 E" + e(20) + "\n";
  g += "G1 E-0.8 F2400\nG1 X20 Y31.5 F6000\nG1 X10 Y31.5 E-0.2\n";
  return g;
}

}  // namespace

TEST(EmpiricalTime, ScanSeparatesRastersLinksContoursAndTravel) {
  pr::ScanOptions opt;
  const auto s = pr::scan_gcode_for_time(layer_gcode(0.505), "sq.gcode", opt);
  EXPECT_NEAR(s.total.contour_mm, 80.0, 1e-9);
  EXPECT_NEAR(s.total.raster_mm, std::hypot(20, 0.5) + 40.0, 1e-9);
  EXPECT_NEAR(s.total.link_mm, 1.0, 1e-9);
  // Width 0.505 is a table node: all link length lands on it.
  ASSERT_EQ(s.total.link_mm_by_width.size(), 3u);
  EXPECT_NEAR(s.total.link_mm_by_width[1], 1.0, 1e-4);
  EXPECT_NEAR(s.total.travel_mm, 0.2 + 30.0 + 10.0, 1e-9);
  EXPECT_DOUBLE_EQ(s.total.retracts, 1.0);
  EXPECT_DOUBLE_EQ(s.total.wipes, 1.0);
  EXPECT_DOUBLE_EQ(s.total.layer_changes, 1.0);
  EXPECT_NEAR(s.mean_raster_width_mm, 0.505, 1e-4);
  ASSERT_EQ(s.layers.size(), 1u);
  EXPECT_NEAR(s.layers[0].raster_mm, s.total.raster_mm, 1e-12);
}

TEST(EmpiricalTime, LinkLengthIsSplitBetweenNeighbouringWidths) {
  const auto s = pr::scan_gcode_for_time(layer_gcode(0.405), "sq.gcode", {});
  // 0.405 lies halfway between 0.305 and 0.505.
  ASSERT_EQ(s.total.link_mm_by_width.size(), 3u);
  EXPECT_NEAR(s.total.link_mm_by_width[0], 0.5, 1e-3);
  EXPECT_NEAR(s.total.link_mm_by_width[1], 0.5, 1e-3);
}

TEST(EmpiricalTime, SeedPresetEstimateIsTheSumOfItsTerms) {
  pr::TimeFeatures f;
  f.raster_mm = 1000;
  f.contour_mm = 200;
  f.link_mm_by_width = {0, 0, 50};
  f.travel_mm = 100;
  f.layer_changes = 10;
  f.files = 1;
  auto m = pr::EmpiricalTimeModel::fdm2000_seed();
  m.layer_change_s = 3.0;
  m.fixed_s = 60.0;
  const double expect = 1200 / 24.34 + 50 / 11.57 + 100 / 24.34 + 30 + 60;
  EXPECT_NEAR(m.estimate_s(f), expect, 1e-9);
}

TEST(EmpiricalTime, SeedTable3AveragesGiveTheImplementedSpeeds) {
  const auto t = pr::CsvTable::read(std::string(AMCTL_SOURCE_DIR) + "/examples/04_head_speeds.csv");
  const auto wc = t.require("width_mm"), rc = t.require("raster_speed_mm_s"),
             lc = t.require("link_speed_mm_s");
  double raster = 0;
  double link[3] = {0, 0, 0};
  for (std::size_t r = 0; r < t.rows(); ++r) {
    raster += t.number(r, rc);
    const double w = t.number(r, wc);
    link[w < 0.4 ? 0 : w < 0.6 ? 1 : 2] += t.number(r, lc) / 4.0;
  }
  EXPECT_NEAR(raster / 12.0, 24.34, 0.005);  // seed: 24.34 mm/s
  EXPECT_NEAR(link[0], 9.13, 0.005);
  EXPECT_NEAR(link[1], 11.10, 0.005);
  EXPECT_NEAR(link[2], 11.57, 0.005);
}

TEST(EmpiricalTime, SeedEquationSixGivesLinkSpeed) {
  // 100 mm of links and 1000 mm of rasters at 25 mm/s timed at 50 s: 100 / (50 - 40) = 10.
  EXPECT_NEAR(pr::link_speed_from_timing(100, 50, 1000, 25), 10.0, 1e-12);
  EXPECT_THROW((void)pr::link_speed_from_timing(100, 30, 1000, 25), amctl::Error);
}

TEST(EmpiricalTime, FitRecoversParametersFromSyntheticTimings) {
  // Durations made with known speeds; features varied so every free parameter is separable.
  pr::EmpiricalTimeModel truth;
  truth.raster_speed_mm_s = 40;
  truth.contour_speed_mm_s = 40;
  truth.link_widths_mm = {0.45};
  truth.link_speeds_mm_s = {12};
  truth.travel_speed_mm_s = 120;
  truth.layer_change_s = 2.0;
  truth.fixed_s = 30.0;
  std::vector<pr::TimeFeatures> xs;
  std::vector<double> ts;
  const double data[6][5] = {{1000, 100, 50, 300, 10},  {3000, 300, 200, 200, 20},
                             {500, 400, 20, 800, 15},   {8000, 600, 900, 100, 50},
                             {2000, 100, 100, 1500, 5}, {4000, 800, 300, 600, 30}};
  for (const auto& d : data) {
    pr::TimeFeatures f;
    f.raster_mm = d[0];
    f.contour_mm = d[1];
    f.link_mm_by_width = {d[2]};
    f.travel_mm = d[3];
    f.layer_changes = d[4];
    f.files = 1;
    xs.push_back(f);
    ts.push_back(truth.estimate_s(f));
  }
  auto start = pr::EmpiricalTimeModel::fdm2000_seed();
  start.link_widths_mm = {0.45};
  start.link_speeds_mm_s = {10};
  const auto fit = pr::fit_empirical(xs, ts, start, {});
  EXPECT_NEAR(fit.model.raster_speed_mm_s, 40, 1e-6);
  EXPECT_NEAR(fit.model.link_speeds_mm_s[0], 12, 1e-6);
  EXPECT_NEAR(fit.model.travel_speed_mm_s, 120, 1e-5);
  EXPECT_NEAR(fit.model.layer_change_s, 2.0, 1e-6);
  EXPECT_NEAR(fit.model.fixed_s, 30.0, 1e-5);
  EXPECT_LT(fit.rms_s, 1e-6);
  // No retractions or wipes anywhere: those parameters are not identified.
  EXPECT_EQ(fit.not_identified.size(), 2u);
  // Too few samples for five free parameters.
  EXPECT_THROW((void)pr::fit_empirical({xs[0], xs[1]}, {ts[0], ts[1]}, start, {}), amctl::Error);
  // Collinear: every sample the same shape -> singular.
  std::vector<pr::TimeFeatures> same(6, xs[0]);
  for (std::size_t i = 0; i < same.size(); ++i) {
    same[i].raster_mm *= static_cast<double>(i + 1);
    same[i].contour_mm *= static_cast<double>(i + 1);
    same[i].link_mm_by_width[0] *= static_cast<double>(i + 1);
    same[i].travel_mm *= static_cast<double>(i + 1);
    same[i].layer_changes *= static_cast<double>(i + 1);
  }
  try {
    (void)pr::fit_empirical(same, ts, start, {});
    FAIL();
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
}
