// Klipper printer.cfg: the configparser dialect Klipper reads, Klipper's defaults and checks,
// macros, includes and the SAVE_CONFIG block. Expected values come from Klipper's
// Config_Reference.md and klippy/toolhead.py, not from our parser.
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include <algorithm>

#include <fmt/format.h>

#include "amctl/machine/effective.hpp"
#include "amctl/machine/loader.hpp"
#include "test_util.hpp"

namespace amctl::machine {
namespace {

using test::error_of;
using test::TempDir;

Machine cfg(const std::string& text) { return parse_klipper_cfg(text, "printer.cfg"); }
std::string cfg_error(const std::string& text) {
  return error_of([&] { (void)cfg(text); });
}

const std::string kMinimal =
    "[printer]\nkinematics: cartesian\nmax_velocity: 250\nmax_accel: 4000\n";

TEST(KlipperCfg, TrinamicRunCurrentReachesItsStepper) {
  const std::string steppers =
      "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\n"
      "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\n"
      "[extruder]\nnozzle_diameter: 0.4\nfilament_diameter: 1.75\nrotation_distance: 22\n"
      "microsteps: 16\n";
  const Machine m = cfg(kMinimal + steppers +
                        "[tmc2209 stepper_x]\nrun_current: 0.8\nhold_current: 0.5\n"
                        "[tmc5160  stepper_y]\nrun_current: 1.1\nsense_resistor: 0.075\n"
                        "[tmc2208 extruder]\nrun_current: 0.65\n"
                        "[tmc2130 stepper_z]\nrun_current: 0.9\n");  // no [stepper_z]: ignored
  EXPECT_DOUBLE_EQ(m.steppers.at("x").run_current_a.value(), 0.8);
  EXPECT_DOUBLE_EQ(m.steppers.at("y").run_current_a.value(), 1.1);
  EXPECT_DOUBLE_EQ(m.steppers.at("e").run_current_a.value(), 0.65);
  EXPECT_EQ(m.steppers.count("z"), 0u);
  const std::string msg = cfg_error(kMinimal + steppers + "[tmc2209 stepper_x]\nrun_current: -1\n");
  EXPECT_NE(msg.find("run_current"), std::string::npos) << msg;
  EXPECT_NE(msg.find("printer.cfg:"), std::string::npos) << msg;
}

TEST(KlipperCfg, MinimalPrinterGetsKlippersDefaults) {
  const Machine m = cfg(kMinimal);
  EXPECT_EQ(m.firmware, Firmware::klipper);
  EXPECT_EQ(m.junction, JunctionPolicy::square_corner_velocity);
  EXPECT_TRUE(kinematics::is<kinematics::Cartesian>(m.kinematics));
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 250);
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 4000);
  EXPECT_DOUBLE_EQ(m.square_corner_velocity_mm_s, 5.0);  // Config_Reference: default 5
  EXPECT_DOUBLE_EQ(m.minimum_cruise_ratio, 0.5);         // default 0.5
  EXPECT_DOUBLE_EQ(effective_max_z_velocity_mm_s(m), 250);  // default max_velocity
  EXPECT_DOUBLE_EQ(effective_max_z_accel_mm_s2(m), 4000);   // default max_accel
  EXPECT_EQ(m.name, "printer");
}

TEST(KlipperCfg, ColonsEqualsAndBothCommentStylesAreAccepted) {
  const Machine m = cfg(
      "# a comment\n; another\n[printer]\nkinematics = corexy   ; inline\n"
      "max_velocity:300#no space needed before hash\nmax_accel :  7000  # trailing\n"
      "square_corner_velocity:8\nMAX_Z_VELOCITY: 20\n");
  EXPECT_TRUE(kinematics::is<kinematics::CoreXY>(m.kinematics));
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 300);
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 7000);
  EXPECT_DOUBLE_EQ(m.square_corner_velocity_mm_s, 8);
  EXPECT_DOUBLE_EQ(m.max_z_velocity_mm_s, 20);  // option names are case-insensitive
}

TEST(KlipperCfg, CrlfLineEndingsAreAccepted) {
  const Machine m = cfg("[printer]\r\nkinematics: corexy\r\nmax_velocity: 300\r\nmax_accel: 5000\r\n");
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 5000);
}

