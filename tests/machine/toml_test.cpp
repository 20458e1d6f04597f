// The TOML machine description: schema errors with file:line:col, did-you-mean, defaults,
// legacy mappings and exact round trips.
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <gtest/gtest.h>

#include "amctl/machine/json.hpp"
#include "amctl/machine/loader.hpp"
#include "test_util.hpp"

namespace amctl::machine {
namespace {

using test::error_of;

Machine parse(const std::string& text) { return parse_machine_toml(text, "m.toml"); }
std::string parse_error(const std::string& text) {
  return error_of([&] { (void)parse(text); });
}

TEST(MachineToml, MissingKeysKeepTheDocumentedDefaults) {
  Machine expected;
  expected.name = "m";  // a file without a name is called after itself
  EXPECT_EQ(parse(""), expected);
  EXPECT_EQ(parse_machine_toml("[printer]\nname = \"x\"\n", "dir/my-printer.toml").name, "x");
  EXPECT_EQ(parse_machine_toml("", "dir/my-printer.toml").name, "my-printer");
  const Machine m = parse("[printer]\nmax_accel = 5000\n");
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 5000);
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 300);
}

TEST(MachineToml, UnknownKeyNamesFileLineColumnAndSuggestsTheClosestKey) {
  EXPECT_EQ(parse_error("[printer]\nmax_velocity = 300\n  max_acel = 5000\n"),
            "m.toml:3:3: unknown key 'max_acel' in [printer], expected a key that `amctl machine keys` lists; did you mean "
            "'max_accel'?");
}

TEST(MachineToml, KeyInTheWrongSectionPointsToItsSection) {
  EXPECT_EQ(parse_error("[printer]\nprint_accel = 500\n"),
            "m.toml:2:1: unknown key 'print_accel' in [printer], expected a key that `amctl machine keys` lists; "
            "'print_accel' belongs in [marlin]");
}

TEST(MachineToml, UnknownSectionSuggestsTheClosestSection) {
  EXPECT_EQ(parse_error("[printr]\nmax_accel = 1\n"),
            "m.toml:1:2: unknown section [printr], expected a section that `amctl machine keys` "
            "lists; did you mean [printer]?");
  EXPECT_NE(parse_error("[stepper_q]\nmicrosteps = 16\n").find("unknown section [stepper_q]"),
            std::string::npos);
}

TEST(MachineToml, WrongTypeNamesTheKeyUnitAndWhatWasFound) {
  EXPECT_EQ(parse_error("[printer]\nmax_accel = \"fast\"\n"),
            "m.toml:2:13: printer.max_accel: expected a number in mm/s^2, got a string");
  EXPECT_EQ(parse_error("[stepper_x]\nmicrosteps = 16.5\n"),
            "m.toml:2:14: stepper_x.microsteps: expected an integer, got a floating-point number");
  EXPECT_NE(parse_error("[marlin]\njerk = [10, 10, 0.4]\n").find("expected [x, y, z, e]"),
            std::string::npos);
}

TEST(MachineToml, NegativeNanAndInfiniteLimitsAreRejectedWithTheirLocation) {
  EXPECT_EQ(parse_error("[printer]\nmax_velocity = -300\n"),
            "m.toml:2:16: printer.max_velocity must be a finite number > 0 mm/s, got -300");
  EXPECT_EQ(parse_error("[printer]\nmax_accel = nan\n"),
            "m.toml:2:13: printer.max_accel must be a finite number > 0 mm/s^2, got nan");
  EXPECT_EQ(parse_error("[extruder]\nnozzle_diameter = inf\n"),
            "m.toml:2:19: extruder.nozzle_diameter must be a finite number > 0 mm, got inf");
  // An element of an array is located by itself.
  EXPECT_EQ(parse_error("[marlin]\nmax_feedrate = [500, 500, -12, 120]\n"),
            "m.toml:2:27: marlin.max_feedrate.z must be a finite number > 0 mm/s, got -12");
}

TEST(MachineToml, MinimumCruiseRatioMustBeBelowOne) {
  EXPECT_NE(parse_error("[printer]\nminimum_cruise_ratio = 1.0\n")
                .find("printer.minimum_cruise_ratio must be a finite number in [0, 1)"),
            std::string::npos);
  EXPECT_DOUBLE_EQ(parse("[printer]\nminimum_cruise_ratio = 0\n").minimum_cruise_ratio, 0.0);
}

