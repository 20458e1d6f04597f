// Reference values: tests/reference/process_shrink_reference.py (scipy.stats.linregress,
// brute-force split search). Seed data: examples/04_shrink_geometry1.csv (seed 004, Table 1).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/shrinkage.hpp"

namespace pr = amctl::process;

namespace {

std::vector<pr::ShrinkSample> table1() {
  const auto t = pr::CsvTable::read(std::string(AMCTL_SOURCE_DIR) +
                                    "/examples/04_shrink_geometry1.csv");
  return pr::read_shrink_samples(t);
}

std::vector<pr::ShrinkSample> from_csv(const std::string& text) {
  return pr::read_shrink_samples(pr::CsvTable::parse(text, "test.csv"));
}

std::string expect_error(auto&& fn) {
  try {
    fn();
  } catch (const amctl::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected amctl::Error";
  return {};
}

}  // namespace

TEST(Shrinkage, SizesBeyondAKilometreAreRefusedBeforeTheFitOverflows) {
  // Found by fuzz_process_csv: measured_mm = 1e308 is finite, but the fit's sums of squares
  // overflowed to a NaN slope and `shrink fit` printed factor 0 with null statistics.
  EXPECT_EQ(expect_error([] {
              (void)from_csv("nominal_mm,measured_mm\n10,10.1\n20,1e308\n30,30.2\n");
            }),
            "test.csv:3:4: measured size 1e+308 mm is out of range: expected at most 1e6 mm (1 km)");
  EXPECT_NE(expect_error([] { (void)from_csv("nominal_in,measured_in\n1e5,1\n"); })
                .find("test.csv:2:1: nominal size 2540000 mm is out of range"),
            std::string::npos);
  EXPECT_EQ(from_csv("nominal_mm,measured_mm\n1e6,1e6\n").size(), 1u);  // the limit itself
}

TEST(Shrinkage, Table1SingleLineMatchesScipyLinregress) {
  const auto fit = pr::fit_shrinkage(table1(), {});
  ASSERT_EQ(fit.size(), 1u);
  ASSERT_EQ(fit[0].ranges.size(), 1u);
  const auto& r = fit[0].ranges[0];
  EXPECT_EQ(fit[0].axis, 'Z');
  EXPECT_NEAR(r.line.slope, -0.00309995231236014, 1e-14);
  EXPECT_NEAR(r.line.intercept, 0.327948993299212, 1e-12);
  EXPECT_NEAR(r.line.slope_se, 0.000412044751362927, 1e-14);
  EXPECT_NEAR(r.line.intercept_se, 0.0247022795870605, 1e-12);
  EXPECT_NEAR(r.line.r2, 0.758715169276931, 1e-12);
  EXPECT_NEAR(r.factor, 1.00310959189896, 1e-12);
  EXPECT_NEAR(r.factor_ci_lo, 1.00223928159118, 1e-10);
  EXPECT_NEAR(r.factor_ci_hi, 1.00398141501581, 1e-10);
  // The seed's C2 = 1.0032 lies inside the 95 % interval, 0.0001 above our estimate.
  EXPECT_LT(r.factor_ci_lo, 1.0032);
  EXPECT_GT(r.factor_ci_hi, 1.0032);
  EXPECT_NEAR(r.factor, 1.0032, 1.2e-4);
}

TEST(Shrinkage, BestTwoRangeSplitAgreesWithBruteForce) {
  pr::ShrinkFitOptions opt;
  opt.ranges = 2;
  const auto fit = pr::fit_shrinkage_axis(table1(), opt);
  ASSERT_EQ(fit.ranges.size(), 2u);
  EXPECT_TRUE(fit.breaks_from_data);
  // Brute force: cut before 90.17 mm, so the break is the midpoint (85.09 + 90.17) / 2.
  EXPECT_NEAR(fit.ranges[0].upper_mm, 87.63, 1e-12);
  EXPECT_EQ(fit.ranges[0].line.n, 17u);
  EXPECT_NEAR(fit.total_sse, 0.03510072252778, 1e-12);
}

TEST(Shrinkage, AutomaticRangeCountKeepsOneLineForTable1) {
  pr::ShrinkFitOptions opt;
  opt.ranges = 0;
  const auto fit = pr::fit_shrinkage_axis(table1(), opt);
  EXPECT_EQ(fit.ranges.size(), 1u);
}

TEST(Shrinkage, UserBreakpointSplitsAtTenMillimetresInclusive) {
  pr::ShrinkFitOptions opt;
  opt.breaks_mm = {30.0};
  const auto fit = pr::fit_shrinkage_axis(table1(), opt);
  ASSERT_EQ(fit.ranges.size(), 2u);
  EXPECT_EQ(fit.ranges[0].line.n, 6u);  // 5.08 ... 29.97
  EXPECT_NEAR(fit.ranges[0].upper_mm, 30.0, 0);
  EXPECT_FALSE(fit.breaks_from_data);
}

TEST(Shrinkage, TwoLinesAreRecoveredFromNoiseFreeData) {
  // E = 0.01 h for h <= 10, E = 0.1 - 0.003 (h - 10) above: factors 1/1.01 and 1/0.997.
  std::string csv = "nominal_mm,measured_mm\n";
  for (double h = 1; h <= 30; h += 1) {
    const double e = h <= 10 ? 0.01 * h : 0.1 - 0.003 * (h - 10);
    csv += std::to_string(h) + "," + std::to_string(h + e) + "\n";
  }
  pr::ShrinkFitOptions opt;
  opt.ranges = 0;
  const auto fit = pr::fit_shrinkage_axis(from_csv(csv), opt);
  ASSERT_EQ(fit.ranges.size(), 2u);
  EXPECT_NEAR(fit.ranges[0].upper_mm, 10.5, 1e-12);
  EXPECT_NEAR(fit.ranges[0].factor, 1.0 / 1.01, 1e-6);
  EXPECT_NEAR(fit.ranges[1].factor, 1.0 / 0.997, 1e-6);
}

TEST(Shrinkage, RepeatedMeasurementsGiveLackOfFitTestAndMeanFit) {
  // Same synthetic data as the reference script.
  const double lv[5] = {2, 4, 6, 8, 10};
  const double dev[3] = {-0.01, 0.0, 0.012};
  const double curv[5] = {0.0, 0.01, 0.015, 0.01, 0.0};
  std::string csv = "part,nominal_mm,reading,measured_mm\n";
  for (int i = 0; i < 5; ++i) {
    for (int k = 0; k < 3; ++k) {
      const double e = -0.004 * lv[i] + 0.1 + dev[k] + curv[i];
      csv += "p,";
      csv += std::to_string(lv[i]) + "," + std::to_string(k) + ",";
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.17g", lv[i] + e);
      csv += std::string(buf) + "\n";
    }
  }
  const auto samples = from_csv(csv);
  const auto raw = pr::fit_shrinkage_axis(samples, {});
  const auto& r = raw.ranges[0];
  EXPECT_NEAR(r.line.slope, -0.004, 1e-12);
  EXPECT_NEAR(r.line.intercept, 0.107666666666667, 1e-12);
  EXPECT_NEAR(r.line.slope_se, 0.00106015641484246, 1e-12);
  EXPECT_NEAR(r.pure_error_sd_mm, 0.0110151410945722, 1e-12);
  ASSERT_TRUE(r.lack_of_fit_p.has_value());
  EXPECT_NEAR(*r.lack_of_fit_p, 0.277822084350361, 1e-9);
  pr::ShrinkFitOptions avg;
  avg.average_repeats = true;
  const auto m = pr::fit_shrinkage_axis(samples, avg);
  EXPECT_EQ(m.ranges[0].line.n, 5u);
  EXPECT_NEAR(m.ranges[0].line.slope_se, 0.00122474487139159, 1e-12);
}

TEST(Shrinkage, AxesAreFittedSeparately) {
  std::string csv = "axis,nominal_mm,measured_mm\n";
  for (double h = 10; h <= 50; h += 10) {
    csv += "X," + std::to_string(h) + "," + std::to_string(h * 0.99) + "\n";
    csv += "z," + std::to_string(h) + "," + std::to_string(h * 1.002 + 0.1) + "\n";
  }
  const auto fit = pr::fit_shrinkage(from_csv(csv), {});
  ASSERT_EQ(fit.size(), 2u);
  EXPECT_EQ(fit[0].axis, 'X');
  EXPECT_NEAR(fit[0].ranges[0].factor, 1.0 / 0.99, 1e-6);
  EXPECT_EQ(fit[1].axis, 'Z');
  EXPECT_NEAR(fit[1].ranges[0].factor, 1.0 / 1.002, 1e-6);
  EXPECT_NEAR(fit[1].ranges[0].line.intercept, 0.1, 1e-5);
}

TEST(Shrinkage, UnitsAreConvertedAndMismatchedUnitsRejected) {
  const auto s = from_csv("nominal_in,measured_in\n1,1.01\n2,2.02\n3,3.03\n");
  EXPECT_NEAR(s[1].nominal_mm, 50.8, 1e-12);
  const auto msg = expect_error([] { (void)from_csv("nominal_mm,measured_in\n1,1\n"); });
  EXPECT_NE(msg.find("units do not match"), std::string::npos) << msg;
}

TEST(Shrinkage, BadInputIsRejectedWithLocation) {
  auto msg = expect_error([] { (void)from_csv("nominal_mm,measured_mm\n5,-1\n"); });
  EXPECT_NE(msg.find("test.csv:2:"), std::string::npos) << msg;
  msg = expect_error([] { (void)from_csv("nominal,measured\n5,1\n"); });
  EXPECT_NE(msg.find("nominal_mm"), std::string::npos) << msg;
  msg = expect_error([] { (void)from_csv("nominal_mm,measured_mm\n5,abc\n"); });
  EXPECT_NE(msg.find("test.csv:2:3"), std::string::npos) << msg;
  // Fewer points than parameters + 1.
  msg = expect_error([] {
    (void)pr::fit_shrinkage(from_csv("nominal_mm,measured_mm\n5,5.1\n10,10.1\n"), {});
  });
  EXPECT_NE(msg.find("needs at least 3"), std::string::npos) << msg;
  // Singular: one nominal value measured many times.
  msg = expect_error([] {
    (void)pr::fit_shrinkage(from_csv("nominal_mm,measured_mm\n5,5.1\n5,5.2\n5,5.0\n"), {});
  });
  EXPECT_NE(msg.find("singular"), std::string::npos) << msg;
  // Non-monotone breakpoints.
  pr::ShrinkFitOptions opt;
  opt.breaks_mm = {50, 20};
  msg = expect_error([&] { (void)pr::fit_shrinkage_axis(table1(), opt); });
  EXPECT_NE(msg.find("strictly increasing"), std::string::npos) << msg;
}
