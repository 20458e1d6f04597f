// `--set section.key=value` overrides.
#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"
#include "test_util.hpp"

namespace amctl::machine {
namespace {

using test::error_of;

Machine with(std::initializer_list<std::string> sets, Machine m = Machine{}) {
  for (const auto& s : sets) apply_override(m, s);
  return m;
}

TEST(Override, SetsNumbersArraysElementsEnumsAndText) {
  const Machine m = with({"printer.max_accel=5000", "marlin.jerk=[10, 10, 0.3, 5]",
                          "marlin.max_feedrate.z=20", "printer.firmware=marlin",
                          "printer.kinematics=\"corexy\"", "printer.name=My printer",
                          "extruder.max_extrude_only_velocity=60", "arcs.min_circle_segments=72",
                          " printer.max_velocity = 1e3 "});
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 5000);
  EXPECT_EQ(m.jerk_mm_s, (std::array<double, 4>{10, 10, 0.3, 5}));
  EXPECT_DOUBLE_EQ(m.max_feedrate_mm_s[2], 20);
  EXPECT_DOUBLE_EQ(m.max_feedrate_mm_s[0], 500);  // other elements untouched
  EXPECT_EQ(m.firmware, Firmware::marlin);
  EXPECT_EQ(m.junction, JunctionPolicy::square_corner_velocity);  // only the named key changes
  EXPECT_TRUE(kinematics::is<kinematics::CoreXY>(m.kinematics));
  EXPECT_EQ(m.name, "My printer");
  EXPECT_EQ(m.extruder.max_extrude_only_velocity_mm_s, 60.0);
  EXPECT_EQ(m.arcs.min_circle_segments, 72);
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 1000);
}

TEST(Override, StepperKeysCreateTheStepperWithDefaults) {
  const Machine m = with({"stepper_x.microsteps=32", "stepper_z.gear_ratio=80:16"});
  EXPECT_EQ(m.steppers.at("x").microsteps, 32);
  EXPECT_DOUBLE_EQ(m.steppers.at("x").rotation_distance_mm, 40);  // Stepper default
  EXPECT_DOUBLE_EQ(m.steppers.at("z").rotation_distance_mm, 8);   // 40 / (80/16)
}

TEST(Override, MaxAccelToDecelUsesTheCurrentMaxAccel) {
  const Machine m = with({"printer.max_accel=8000", "printer.max_accel_to_decel=2000"});
  EXPECT_DOUBLE_EQ(m.minimum_cruise_ratio, 0.75);  // 1 - 2000/8000
}

TEST(Override, UnknownKeysSuggestTheClosestKey) {
  Machine m;
  EXPECT_EQ(error_of([&] { apply_override(m, "printer.max_acel=5000"); }),
            "--set printer.max_acel=5000: unknown key 'printer.max_acel', expected a key that `amctl machine keys` lists; "
            "did you mean 'printer.max_accel'?");
  EXPECT_EQ(error_of([&] { apply_override(m, "printer.jerk=[1,1,1,1]"); }),
            "--set printer.jerk=[1,1,1,1]: unknown key 'printer.jerk', expected a key that `amctl machine keys` lists; "
            "did you mean 'marlin.jerk'?");
  EXPECT_EQ(error_of([&] { apply_override(m, "stepper_x.microstep=8"); }),
            "--set stepper_x.microstep=8: unknown key 'stepper_x.microstep', expected a key that `amctl machine keys` lists; "
            "did you mean 'microsteps'?");
  EXPECT_EQ(error_of([&] { apply_override(m, "max_accel=5000"); }),
            "--set max_accel=5000: expected section.key=value, e.g. printer.max_accel=5000");
  EXPECT_EQ(error_of([&] { apply_override(m, "printer.max_accel"); }),
            "--set printer.max_accel: expected section.key=value, e.g. printer.max_accel=5000");
}

TEST(Override, ValuesAreTypeAndRangeChecked) {
  Machine m;
  EXPECT_EQ(error_of([&] { apply_override(m, "printer.max_accel=fast"); }),
            "--set printer.max_accel=fast: printer.max_accel: expected a number in mm/s^2, got "
            "a string");
  EXPECT_EQ(error_of([&] { apply_override(m, "printer.max_accel=-1"); }),
            "--set printer.max_accel=-1: printer.max_accel must be a finite number > 0 mm/s^2, "
            "got -1");
  EXPECT_EQ(error_of([&] { apply_override(m, "marlin.jerk.w=3"); }),
            "--set marlin.jerk.w=3: unknown key 'marlin.jerk.w', expected a key that `amctl machine keys` lists (the "
            "element must be x, y, z or e)");
  EXPECT_EQ(error_of([&] { apply_override(m, "printer.firmware=grbl"); }),
            "--set printer.firmware=grbl: printer.firmware: found 'grbl', expected one of "
            "klipper, marlin, reprap");
  EXPECT_NE(error_of([&] { apply_override(m, "stepper_y.microsteps=0"); }).find(">= 1"),
            std::string::npos);
  EXPECT_EQ(m, Machine{});  // failed overrides leave the machine as it was
}

TEST(Override, LoadMachineAppliesOverridesInOrderThenValidates) {
  const Machine m = load_machine("voron24", {"printer.max_accel=5000", "printer.max_accel=6000"});
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 6000);
  EXPECT_EQ(error_of([] { (void)load_machine("voron24", {"extruder.filament_diameter=0.2"}); }),
            "extruder.filament_diameter (0.2 mm) must be >= extruder.nozzle_diameter (0.4 mm)");
}

}  // namespace
}  // namespace amctl::machine