TEST(MachineToml, MalformedTomlReportsTheParserPosition) {
  const std::string msg = parse_error("[printer]\nmax_accel = = 3\n");
  EXPECT_EQ(msg.rfind("m.toml:2:", 0), 0u) << msg;
  EXPECT_NE(msg.find("invalid TOML"), std::string::npos);
}

TEST(MachineToml, TopLevelKeysAreRejected) {
  EXPECT_NE(parse_error("max_accel = 3000\n").find("m.toml:1:1: unexpected top-level key"),
            std::string::npos);
}

TEST(MachineToml, UnsupportedKinematicsSaysSo) {
  EXPECT_EQ(parse_error("[printer]\nkinematics = \"polr\"\n"),
            "m.toml:2:14: printer.kinematics: found 'polr', expected one of cartesian, corexy, "
            "corexz, hybrid_corexy, hybrid_corexz, delta, none, winch, deltesian, "
            "generic_cartesian, polar, rotary_delta, limited_cartesian, limited_corexy, "
            "limited_corexz; did you mean 'polar'?");
  EXPECT_EQ(parse_error("[printer]\nfirmware = \"marlinn\"\n"),
            "m.toml:2:12: printer.firmware: found 'marlinn', expected one of klipper, marlin, "
            "reprap; did you mean 'marlin'?");
}

TEST(MachineToml, JunctionPolicyDefaultsFromTheFirmware) {
  EXPECT_EQ(parse("[printer]\nfirmware = \"klipper\"\n").junction,
            JunctionPolicy::square_corner_velocity);
  EXPECT_EQ(parse("[printer]\nfirmware = \"marlin\"\n").junction,
            JunctionPolicy::junction_deviation);
  EXPECT_EQ(parse("[printer]\nfirmware = \"reprap\"\n").junction, JunctionPolicy::classic_jerk);
  EXPECT_EQ(parse("[printer]\nfirmware = \"marlin\"\njunction = \"classic_jerk\"\n").junction,
            JunctionPolicy::classic_jerk);
}

TEST(MachineToml, LegacyMaxAccelToDecelMapsToMinimumCruiseRatio) {
  // 1 - min(1, 1000 / 4000) = 0.75, independent of key order.
  EXPECT_DOUBLE_EQ(parse("[printer]\nmax_accel_to_decel = 1000\nmax_accel = 4000\n")
                       .minimum_cruise_ratio,
                   0.75);
  // Above max_accel it clamps to 0.
  EXPECT_DOUBLE_EQ(parse("[printer]\nmax_accel = 4000\nmax_accel_to_decel = 9000\n")
                       .minimum_cruise_ratio,
                   0.0);
  // An explicit minimum_cruise_ratio wins, as in Klipper.
  EXPECT_DOUBLE_EQ(parse("[printer]\nmax_accel = 4000\nmax_accel_to_decel = 1000\n"
                         "minimum_cruise_ratio = 0.1\n")
                       .minimum_cruise_ratio,
                   0.1);
}

TEST(MachineToml, GearRatioIsFoldedIntoThePerMotorRotationDistance) {
  const Machine m = parse(
      "[stepper_z]\nrotation_distance = 40\ngear_ratio = \"80:16\"\nmicrosteps = 32\n"
      "[stepper_e]\nrotation_distance = 40\ngear_ratio = \"57:11, 2:1\"\n");
  EXPECT_DOUBLE_EQ(m.steppers.at("z").rotation_distance_mm, 8.0);
  // 40 / (57/11 * 2) = 440 / 114 = 3.859649122807...
  EXPECT_NEAR(m.steppers.at("e").rotation_distance_mm, 440.0 / 114.0, 1e-12);
  EXPECT_NE(parse_error("[stepper_z]\ngear_ratio = \"80-16\"\n").find("m.toml:2:14"),
            std::string::npos);
}

TEST(MachineToml, FilamentThinnerThanTheNozzleIsRejected) {
  EXPECT_EQ(parse_error("[extruder]\nnozzle_diameter = 0.4\nfilament_diameter = 0.3\n"),
            "m.toml: extruder.filament_diameter (0.3 mm) must be >= extruder.nozzle_diameter "
            "(0.4 mm)");
}

