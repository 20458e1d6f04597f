// amctl compare's study (comparison::compare_file): the rows are the runs they name.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "amctl/comparison/compare.hpp"
#include "amctl/compensation/compensate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/dynamics/print_simulation.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/simulation/shaped_simulation.hpp"

namespace amctl::comparison {
namespace {

const std::string kGcode = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner.gcode";
const std::string kPrinter = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner_printer.cfg";
constexpr double kF = 15.915494309189533;  // 100 rad/s
constexpr double kZeta = 0.5;

ComparisonOptions seed_options() {
  ComparisonOptions o;
  o.natural_frequency_hz = kF;
  o.damping_ratio = kZeta;
  return o;
}

dynamics::PrintSimulationOptions sim_options(const machine::Machine& m) {
  dynamics::PrintSimulationOptions o;
  o.simulation.sample_rate_hz = 1000.0;
  o.metrics.keep_per_move = false;
  return o;
}

TEST(Compare, SeedBaseCaseRowsAreTheRunsTheyName) {
  const machine::Machine m = machine::load_machine(kPrinter, {});
  const ComparisonOptions o = seed_options();
  const ComparisonResult r = compare_file(kGcode, m, o);
  ASSERT_EQ(r.rows.size(), (o.methods.size() + 1) * o.plant_offsets_pct.size());
  const dynamics::AxisModel model = dynamics::AxisModel::belt(kF, kZeta);
  std::size_t seen_zero = 0;
  for (const auto& row : r.rows) {
    if (row.plant_offset_pct != 0.0) continue;
    ++seen_zero;
    EXPECT_EQ(row.plant_natural_frequency_hz, kF);
    if (row.kind == "uncompensated") {
      // what `amctl simulate` reports
      const dynamics::PrintSimulationResult s = dynamics::simulate_print(kGcode, m, model, model, sim_options(m));
      EXPECT_EQ(row.max_contour_error_mm, s.report.max_contour_error_mm);
      EXPECT_EQ(row.rms_contour_error_mm, s.report.rms_contour_error_mm);
      EXPECT_EQ(row.max_residual_vibration_mm, s.report.max_residual_vibration_mm);
      EXPECT_NEAR(row.max_contour_error_mm, 0.4636, 1e-4);
    } else if (row.kind == "compensation") {
      // what `amctl compensate --method M` reports
      compensation::CompensationOptions c;
      c.method = compensation::parse_method(row.method);
      c.model_x = c.model_y = c.plant_x = c.plant_y = model;
      const compensation::CompensationResult e = compensation::compensate_file(kGcode, m, c);
      EXPECT_EQ(row.status, compensation::to_string(e.status)) << row.method;
      EXPECT_EQ(row.max_contour_error_mm, e.max_contour_error_mm) << row.method;
      EXPECT_EQ(row.max_tracking_error_mm, e.max_tracking_error_mm) << row.method;
      EXPECT_EQ(row.rms_tracking_error_mm, e.rms_tracking_error_mm) << row.method;
      EXPECT_EQ(row.peak_command_accel_mm_s2, e.peak_command_accel_mm_s2) << row.method;
      EXPECT_EQ(row.lead_in_s, e.lead_in_s) << row.method;
      EXPECT_EQ(row.motion_time_s, e.motion_time_s) << row.method;
      EXPECT_TRUE(std::isnan(row.max_residual_vibration_mm));
    } else {
      ASSERT_EQ(row.kind, "shaper");
      simulation::AxisShaperSetting s{row.method, kF, kZeta, "test"};
      simulation::ShaperSettings settings;
      settings.x = settings.y = s;
      const simulation::ShapedPrintResult e =
          simulation::simulate_shaped_print(kGcode, m, model, model, sim_options(m), settings);
      EXPECT_EQ(row.max_contour_error_mm, e.shaped.report.max_contour_error_mm) << row.method;
      EXPECT_EQ(row.rms_contour_error_mm, e.shaped.report.rms_contour_error_mm) << row.method;
      EXPECT_EQ(row.max_residual_vibration_mm, e.shaped.report.max_residual_vibration_mm) << row.method;
      EXPECT_EQ(row.smoothing_mm, e.smoothing.max_mm) << row.method;
      EXPECT_TRUE(std::isnan(row.max_tracking_error_mm));
    }
  }
  EXPECT_EQ(seen_zero, o.methods.size() + 1);
}

TEST(Compare, OffsetsMoveThePlantOnly) {
  const machine::Machine m = machine::load_machine(kPrinter, {});
  ComparisonOptions o = seed_options();
  o.methods = {"fbf", "rfbf"};
  o.plant_offsets_pct = {-20.0, 20.0};
  const ComparisonResult r = compare_file(kGcode, m, o);
  ASSERT_EQ(r.rows.size(), 6u);
  EXPECT_EQ(r.rows[0].method, "uncompensated");
  EXPECT_NEAR(r.rows[0].plant_natural_frequency_hz, 0.8 * kF, 1e-12);
  EXPECT_NEAR(r.rows[3].plant_natural_frequency_hz, 1.2 * kF, 1e-12);
  const dynamics::AxisModel model = dynamics::AxisModel::belt(kF, kZeta);
  compensation::CompensationOptions c;
  c.method = compensation::Method::rfbf;
  c.model_x = c.model_y = model;
  c.plant_x = c.plant_y = dynamics::AxisModel::belt(1.2 * kF, kZeta);
  const compensation::CompensationResult e = compensation::compensate_file(kGcode, m, c);
  EXPECT_EQ(r.rows[5].method, "rfbf");
  EXPECT_EQ(r.rows[5].max_contour_error_mm, e.max_contour_error_mm);
  EXPECT_EQ(r.rows[5].max_tracking_error_mm, e.max_tracking_error_mm);
  // the model mismatch costs accuracy
  EXPECT_GT(r.rows[5].max_tracking_error_mm, 0.01);
  const Json j = to_json(r);
  EXPECT_EQ(j["rows"].size(), 6u);
  EXPECT_EQ(j["rows"][1]["method"], "fbf");
  EXPECT_TRUE(j["rows"][0]["max_tracking_error_mm"].is_null());
}

TEST(Compare, LayerSpanOfTheWholeSeedFileGivesTheFileRows) {
  // The seed file is one layer (-1): the span runs see the same moves as the file runs.
  const machine::Machine m = machine::load_machine(kPrinter, {});
  ComparisonOptions o = seed_options();
  o.plant_offsets_pct = {0.0, 10.0};
  const ComparisonResult file = compare_file(kGcode, m, o);
  o.layer = -1;
  const ComparisonResult span = compare_file(kGcode, m, o);
  ASSERT_EQ(span.rows.size(), file.rows.size());
  for (std::size_t i = 0; i < span.rows.size(); ++i) {
    const auto& a = span.rows[i];
    const auto& b = file.rows[i];
    EXPECT_EQ(a.method, b.method);
    EXPECT_NEAR(a.max_contour_error_mm, b.max_contour_error_mm, 1e-12) << a.method;
    if (a.kind == "compensation") {
      EXPECT_EQ(a.max_tracking_error_mm, b.max_tracking_error_mm) << a.method;
      EXPECT_EQ(a.peak_command_accel_mm_s2, b.peak_command_accel_mm_s2) << a.method;
    } else {
      EXPECT_NEAR(a.rms_contour_error_mm, b.rms_contour_error_mm, 1e-12) << a.method;
      EXPECT_NEAR(a.max_residual_vibration_mm, b.max_residual_vibration_mm, 1e-12) << a.method;
      EXPECT_NEAR(a.smoothing_mm, b.smoothing_mm, 1e-12) << a.method;
    }
  }
  o.layer = 7;
  EXPECT_THROW((void)compare_file(kGcode, m, o), Error);
}

void expect_error_naming(const ComparisonOptions& o, const std::string& param) {
  try {
    validate(o);
    ADD_FAILURE() << "no error for " << param;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(param), std::string::npos) << e.what();
  }
}

TEST(Compare, BadInputNamesTheParameter) {
  ComparisonOptions o = seed_options();
  o.methods = {"fbf", "magic"};
  expect_error_naming(o, "--methods");
  o.methods = {"fbf", "fbf"};
  expect_error_naming(o, "--methods");
  o = seed_options();
  o.plant_offsets_pct = {0.0, -100.0};
  expect_error_naming(o, "--plant-offsets");
  o.plant_offsets_pct = {std::nan("")};
  expect_error_naming(o, "--plant-offsets");
  o = seed_options();
  o.natural_frequency_hz = 0.0;
  expect_error_naming(o, "--natural-frequency-hz");
  o = seed_options();
  o.damping_ratio = 1.0;  // the shapers need < 1
  expect_error_naming(o, "--damping-ratio");
  o.methods = {"fbf"};
  EXPECT_NO_THROW(validate(o));
  o = seed_options();
  o.max_base_accel_mm_s2 = -1.0;
  expect_error_naming(o, "--max-base-accel-mm-s2");
}

}  // namespace
}  // namespace amctl::comparison