TEST(KlipperCfg, MaxAccelToDecelMapsToMinimumCruiseRatio) {
  // toolhead.py (0105aa33): minimum_cruise_ratio = 1 - min(1, max_accel_to_decel / max_accel)
  EXPECT_DOUBLE_EQ(cfg(kMinimal + "max_accel_to_decel: 2000\n").minimum_cruise_ratio, 0.5);
  EXPECT_DOUBLE_EQ(cfg(kMinimal + "max_accel_to_decel: 1000\n").minimum_cruise_ratio, 0.75);
  EXPECT_DOUBLE_EQ(cfg(kMinimal + "max_accel_to_decel: 4000\n").minimum_cruise_ratio, 0.0);
  EXPECT_DOUBLE_EQ(cfg(kMinimal + "max_accel_to_decel: 9000\n").minimum_cruise_ratio, 0.0);
  EXPECT_DOUBLE_EQ(
      cfg(kMinimal + "max_accel_to_decel: 1000\nminimum_cruise_ratio: 0.2\n").minimum_cruise_ratio,
      0.2);
}

TEST(KlipperCfg, OutOfRangeValuesAreErrorsAtTheValue) {
  EXPECT_EQ(cfg_error(kMinimal + "minimum_cruise_ratio: 1.0\n"),
            "printer.cfg:5:23: [printer] minimum_cruise_ratio: must be below 1, got 1");
  EXPECT_EQ(cfg_error(kMinimal + "max_z_velocity: 400\n"),
            "printer.cfg:5:17: [printer] max_z_velocity: must be at most 250, got 400");
  EXPECT_EQ(cfg_error("[printer]\nkinematics: corexy\nmax_velocity: 300\nmax_accel: fast\n"),
            "printer.cfg:4:12: [printer] max_accel: expected a number, got 'fast'");
  EXPECT_EQ(cfg_error("[printer]\nkinematics: corexy\nmax_velocity: nan\nmax_accel: 3\n"),
            "printer.cfg:3:15: [printer] max_velocity: must be a finite number, got 'nan'");
  EXPECT_EQ(cfg_error("[printer]\nkinematics: corexy\nmax_velocity: -3\nmax_accel: 3\n"),
            "printer.cfg:3:15: [printer] max_velocity: must be above 0, got -3");
}

TEST(KlipperCfg, RequiredOptionsAreNamed) {
  EXPECT_EQ(cfg_error("[mcu]\nserial: /dev/x\n\n[printer]\nkinematics: corexy\nmax_velocity: 300\n"),
            "printer.cfg:4:1: option 'max_accel' in section [printer] must be specified");
  EXPECT_EQ(cfg_error("[mcu]\nserial: /dev/x\n"),
            "printer.cfg: found no [printer] section, expected a Klipper printer.cfg (which has one)");
}

TEST(KlipperCfg, MisspeltPrinterOptionIsAnErrorWithASuggestion) {
  EXPECT_EQ(cfg_error(kMinimal + "square_corner_velocty: 8\n"),
            "printer.cfg:5:24: option 'square_corner_velocty' is not valid in section [printer]; "
            "did you mean 'square_corner_velocity'?");
  // Options that are not near any known one (e.g. from Klipper forks) are ignored.
  EXPECT_DOUBLE_EQ(cfg(kMinimal + "some_fork_feature: 1\n").max_accel_mm_s2, 4000);
}

TEST(KlipperCfg, UnknownKinematicsGetADidYouMean) {
  // Every Klipper kinematics is read now; a polar printer without its steppers says which.
  EXPECT_EQ(cfg_error("[printer]\nkinematics: polar\nmax_velocity: 300\nmax_accel: 3000\n"),
            "printer.cfg:1:1: a polar printer needs [stepper_bed] (stepper_bed, stepper_arm, "
            "stepper_z)");
  EXPECT_EQ(cfg_error("[printer]\nkinematics: rotary_deta\nmax_velocity: 300\nmax_accel: 3000\n"),
            "printer.cfg:2:13: [printer] kinematics: found 'rotary_deta', expected a Klipper "
            "kinematics; did you mean 'rotary_delta'?");
  EXPECT_EQ(cfg_error("[printer]\nkinematics: corexyy\nmax_velocity: 300\nmax_accel: 3000\n"),
            "printer.cfg:2:13: [printer] kinematics: found 'corexyy', expected a Klipper "
            "kinematics; did you mean 'corexy'?");
}