TEST(MachineToml, ToTomlRoundTripsEveryFieldExactly) {
  Machine m;
  m.name = "quote \" and \\ backslash\tand tab";
  m.firmware = Firmware::reprap;
  m.kinematics = kinematics::CoreXY{};
  m.junction = JunctionPolicy::junction_deviation;
  m.profile = VelocityProfile::scurve7;
  m.max_velocity_mm_s = 0.1 + 0.2;  // not representable in short decimal
  m.max_accel_mm_s2 = 12345.678901234567;
  m.square_corner_velocity_mm_s = 0;
  m.minimum_cruise_ratio = 1.0 / 3.0;
  m.max_z_velocity_mm_s = 1.0000001e-3;  // just above the speed range's floor, 0.001 mm/s
  m.max_jerk_mm_s3 = 9.87654321e14;       // just below the jerk range's ceiling, 1e15 mm/s^3
  m.max_feedrate_mm_s = {1.5, 2.25, 3.125, 4.0625};
  m.jerk_mm_s = {0, 0, 0, 0};
  m.block_buffer_size = 64;
  m.extruder.max_extrude_only_velocity_mm_s = 77.7;
  m.extruder.max_extrude_cross_section_mm2 = 0.8;
  m.arcs.min_circle_segments = 33;
  m.firmware_retraction.lift_z_mm = 0.2;
  m.steppers["x"] = Stepper{40.0 / 3.0, 256, 400};
  m.steppers["z2"] = Stepper{8, 16, 200};
  m.steppers["y"] = Stepper{40, 16, 200};
  std::get<kinematics::CoreXY>(m.kinematics).rails["y"] = {-5.0, 230.0, -5.0};
  m.soft_min_position_mm = {0.0, -2.0, std::nullopt};
  m.soft_max_position_mm = {220.0, std::nullopt, 250.0};
  const std::string text = to_toml(m);
  EXPECT_EQ(parse_machine_toml(text, "rt.toml"), m) << text;
}

TEST(MachineToml, SchemaListsEveryKeyWithItsUnit) {
  const auto keys = schema();
  auto find = [&](std::string_view s, std::string_view k) {
    for (const auto& key : keys) {
      if (key.section == s && key.key == k) return key;
    }
    return KeyInfo{};
  };
  EXPECT_EQ(find("printer", "max_accel").unit, "mm/s^2");
  EXPECT_EQ(find("marlin", "jerk").type, "[x, y, z, e]");
  EXPECT_EQ(find("stepper_*", "rotation_distance").unit, "mm");
  EXPECT_EQ(find("marlin", "min_segment_time").unit, "s");
  EXPECT_EQ(find("marlin", "max_position_x").unit, "mm");
  EXPECT_EQ(find("stepper_*", "position_max").unit, "mm");
  // Range keys are written only when set: a machine without them prints as before.
  Machine plain;
  plain.steppers["x"] = Stepper{};
  EXPECT_EQ(to_toml(plain).find("position"), std::string::npos);
  EXPECT_EQ(to_json(plain).dump().find("position"), std::string::npos);
  plain.soft_max_position_mm[0] = 220.0;
  std::get<kinematics::Cartesian>(plain.kinematics).rails["x"].position_max_mm = 230.0;
  EXPECT_NE(to_toml(plain).find("max_position_x = 220"), std::string::npos);
  EXPECT_NE(to_toml(plain).find("position_max = 230"), std::string::npos);
  EXPECT_EQ(to_toml(plain).find("min_position"), std::string::npos);
}

}  // namespace
}  // namespace amctl::machine

namespace amctl::machine {
namespace {

TEST(MachineDocs, DocsMachineMdDocumentsEveryKey) {
  std::ifstream in(std::string(AMCTL_SOURCE_DIR) + "/docs/machine.md");
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  ASSERT_FALSE(doc.empty());
  const auto keys = schema();
  ASSERT_GT(keys.size(), 40u);  // the loop below checks nothing if the schema came back empty
  for (const auto& k : keys) {
    EXPECT_NE(doc.find("| `" + k.key + "` |"), std::string::npos)
        << k.section << "." << k.key << " has no row in docs/machine.md";
  }
}

}  // namespace
}  // namespace amctl::machine
