// dynamics::simulate_print's row callback (PrintSimulationOptions::rows), which the Python
// binding fills its sample arrays from: one call per simulated sample, in time order, with
// the contour error of the samples the metrics count (NaN for the others), the same rows as
// the CSV, and no effect on the report.
#include "amctl/dynamics/print_simulation.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"

namespace amctl::dynamics {
namespace {

const std::string kCorner = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner.gcode";

machine::Machine seed_machine() {
  return machine::load_machine(std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner_printer.cfg");
}

TEST(PrintSimulationRows, OneCallPerSampleInTimeOrderWithTheMeasuredErrors) {
  const machine::Machine m = seed_machine();
  const AxisModel belt = AxisModel::belt(15.915494309189533, 0.5);
  PrintSimulationOptions o;
  o.metrics.t_begin_s = 0.1;  // the first 0.1 s are not measured: NaN rows
  std::size_t calls = 0, measured = 0;
  double last_t = -1.0, max_e = 0.0;
  bool ordered = true;
  o.rows = [&](const SimSample& s, double e) {
    ++calls;
    ordered = ordered && s.t_s > last_t;
    last_t = s.t_s;
    if (std::isnan(e)) {
      EXPECT_LT(s.t_s, 0.1);
      return;
    }
    ++measured;
    max_e = std::max(max_e, e);
  };
  const PrintSimulationResult r = simulate_print(kCorner, m, belt, belt, o);
  EXPECT_TRUE(ordered);
  EXPECT_EQ(calls, r.stats.samples);
  EXPECT_EQ(measured, r.report.samples);
  EXPECT_DOUBLE_EQ(max_e, r.report.max_contour_error_mm);
  // 1 kHz from t = 0 to the motion end (0.24 s: two 10 mm moves rest to rest) plus the settle.
  EXPECT_DOUBLE_EQ(r.report.motion_time_s, 0.24);
  EXPECT_GT(calls, 240u);

  PrintSimulationOptions plain;
  plain.metrics.t_begin_s = 0.1;
  const PrintSimulationResult q = simulate_print(kCorner, m, belt, belt, plain);
  EXPECT_EQ(q.report.samples, r.report.samples);
  EXPECT_EQ(q.report.max_contour_error_mm, r.report.max_contour_error_mm);
  EXPECT_EQ(q.report.rms_contour_error_mm, r.report.rms_contour_error_mm);
}

TEST(PrintSimulationRows, SeeTheSameSamplesAsTheCsv) {
  const machine::Machine m = seed_machine();
  const AxisModel belt = AxisModel::belt(40.0, 0.1);
  const std::string csv = ::testing::TempDir() + "print_simulation_rows.csv";
  PrintSimulationOptions o;
  o.csv_path = csv;
  o.simulation.vibration_per_sample = true;
  std::size_t rows = 0;
  o.rows = [&](const SimSample&, double e) { rows += std::isnan(e) ? 0 : 1; };
  (void)simulate_print(kCorner, m, belt, belt, o);
  std::ifstream in(csv);
  std::size_t lines = 0;
  for (std::string line; std::getline(in, line);) ++lines;
  EXPECT_EQ(lines, rows + 1);  // header + one row per measured sample
  std::remove(csv.c_str());
}

}  // namespace
}  // namespace amctl::dynamics