TEST(KlipperCfg, ExtruderAndArcAndRetractionSectionsAreRead) {
  const Machine m = cfg(kMinimal +
                        "[extruder]\nstep_pin: PE2\nrotation_distance: 22.6789511\n"
                        "gear_ratio: 50:17\nmicrosteps: 16\nnozzle_diameter: 0.6\n"
                        "filament_diameter: 2.85\nmax_extrude_only_velocity: 120\n"
                        "max_extrude_only_accel: 1500\nmax_extrude_only_distance: 150\n"
                        "instantaneous_corner_velocity: 2.5\nmax_extrude_cross_section: 3\n"
                        "heater_pin: PA2\nsensor_type: Generic 3950\ncontrol: pid\n"
                        "[gcode_arcs]\nresolution: 0.25\n"
                        "[firmware_retraction]\nretract_length: 0.8\nretract_speed: 35\n"
                        "unretract_extra_length: 0.1\nunretract_speed: 25\n");
  EXPECT_DOUBLE_EQ(m.extruder.nozzle_diameter_mm, 0.6);
  EXPECT_DOUBLE_EQ(m.extruder.filament_diameter_mm, 2.85);
  EXPECT_EQ(m.extruder.max_extrude_only_velocity_mm_s, 120.0);
  EXPECT_EQ(m.extruder.max_extrude_only_accel_mm_s2, 1500.0);
  EXPECT_DOUBLE_EQ(m.extruder.max_extrude_only_distance_mm, 150);
  EXPECT_DOUBLE_EQ(m.extruder.instantaneous_corner_velocity_mm_s, 2.5);
  EXPECT_EQ(m.extruder.max_extrude_cross_section_mm2, 3.0);
  // 22.6789511 * 17 / 50 = 7.710843374 mm per motor turn (hand calculation).
  EXPECT_NEAR(m.steppers.at("e").rotation_distance_mm, 7.710843374, 1e-12);
  EXPECT_EQ(m.steppers.at("e").microsteps, 16);
  EXPECT_DOUBLE_EQ(m.arcs.mm_per_arc_segment, 0.25);
  EXPECT_DOUBLE_EQ(m.firmware_retraction.retract_length_mm, 0.8);
  EXPECT_DOUBLE_EQ(m.firmware_retraction.retract_speed_mm_s, 35);
  EXPECT_DOUBLE_EQ(m.firmware_retraction.unretract_extra_length_mm, 0.1);
  EXPECT_DOUBLE_EQ(m.firmware_retraction.unretract_speed_mm_s, 25);
}

TEST(KlipperCfg, InputShaperSectionIsReadWithKlippersDefaults) {
  // input_shaper.py (84104bbb): shaper_type (mzv) is the default of shaper_type_x/_y, as
  // written (no longer lower-cased); damping_ratio_x/_y 0.1; shaper_freq_x/_y 0 = off.
  EXPECT_EQ(cfg(kMinimal).input_shaper, InputShaper{});
  EXPECT_FALSE(cfg(kMinimal).input_shaper.active());
  const Machine m = cfg(kMinimal + "[input_shaper]\nshaper_type: ei\nshaper_type_y: 2hump_ei\n"
                                   "shaper_freq_x: 52.4\nshaper_freq_y: 41\ndamping_ratio_y: 0.07\n");
  EXPECT_EQ(m.input_shaper.shaper_type_x, "ei");
  EXPECT_EQ(m.input_shaper.shaper_type_y, "2hump_ei");
  EXPECT_DOUBLE_EQ(m.input_shaper.shaper_freq_x_hz, 52.4);
  EXPECT_DOUBLE_EQ(m.input_shaper.shaper_freq_y_hz, 41.0);
  EXPECT_DOUBLE_EQ(m.input_shaper.damping_ratio_x, 0.1);
  EXPECT_DOUBLE_EQ(m.input_shaper.damping_ratio_y, 0.07);
  EXPECT_TRUE(m.input_shaper.active());
  const Machine only_x = cfg(kMinimal + "[input_shaper]\nshaper_freq_x: 40\n");
  EXPECT_EQ(only_x.input_shaper.shaper_type_x, "mzv");
  EXPECT_EQ(only_x.input_shaper.shaper_freq_y_hz, 0.0);
  EXPECT_NE(cfg_error(kMinimal + "[input_shaper]\nshaper_freq_x: -1\n").find("shaper_freq_x"),
            std::string::npos);
  EXPECT_NE(cfg_error(kMinimal + "[input_shaper]\ndamping_ratio_x: 1.5\n").find("damping_ratio_x"),
            std::string::npos);
  // The TOML form carries it, and only when set.
  const std::string toml = to_toml(m);
  EXPECT_NE(toml.find("[input_shaper]"), std::string::npos);
  EXPECT_EQ(to_toml(cfg(kMinimal)).find("[input_shaper]"), std::string::npos);
  EXPECT_EQ(parse_machine_toml(toml, "m.toml").input_shaper, m.input_shaper);
}

