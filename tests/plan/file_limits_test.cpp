// --file-limits keep|ignore|cap: the file's own limits commands against the machine's.
// Every time is a closed form: moves of 100 mm from rest to rest (square_corner_velocity 0),
// t = d / v + v / a when the cruise speed v is reached, 2 sqrt(d / a) when it is not.
#include "amctl/plan/file_limits.hpp"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

double rest_to_rest_s(double d, double v, double a) {
  return d * a >= v * v ? d / v + v / a : 2.0 * std::sqrt(d / a);
}

machine::Machine klipper(double accel) {
  machine::Machine m;
  m.max_velocity_mm_s = 300;
  m.max_accel_mm_s2 = accel;
  m.square_corner_velocity_mm_s = 0;
  m.minimum_cruise_ratio = 0;
  return m;
}

EstimateReport run(const std::string& g, const machine::Machine& m, FileLimits f) {
  EstimateOptions o;
  o.planner.file_limits = f;
  return estimate_text(g, "t.gcode", m, o);
}

// Two moves: one at the file's M204 S3000 (above the machine's 1000), one at S500 (below).
const char* kTwoAccels = "G1 X100 F6000\nM204 S3000\nG1 X0\nM204 S500\nG1 X100\n";

TEST(FileLimits, KeepAppliesTheFilesAccelerationsAsKlipperDoes) {
  const auto r = run(kTwoAccels, klipper(1000), FileLimits::keep);
  const double want = rest_to_rest_s(100, 100, 1000) + rest_to_rest_s(100, 100, 3000) +
                      rest_to_rest_s(100, 100, 500);
  EXPECT_NEAR(r.total_time_s, want, 1e-12);
  const FileLimitsReport& f = r.diagnostics.file_limits;
  EXPECT_EQ(f.policy, FileLimits::keep);
  EXPECT_EQ(f.commands, 2u);
  ASSERT_EQ(f.by_command.size(), 1u);
  EXPECT_EQ(f.by_command[0].command, "M204");
  EXPECT_EQ(f.by_command[0].lines, 2u);
  EXPECT_EQ(f.by_command[0].first_line, 2u);
  ASSERT_EQ(f.values.size(), 1u);
  EXPECT_EQ(f.values[0].parameter, "S");
  EXPECT_EQ(f.values[0].min, 500.0);
  EXPECT_EQ(f.values[0].max, 3000.0);
  EXPECT_EQ(f.values[0].values, (std::vector<double>{500.0, 3000.0}));
  EXPECT_EQ(f.capped, 0u);
  EXPECT_EQ(f.ignored, 0u);
}

TEST(FileLimits, IgnorePlansOnTheMachinesLimitsAlone) {
  const auto r = run(kTwoAccels, klipper(1000), FileLimits::ignore);
  EXPECT_NEAR(r.total_time_s, 3 * rest_to_rest_s(100, 100, 1000), 1e-12);
  EXPECT_EQ(r.diagnostics.file_limits.ignored, 2u);
  EXPECT_EQ(r.diagnostics.file_limits.commands, 2u);  // still read and reported
}

TEST(FileLimits, CapLowersWhatIsAboveTheMachineAndKeepsWhatIsBelow) {
  const auto r = run(kTwoAccels, klipper(1000), FileLimits::cap);
  const double want = 2 * rest_to_rest_s(100, 100, 1000) + rest_to_rest_s(100, 100, 500);
  EXPECT_NEAR(r.total_time_s, want, 1e-12);
  EXPECT_EQ(r.diagnostics.file_limits.capped, 1u);
}

TEST(FileLimits, SetVelocityLimitIsCappedKeyByKey) {
  // VELOCITY 500 above the machine's 300 (capped), ACCEL 400 below its 1000 (kept); the move
  // asks for 400 mm/s.
  const char* g = "SET_VELOCITY_LIMIT VELOCITY=500 ACCEL=400\nG1 X100 F24000\n";
  EXPECT_NEAR(run(g, klipper(1000), FileLimits::keep).total_time_s, rest_to_rest_s(100, 400, 400), 1e-12);
  EXPECT_NEAR(run(g, klipper(1000), FileLimits::cap).total_time_s, rest_to_rest_s(100, 300, 400), 1e-12);
  EXPECT_NEAR(run(g, klipper(1000), FileLimits::ignore).total_time_s, rest_to_rest_s(100, 300, 1000), 1e-12);
  const auto f = run(g, klipper(1000), FileLimits::keep).diagnostics.file_limits;
  ASSERT_EQ(f.values.size(), 2u);
  EXPECT_EQ(f.values[0].parameter, "VELOCITY");
  EXPECT_EQ(f.values[0].unit, "mm/s");
  EXPECT_EQ(f.values[1].parameter, "ACCEL");
}

TEST(FileLimits, OtherFirmwaresCommandsAreCountedApartAndNeverApplied) {
  // Klipper has no M201/M203: they change nothing under any policy.
  const char* g = "M201 X100 Y100\nM203 X10 Y10\nG1 X100 F6000\n";
  for (FileLimits p : {FileLimits::keep, FileLimits::ignore, FileLimits::cap}) {
    const auto r = run(g, klipper(1000), p);
    EXPECT_NEAR(r.total_time_s, rest_to_rest_s(100, 100, 1000), 1e-12);
    EXPECT_EQ(r.diagnostics.file_limits.commands, 0u);
    EXPECT_EQ(r.diagnostics.file_limits.other_firmware_commands, 2u);
    EXPECT_EQ(r.diagnostics.file_limits.ignored, 0u);
  }
  EXPECT_EQ(describe_file_limits(run(g, klipper(1000), FileLimits::keep).diagnostics.file_limits).size(), 2u);
}

TEST(FileLimits, MarlinPrintAccelerationIsCappedAtTheMachines) {
  machine::Machine m = klipper(1000);
  m.firmware = machine::Firmware::marlin;
  m.junction = machine::JunctionPolicy::junction_deviation;
  m.print_accel_mm_s2 = m.travel_accel_mm_s2 = m.retract_accel_mm_s2 = 800;
  m.max_axis_accel_mm_s2 = {10000, 10000, 10000, 10000};
  m.max_feedrate_mm_s = {300, 300, 300, 300};
  m.min_segment_time_s = 0;
  // A travel (no E): Marlin's travel acceleration, M204 T.
  const char* g = "M204 T2000\nG1 X100 F6000\n";
  EXPECT_NEAR(run(g, m, FileLimits::keep).total_time_s, rest_to_rest_s(100, 100, 2000), 1e-9);
  EXPECT_NEAR(run(g, m, FileLimits::cap).total_time_s, rest_to_rest_s(100, 100, 800), 1e-9);
  EXPECT_NEAR(run(g, m, FileLimits::ignore).total_time_s, rest_to_rest_s(100, 100, 800), 1e-9);
}

TEST(FileLimits, NamesParseBothWays) {
  for (FileLimits p : {FileLimits::keep, FileLimits::ignore, FileLimits::cap}) {
    EXPECT_EQ(parse_file_limits(to_string(p)), p);
  }
  EXPECT_FALSE(parse_file_limits("Keep").has_value());
  EXPECT_TRUE(describe_file_limits(FileLimitsReport{}).empty());
}

}  // namespace
}  // namespace amctl::plan
