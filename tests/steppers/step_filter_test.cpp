// Klipper's step+direction+step filter against stepcompress_append's rule worked by hand: a
// pending step and an opposite step of the same stepper less than 750 us later are both
// dropped; at 750 us or with the same direction both stay; after a rollback the next step
// starts afresh; output stays in time order across steppers. And on a file: a one-microstep
// reversal at 100 000 mm/s^2 whose step back and forth are 548 us apart.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"
#include "amctl/steppers/step_filter.hpp"

namespace amctl::steppers {
namespace {

std::vector<Step> run(const std::vector<Step>& in, StepDirFilter& f) {
  std::vector<Step> out;
  // Fed one step at a time, as moves would.
  for (const Step& s : in) f.push(std::span<const Step>(&s, 1), out);
  f.finish(out);
  return out;
}

TEST(StepDirFilter, DropsAStepAndItsStepBackWithin750us) {
  StepDirFilter f(2);
  const std::vector<Step> in = {
      {0.0, 0, +1},      // dropped with the next
      {0.0002, 1, +1},   // other stepper, kept
      {0.0005, 0, -1},   // 0.5 ms after its pending step, opposite: both go
      {0.0006, 1, +1},   // same direction: kept
      {0.0010, 0, +1},   // nothing pending after the rollback: kept
      {0.0019, 0, -1},   // 0.9 ms later: kept
  };
  const std::vector<Step> out = run(in, f);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_EQ(out[0].time_s, 0.0002);
  EXPECT_EQ(out[1].time_s, 0.0006);
  EXPECT_EQ(out[2].time_s, 0.0010);
  EXPECT_EQ(out[3].time_s, 0.0019);
  EXPECT_EQ(f.pairs_removed()[0], 1u);
  EXPECT_EQ(f.pairs_removed()[1], 0u);
  EXPECT_EQ(f.stats()[0].steps, 2u);
  EXPECT_EQ(f.stats()[0].position_steps, 0);
  EXPECT_EQ(f.stats()[1].steps, 2u);
  EXPECT_NEAR(f.stats()[1].min_interval_s, 0.0004, 1e-15);
}

TEST(StepDirFilter, ExactlyTheWindowApartIsKept) {
  StepDirFilter f(1);
  const std::vector<Step> out = run({{0.0, 0, +1}, {0.00075, 0, -1}}, f);
  EXPECT_EQ(out.size(), 2u);  // stepcompress.c: diff < SDS_FILTER_TIME, strictly
  EXPECT_EQ(f.pairs_removed()[0], 0u);
}

TEST(StepDirFilter, OnlyThePendingStepIsRolledBack) {
  // +1, +1 (commits the first), -1 within 750 us of the second: the second and the -1 go,
  // the first stays.
  StepDirFilter f(1);
  const std::vector<Step> out = run({{0.0, 0, +1}, {0.0001, 0, +1}, {0.0002, 0, -1}}, f);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].time_s, 0.0);
}

TEST(StepDirFilter, AFileReversalOfOneStepIsFilteredAsKlipperWould) {
  // Klipper Ender-3-like printer, X: 0.0125 mm steps. X10 ends on step 800 (its level 9.99375
  // crossed on the way). X9.99 crosses 9.99375 back (-1), X10 forward again (+1). Each 0.01 mm
  // move brakes at 100 000 mm/s^2 into the turn; the level lies 0.00375 mm from it, passed
  // sqrt(2 * 0.00375 / 1e5) = 0.274 ms before and after it: the pair is about 0.55 ms apart
  // (0.559 ms in the CSV), inside 750 us, so Klipper's filter drops both.
  machine::Machine m = machine::load_machine(std::string(AMCTL_SOURCE_DIR) +
                                             "/tests/reference/klipper/steps_cartesian.cfg");
  m.max_accel_mm_s2 = 100000.0;
  const std::string g = std::string(AMCTL_BINARY_DIR) + "/step_filter_test.gcode";
  {
    std::ofstream(g) << "G90\nG1 X10 F6000\nG1 X9.99\nG1 X10\n";
  }
  const StepsReport raw = generate_steps_file(g, m, "");
  const StepsReport klipper = generate_steps_file(g, m, "", StepFilter::klipper);
  std::remove(g.c_str());
  ASSERT_EQ(raw.motors[0].name, "stepper_x");
  EXPECT_EQ(raw.stats[0].steps, 802u);
  EXPECT_EQ(raw.stats[0].steps_negative, 1u);
  EXPECT_EQ(klipper.stats[0].steps, 800u);
  EXPECT_EQ(klipper.stats[0].steps_negative, 0u);
  EXPECT_EQ(klipper.stats[0].position_steps, raw.stats[0].position_steps);
  EXPECT_EQ(klipper.filtered_pairs[0], 1u);
}

}  // namespace
}  // namespace amctl::steppers