TEST(KlipperCfg, UnknownShaperTypesAreRefusedAsKlipperDoes) {
  // Found by fuzz_klipper_cfg: any text was taken as a shaper type, and bytes that are not
  // UTF-8 made `machine show` write a TOML file amctl could not read back. Klipper refuses
  // every type outside shaper_defs.INPUT_SHAPERS ("Unsupported shaper type").
  const std::string base = kMinimal + "[input_shaper]\n";
  const int line = 1 + static_cast<int>(std::count(base.begin(), base.end(), '\n'));
  const std::string msg = cfg_error(base + "shaper_type_x: m\x86\x86\n");
  EXPECT_NE(msg.find(fmt::format("printer.cfg:{}:16: [input_shaper] shaper_type_x: found '", line)),
            std::string::npos) << msg;
  EXPECT_NE(msg.find("expected one of zv, mzv, zvd, ei, 2hump_ei, 3hump_ei"), std::string::npos)
      << msg;
  EXPECT_NE(cfg_error(base + "shaper_type: zvdd\n").find("shaper_type: found 'zvdd'"),
            std::string::npos);
  EXPECT_NE(cfg_error(base + "shaper_type_y: smooth\n").find("shaper_type_y"), std::string::npos);
}

TEST(KlipperCfg, ShaperTypesWithParametersAndCaseAsKlipperReadsThem) {
  // shaper_defs.get_shaper_cfg: `name(args)` with a known name is accepted (Klipper's own
  // test/klippy/input_shaper.cfg has `ei(v_tol=0.02)`); the name is compared as written.
  const std::string base = kMinimal + "[input_shaper]\n";
  const Machine m = cfg(base + "shaper_type_x: mzv(5, 0.6)\nshaper_type_y: ei(v_tol=0.02)\n");
  EXPECT_EQ(m.input_shaper.shaper_type_x, "mzv(5, 0.6)");
  EXPECT_EQ(m.input_shaper.shaper_type_y, "ei(v_tol=0.02)");
  const std::string msg = cfg_error(base + "shaper_type: EI\n");
  EXPECT_NE(msg.find("found 'EI'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("as written: 'ei'"), std::string::npos) << msg;
  EXPECT_NE(cfg_error(base + "shaper_type: smooth(1)\n").find("found 'smooth(1)'"),
            std::string::npos);
}

TEST(KlipperCfg, ExtruderOmissionsGetKlippersDerivedDefaults) {
  const Machine m = cfg(kMinimal + "[extruder]\nnozzle_diameter: 0.4\nfilament_diameter: 1.75\n");
  EXPECT_FALSE(m.extruder.max_extrude_only_velocity_mm_s.has_value());
  EXPECT_DOUBLE_EQ(m.extruder.max_extrude_only_distance_mm, 50);
  EXPECT_DOUBLE_EQ(m.extruder.instantaneous_corner_velocity_mm_s, 1.0);
  // 250 mm/s * 4 * 0.4^2 / (pi * 0.875^2) = 250 * 0.64 / 2.405281875 = 66.5202... mm/s
  EXPECT_NEAR(effective_max_extrude_only_velocity_mm_s(m), 66.52027009228605, 1e-9);
  EXPECT_EQ(m.steppers.count("e"), 0u);  // no step_pin/dir_pin/rotation_distance
  EXPECT_EQ(cfg_error(kMinimal + "[extruder]\nnozzle_diameter: 0.4\nfilament_diameter: 0.3\n"),
            "printer.cfg:7:20: [extruder] filament_diameter: must be at least 0.4, got 0.3");
}

TEST(KlipperCfg, StepperSectionsGiveStepsPerMm) {
  const Machine m = cfg(kMinimal +
                        "[stepper_x]\nstep_pin: PF13\nrotation_distance: 40\nmicrosteps: 16\n"
                        "full_steps_per_rotation: 400\n"
                        "[tmc2209 stepper_x]\nrun_current: 0.8\n"
                        "[stepper_z1]\nrotation_distance: 40\ngear_ratio: 80:16\nmicrosteps: 32\n");
  EXPECT_DOUBLE_EQ(m.steppers.at("x").steps_per_mm(), 400.0 * 16 / 40);  // 160
  EXPECT_DOUBLE_EQ(m.steppers.at("z1").rotation_distance_mm, 8.0);
  EXPECT_EQ(m.steppers.size(), 2u);
  EXPECT_EQ(cfg_error(kMinimal + "[stepper_y]\nrotation_distance: 40\n"),
            "printer.cfg:5:1: option 'microsteps' in section [stepper_y] must be specified");
  EXPECT_EQ(cfg_error(kMinimal +
                      "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\n"
                      "full_steps_per_rotation: 202\n"),
            "printer.cfg:8:26: [stepper_y] full_steps_per_rotation: must be a multiple of 4, "
            "got 202");
}

TEST(KlipperCfg, RailRangesAreRead) {
  const Machine m = cfg(kMinimal +
                        "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\n"
                        "position_endstop: 0\nposition_max: 235\n"
                        "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\n"
                        "position_min: -5\nposition_endstop: -5\nposition_max: 230\n"
                        "[stepper_e]\nrotation_distance: 7\nmicrosteps: 16\n");
  const auto& rails = std::get<kinematics::Cartesian>(m.kinematics).rails;
  EXPECT_EQ(rails.at("x").position_min_mm, 0.0);  // Klipper's default
  EXPECT_EQ(rails.at("x").position_max_mm, 235.0);
  EXPECT_EQ(rails.at("x").position_endstop_mm, 0.0);
  EXPECT_EQ(rails.at("y").position_min_mm, -5.0);
  EXPECT_EQ(rails.at("y").position_max_mm, 230.0);
  EXPECT_EQ(rails.count("e"), 0u);  // [stepper_e] is no rail (nor a Klipper section)
  EXPECT_EQ(cfg_error(kMinimal + "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\n"
                                 "position_min: 10\nposition_max: 5\n"),
            "printer.cfg:9:15: [stepper_x] position_max: must be above 10, got 5");
}

TEST(KlipperCfg, MacrosWithMultiLineGcodeAreSkippedWithoutConfusingTheParser) {
  const Machine m = cfg(
      "[gcode_macro PRINT_START]\n"
      "description: start\n"
      "gcode:\n"
      "    {% set bed = params.BED|default(60)|float %}\n"
      "    M190 S{bed}\n"
      "\n"
      "    [not_a_section]\n"
      "    max_accel: 1 ; looks like an option but is macro text\n"
      "  G1 X10: F3000\n"
      "[printer]\n"
      "kinematics: corexy\n"
      "max_velocity: 400\n"
      "max_accel: 9000\n"
      "[gcode_macro PARK]\n"
      "gcode:\n"
      "  G1 X0 Y0\n");
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 9000);
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 400);
}

