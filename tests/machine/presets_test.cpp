// Presets: each parses, validates, round-trips, and holds the numbers of its cited source
// (checked here against the source's own figures, e.g. Marlin's steps/mm, not against our
// derived rotation distances).
#include <algorithm>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "amctl/machine/effective.hpp"
#include "amctl/machine/loader.hpp"
#include "test_util.hpp"

namespace amctl::machine {
namespace {

using test::error_of;

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Presets, IncludeTheDefaultAKlipperCoreXYAPrusaMk3sAndAnEnder3) {
  const auto names = preset_names();
  for (const char* n : {"default", "voron24", "prusa-mk3s", "ender3"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  }
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
}

TEST(Presets, CompiledInTextIsExactlyTheFileInConfigs) {
  ASSERT_GE(preset_names().size(), 4u);  // an empty list would check nothing
  for (const auto& name : preset_names()) {
    EXPECT_EQ(preset_toml(name), read(std::string(AMCTL_SOURCE_DIR) + "/configs/" + name + ".toml"))
        << name;
  }
}

TEST(Presets, EveryPresetValidatesAndRoundTripsThroughToml) {
  ASSERT_GE(preset_names().size(), 4u);  // an empty list would check nothing
  for (const auto& name : preset_names()) {
    const Machine m = preset(name);
    EXPECT_NO_THROW(validate(m)) << name;
    EXPECT_EQ(m.name, name);
    const Machine back = parse_machine_toml(to_toml(m), "roundtrip.toml");
    EXPECT_EQ(back, m) << name << "\n" << to_toml(m);
  }
}

TEST(Presets, DefaultPresetIsTheBuiltInDefaultMachine) {
  EXPECT_EQ(preset("default"), Machine{});
  EXPECT_EQ(load_machine(""), Machine{});
}

TEST(Presets, Voron24HasTheVoronOctopusConfigLimits) {
  const Machine m = preset("voron24");
  EXPECT_EQ(m.firmware, Firmware::klipper);
  EXPECT_TRUE(kinematics::is<kinematics::CoreXY>(m.kinematics));
  EXPECT_EQ(m.junction, JunctionPolicy::square_corner_velocity);
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 300);
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 3000);
  EXPECT_DOUBLE_EQ(m.max_z_velocity_mm_s, 15);
  EXPECT_DOUBLE_EQ(m.max_z_accel_mm_s2, 350);
  EXPECT_DOUBLE_EQ(m.square_corner_velocity_mm_s, 5);
  EXPECT_DOUBLE_EQ(m.minimum_cruise_ratio, 0.5);
  // Z: 40 mm belt per 80-tooth pulley turn, 80:16 reduction -> 8 mm per motor turn;
  // 200 full steps * 32 microsteps / 8 mm = 800 steps/mm.
  EXPECT_DOUBLE_EQ(m.steppers.at("z").steps_per_mm(), 800.0);
  EXPECT_EQ(m.steppers.count("z3"), 1u);
  // E: 22.6789511 mm per drive-gear turn / (50/17) = 7.710843374 mm per motor turn;
  // 6400 / 7.710843374 = 829.9999... steps/mm (hand calculation).
  EXPECT_NEAR(m.steppers.at("e").rotation_distance_mm, 7.710843374, 1e-12);
  EXPECT_NEAR(m.steppers.at("e").steps_per_mm(), 6400.0 / 7.710843374, 1e-9);
  // X: 32 * 200 / 40 = 160 steps/mm.
  EXPECT_DOUBLE_EQ(m.steppers.at("x").steps_per_mm(), 160.0);
}