TEST(KlipperCfg, RepeatedSectionsMergeAndTheLastValueWins) {
  const Machine m = cfg(kMinimal + "[mcu]\nserial: x\n[printer]\nmax_accel: 6000\n");
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 6000);
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 250);
}

TEST(KlipperCfg, TextBeforeAnySectionIsAnError) {
  EXPECT_EQ(cfg_error("max_accel: 3\n[printer]\n"),
            "printer.cfg:1:1: expected a [section] header before 'max_accel: 3'");
  EXPECT_EQ(cfg_error("[printer]\njust words\n"),
            "printer.cfg:2:1: expected 'option: value' in [printer], got 'just words'");
}

TEST(KlipperCfg, SaveConfigBlockFillsOnlyWhatTheRegularConfigLeavesOpen) {
  const Machine m = cfg(kMinimal +
                        "\n#*# <---------------------- SAVE_CONFIG ---------------------->\n"
                        "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n"
                        "#*#\n"
                        "#*# [printer]\n"
                        "#*# max_accel = 9999\n"
                        "#*# square_corner_velocity = 7.5\n"
                        "#*#\n"
                        "#*# [bed_mesh default]\n"
                        "#*# version = 1\n"
                        "#*# points =\n"
                        "#*# \t  0.012500, -0.020000\n"
                        "#*# \t  0.030000, 0.002500\n");
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 4000);  // the regular config wins
  EXPECT_DOUBLE_EQ(m.square_corner_velocity_mm_s, 7.5);
}