TEST(Presets, PrusaMk3sReproducesTheFirmwareStepsPerUnitAndLimits) {
  const Machine m = preset("prusa-mk3s");
  EXPECT_EQ(m.firmware, Firmware::marlin);
  EXPECT_EQ(m.junction, JunctionPolicy::classic_jerk);
  // DEFAULT_AXIS_STEPS_PER_UNIT {100, 100, 3200/8, 280}
  EXPECT_NEAR(m.steppers.at("x").steps_per_mm(), 100.0, 1e-9);
  EXPECT_NEAR(m.steppers.at("y").steps_per_mm(), 100.0, 1e-9);
  EXPECT_NEAR(m.steppers.at("z").steps_per_mm(), 400.0, 1e-9);
  EXPECT_NEAR(m.steppers.at("e").steps_per_mm(), 280.0, 1e-9);
  EXPECT_EQ(m.max_feedrate_mm_s, (std::array<double, 4>{200, 200, 12, 120}));
  EXPECT_EQ(m.max_axis_accel_mm_s2, (std::array<double, 4>{1000, 1000, 200, 5000}));
  EXPECT_EQ(m.jerk_mm_s, (std::array<double, 4>{10, 10, 0.4, 4.5}));
  EXPECT_DOUBLE_EQ(m.print_accel_mm_s2, 1250);
  EXPECT_DOUBLE_EQ(m.retract_accel_mm_s2, 1250);
  EXPECT_DOUBLE_EQ(m.travel_accel_mm_s2, 1250);
  EXPECT_DOUBLE_EQ(m.min_segment_time_s, 20000e-6);  // DEFAULT_MINSEGMENTTIME 20000 us
  EXPECT_EQ(m.arcs.min_circle_segments, 20);
  EXPECT_DOUBLE_EQ(m.arcs.min_arc_segment_mm, 0.5);
  EXPECT_DOUBLE_EQ(m.firmware_retraction.retract_length_mm, 3);
}

TEST(Presets, Ender3ReproducesMarlinsExampleConfig) {
  const Machine m = preset("ender3");
  EXPECT_EQ(m.firmware, Firmware::marlin);
  EXPECT_EQ(m.junction, JunctionPolicy::junction_deviation);
  EXPECT_DOUBLE_EQ(m.junction_deviation_mm, 0.08);
  // DEFAULT_AXIS_STEPS_PER_UNIT { 80, 80, 400, 93 }
  EXPECT_NEAR(m.steppers.at("x").steps_per_mm(), 80.0, 1e-9);
  EXPECT_NEAR(m.steppers.at("z").steps_per_mm(), 400.0, 1e-9);
  EXPECT_NEAR(m.steppers.at("e").steps_per_mm(), 93.0, 1e-9);
  EXPECT_EQ(m.max_feedrate_mm_s, (std::array<double, 4>{500, 500, 5, 25}));
  EXPECT_EQ(m.max_axis_accel_mm_s2, (std::array<double, 4>{500, 500, 100, 5000}));
  EXPECT_DOUBLE_EQ(m.print_accel_mm_s2, 500);
  EXPECT_EQ(m.arcs.min_circle_segments, 72);
  EXPECT_DOUBLE_EQ(m.arcs.min_arc_segment_mm, 0.1);
  EXPECT_DOUBLE_EQ(m.arcs.max_arc_segment_mm, 1.0);
}

TEST(Presets, LoadMachineFindsPresetsByNameAndFilesByPath) {
  EXPECT_EQ(load_machine("voron24"), preset("voron24"));
  EXPECT_EQ(load_machine(std::string(AMCTL_SOURCE_DIR) + "/configs/ender3.toml"),
            preset("ender3"));
}

TEST(Presets, UnknownPresetSuggestsTheClosestName) {
  const std::string msg = error_of([] { (void)load_machine("vorn24"); });
  EXPECT_NE(msg.find("unknown machine 'vorn24'; did you mean 'voron24'?"), std::string::npos)
      << msg;
  EXPECT_NE(error_of([] { (void)load_machine("no/such/file.toml"); }).find("does not exist"),
            std::string::npos);
}

TEST(Effective, KlipperDefaultsDeriveFromTheToolheadAndNozzle) {
  Machine m;  // 300 mm/s, 3000 mm/s^2, 0.4 mm nozzle, 1.75 mm filament
  EXPECT_DOUBLE_EQ(effective_max_z_velocity_mm_s(m), 300);
  EXPECT_DOUBLE_EQ(effective_max_z_accel_mm_s2(m), 3000);
  // Hand calculation: ratio = 4 * 0.4^2 / (pi * 0.875^2) = 0.64 / 2.40528187... = 0.266081...
  const double ratio = 0.64 / 2.4052818754046;
  EXPECT_NEAR(effective_max_extrude_only_velocity_mm_s(m), 300 * ratio, 1e-9);
  EXPECT_NEAR(effective_max_extrude_only_accel_mm_s2(m), 3000 * ratio, 1e-8);
  EXPECT_DOUBLE_EQ(effective_max_extrude_cross_section_mm2(m), 0.64);
  // scv 5, accel 3000: 25 * 0.41421356237 / 3000 = 0.0034517796864 mm.
  EXPECT_NEAR(klipper_junction_deviation_mm(5, 3000), 0.0034517796864, 1e-12);
}

}  // namespace
}  // namespace amctl::machine