TEST(KlipperCfg, SaveConfigErrorsPointAtTheirLineInTheFile) {
  EXPECT_EQ(cfg_error(kMinimal +
                      "#*# <---------------------- SAVE_CONFIG ---------------------->\n"
                      "#*# [printer]\n"
                      "#*# square_corner_velocity = -1\n"),
            // Column 30: the value's column in the file, "#*# " counted.
            "printer.cfg:7:30: [printer] square_corner_velocity: must be at least 0, got -1");
}

TEST(KlipperCfg, IncludesResolveRelativeToTheFileWithGlobsAndLaterOverrides) {
  TempDir dir("include");
  dir.write("conf/limits.cfg", "[printer]\nkinematics: corexy\nmax_velocity: 350\nmax_accel: 5000\n");
  dir.write("conf/macros/a.cfg", "[gcode_macro A]\ngcode:\n  G28\n");
  dir.write("conf/macros/b.cfg", "[printer]\nmax_accel: 5500\n");  // sorted after a.cfg
  const std::string main = dir.write(
      "conf/printer.cfg",
      "[include limits.cfg]\n[include macros/*.cfg]\n[printer]\nsquare_corner_velocity: 6\n");
  const Machine m = load_machine(main);
  EXPECT_TRUE(kinematics::is<kinematics::CoreXY>(m.kinematics));
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 350);
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 5500);
  EXPECT_DOUBLE_EQ(m.square_corner_velocity_mm_s, 6);
  // A glob that matches nothing is fine; a missing file is not.
  const std::string glob_none = dir.write(
      "conf/g.cfg", "[include limits.cfg]\n[include nothing/*.cfg]\n");
  EXPECT_NO_THROW((void)load_machine(glob_none));
  const std::string missing = dir.write("conf/m.cfg", "[include limits.cfg]\n[include nope.cfg]\n");
  const std::string msg = error_of([&] { (void)load_machine(missing); });
  EXPECT_NE(msg.find("m.cfg:2:1: include file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("nope.cfg' does not exist"), std::string::npos) << msg;
}

TEST(KlipperCfg, RecursiveIncludeIsAnError) {
  TempDir dir("recursive");
  dir.write("a.cfg", "[include b.cfg]\n");
  dir.write("b.cfg", "[include a.cfg]\n");
  const std::string msg = error_of([&] { (void)load_machine((dir.path() / "a.cfg").string()); });
  EXPECT_NE(msg.find("recursive include"), std::string::npos) << msg;
  // Reported at the [include] line that closes the loop.
  EXPECT_NE(msg.find("b.cfg:1:1: recursive include of config file"), std::string::npos) << msg;
}

TEST(KlipperCfg, OptionsRightAfterAnIncludeNeedASectionHeader) {
  TempDir dir("after_include");
  dir.write("limits.cfg", "[mcu]\nserial: x\n");
  const std::string main = dir.write(
      "p.cfg", "[printer]\nkinematics: corexy\n[include limits.cfg]\nmax_velocity: 3\n");
  const std::string msg = error_of([&] { (void)load_machine(main); });
  EXPECT_NE(msg.find("p.cfg:4:1: expected a [section] header before 'max_velocity: 3'"),
            std::string::npos)
      << msg;
}

TEST(KlipperCfg, ExampleVoronV0ConfigLoadsWithItsIncludedMacros) {
  const Machine m = load_machine(std::string(AMCTL_SOURCE_DIR) + "/configs/klipper-voron-v0.cfg");
  EXPECT_EQ(m.name, "klipper-voron-v0");
  EXPECT_TRUE(kinematics::is<kinematics::CoreXY>(m.kinematics));
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 500);   // machine_max_feedrate_x 30000 mm/min
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 16000);   // machine_max_acceleration_x
  EXPECT_DOUBLE_EQ(m.max_z_velocity_mm_s, 50);  // machine_max_feedrate_z 3000 mm/min
  EXPECT_DOUBLE_EQ(m.max_z_accel_mm_s2, 1000);
  EXPECT_NEAR(m.steppers.at("e").rotation_distance_mm, 22.6789511 / 5.0, 1e-12);
  EXPECT_DOUBLE_EQ(m.arcs.mm_per_arc_segment, 0.1);
}

TEST(KlipperCfg, FilesWithoutAKnownExtensionAreSniffed) {
  TempDir dir("sniff");
  const std::string k = dir.write("myprinter", kMinimal);
  EXPECT_DOUBLE_EQ(load_machine(k).max_accel_mm_s2, 4000);
  const std::string t = dir.write("mymachine", "[printer]\nmax_accel = 1234\n");
  EXPECT_DOUBLE_EQ(load_machine(t).max_accel_mm_s2, 1234);
}

}  // namespace
}  // namespace amctl::machine

#include <random>

namespace amctl::machine {
namespace {

/// Byte-level mutations (flip, delete, duplicate, insert specials) of a valid input; every
/// result must either load or fail with amctl::Error - nothing else may escape. Both outcomes
/// must occur: a run in which every input is rejected (or every one loads) would only
/// exercise one path and could pass whatever the parser did with the rest.
template <class Parse>
void mutate_and_parse(const std::string& seed_text, Parse parse, unsigned seed) {
  std::mt19937 rng(seed);
  int loaded = 0, rejected = 0;
  const std::string specials = "[]:=#;\n\t \"'\\{}%*?.,-+eEn0123456789";
  for (int round = 0; round < 600; ++round) {
    std::string text = seed_text;
    const int edits = 1 + static_cast<int>(rng() % 6);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const std::size_t at = rng() % text.size();
      switch (rng() % 4) {
        case 0: text[at] = specials[rng() % specials.size()]; break;
        case 1: text.erase(at, 1 + rng() % 8); break;
        case 2: text.insert(at, text.substr(at, 1 + rng() % 16)); break;
        default: text.insert(at, 1, static_cast<char>(rng() % 256)); break;
      }
    }
    try {
      (void)parse(text);
      ++loaded;
    } catch (const amctl::Error&) {
      ++rejected;
    } catch (const std::exception& ex) {
      ADD_FAILURE() << "non-amctl exception '" << ex.what() << "' for input:\n" << text;
      return;
    }
  }
  EXPECT_GT(loaded, 0) << "no mutated input loaded";
  EXPECT_GT(rejected, 0) << "no mutated input was rejected";
}

TEST(Robustness, MutatedPrinterCfgEitherLoadsOrFailsWithAnAmctlError) {
  std::ifstream in(std::string(AMCTL_SOURCE_DIR) + "/configs/klipper-voron-v0.cfg");
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::size_t inc = text.find("[include");
  ASSERT_NE(inc, std::string::npos);
  text.erase(inc, text.find('\n', inc) - inc);  // parse the body, not a failing include
  ASSERT_NO_THROW((void)parse_klipper_cfg(text, "/nonexistent-amctl-dir/printer.cfg"));
  mutate_and_parse(text, [](const std::string& t) {
    return parse_klipper_cfg(t, "/nonexistent-amctl-dir/printer.cfg");
  }, 1234u);
}

TEST(Robustness, MutatedTomlEitherLoadsOrFailsWithAnAmctlError) {
  mutate_and_parse(std::string(preset_toml("prusa-mk3s")), [](const std::string& t) {
    return parse_machine_toml(t, "m.toml");
  }, 4321u);
}

TEST(Robustness, MutatedOverridesEitherApplyOrFailWithAnAmctlError) {
  mutate_and_parse("marlin.max_feedrate.z=12.5", [](const std::string& t) {
    Machine m;
    apply_override(m, t);
    return m;
  }, 99u);
}

}  // namespace
}  // namespace amctl::machine
