// generic_cartesian, polar and rotary_delta: their printer.cfg and TOML forms, Klipper's
// configuration checks, and the derived geometry against hand calculations (the carriage rows
// of Klipper's config/example-generic-caretesian.cfg, the polar bed's radians, the rotary
// delta's build volume and home position checked by forward kinematics).
#include <cmath>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"
#include "test_util.hpp"

namespace amctl::machine {
namespace {

using test::error_of;
using test::delta_geometry;
using test::deltesian_geometry;
using test::generic_cartesian_geometry;
using test::parse_carriages;
using test::polar_geometry;
using test::rotary_delta_geometry;
using kinematics::DeltaGeometry;
using kinematics::DeltesianGeometry;
using kinematics::GenericCartesianGeometry;
using kinematics::GenericStepper;
using kinematics::PolarGeometry;
using kinematics::RotaryDeltaGeometry;
using kinematics::trilaterate_below;

const std::string kDir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/";

Machine without_cfg_sections(Machine m) {
  m.klipper_config.clear();
  return m;
}

std::string cfg_error(const std::string& text) {
  return error_of([&] { (void)parse_klipper_cfg(text, "printer.cfg"); });
}

const std::string kGeneric =
    "[printer]\nkinematics: generic_cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
    "[carriage carriage_x]\naxis: x\nposition_endstop: 0\nposition_max: 300\n"
    "[carriage carriage_y]\naxis: y\nposition_endstop: 0\nposition_max: 200\n"
    "[carriage z]\nposition_endstop: 0\nposition_max: 100\n"
    "[stepper a]\ncarriages: carriage_x+carriage_y\nmicrosteps: 16\nrotation_distance: 40\n"
    "[stepper b]\ncarriages: carriage_x-carriage_y\nmicrosteps: 16\nrotation_distance: 40\n";

TEST(GenericCartesianCfg, CarriagesBecomeStepperRows) {
  // example-generic-caretesian.cfg: x = X + Y; u = u - y1 with u the parked dual carriage of
  // X and y1 an extra carriage of Y: -Y; y0 = y1 = Y; z0 = z1 = Z.
  const Machine m = load_machine(kDir + "generic_cartesian.cfg");
  EXPECT_TRUE(kinematics::is<kinematics::GenericCartesian>(m.kinematics));
  const auto& gc = std::get<kinematics::GenericCartesian>(m.kinematics);
  ASSERT_EQ(gc.carriages.size(), 5u);
  EXPECT_EQ(gc.carriages.at("carriage_u").type, kinematics::Carriage::Type::dual);
  EXPECT_EQ(gc.carriages.at("carriage_y1").primary_carriage, "carriage_y");
  const GenericCartesianGeometry g = generic_cartesian_geometry(m);
  ASSERT_EQ(g.steppers.size(), 6u);
  const std::map<std::string, std::array<double, 3>> want = {
      {"my_stepper_x", {1, 1, 0}},  {"my_stepper_u", {0, -1, 0}}, {"my_stepper_y0", {0, 1, 0}},
      {"my_stepper_y1", {0, 1, 0}}, {"my_stepper_z0", {0, 0, 1}}, {"my_stepper_z1", {0, 0, 1}}};
  for (const GenericStepper& s : g.steppers) EXPECT_EQ(s.coeffs, want.at(s.name)) << s.name;
  EXPECT_EQ(g.limits_mm[0], (std::array<double, 2>{0, 300}));
  EXPECT_EQ(g.limits_mm[1], (std::array<double, 2>{0, 200}));
  EXPECT_EQ(g.limits_mm[2], (std::array<double, 2>{0, 100}));
  // With the dual carriage active u moves X: u - y1 = X - Y.
  EXPECT_EQ(parse_carriages("carriage_u-carriage_y1", m, "t", true), (std::array<double, 3>{1, -1, 0}));
  EXPECT_EQ(parse_carriages("1*carriage_y+0.5*carriage_z", m, "t", false),
            (std::array<double, 3>{0, 1, 0.5}));
  // machine show round trip: [carriage.NAME] tables and carriages keys.
  EXPECT_EQ(parse_machine_toml(to_toml(m), "g.toml"), without_cfg_sections(m));
}

TEST(GenericCartesianCfg, KlippersConfigurationErrors) {
  EXPECT_NE(cfg_error(kGeneric).find("carriage z must be referenced by some stepper"),
            std::string::npos);
  const std::string with_z = kGeneric + "[stepper c]\ncarriages: z\nmicrosteps: 16\nrotation_distance: 8\n";
  EXPECT_NO_THROW((void)parse_klipper_cfg(with_z, "printer.cfg"));
  std::string twice = with_z;
  twice.replace(twice.find("carriage_x-carriage_y"), 21, "carriage_x-carriage_x");
  EXPECT_NE(cfg_error(twice).find("axis 'x' is referenced by more than one carriage in "
                                  "'carriage_x-carriage_x'"),
            std::string::npos);
  std::string unknown = with_z;
  unknown.replace(unknown.find("carriage_x-carriage_y"), 21, "carriage_x-carriage_q");
  EXPECT_NE(cfg_error(unknown).find("unknown carriage 'carriage_q'"), std::string::npos);
  std::string dependent = with_z;
  dependent.replace(dependent.find("carriage_x-carriage_y"), 21, "2*carriage_x+2*carriage_y");
  EXPECT_NE(cfg_error(dependent).find("do not move X, Y and Z independently"), std::string::npos);
  std::string no_axis = with_z;
  no_axis.replace(no_axis.find("[carriage carriage_y]\naxis: y\n"), 29, "[carriage carriage_y]\n");
  EXPECT_NE(cfg_error(no_axis).find("option 'axis' in section [carriage carriage_y] must be specified"),
            std::string::npos);
}

TEST(PolarCfg, BedTurnsInRadiansAndTheArmSetsTheReach) {
  const Machine m = load_machine(kDir + "polar.cfg");
  EXPECT_TRUE(kinematics::is<kinematics::Polar>(m.kinematics));
  // stepper_bed: 2 pi per turn of the final gear, geared 80:16.
  EXPECT_NEAR(*m.steppers.at("bed").rotation_distance_rad, 2.0 * std::numbers::pi / 5.0, 1e-15);
  EXPECT_EQ(std::get<kinematics::Polar>(m.kinematics).max_angular_velocity_rad_s, 5.0);
  const PolarGeometry g = polar_geometry(m);
  EXPECT_EQ(g.max_radius_mm, 300.0);
  EXPECT_EQ(g.z_limits_mm, (std::array<double, 2>{0.0, 200.0}));
  EXPECT_EQ(parse_machine_toml(to_toml(m), "p.toml"), without_cfg_sections(m));
  const std::string base =
      "[printer]\nkinematics: polar\nmax_velocity: 300\nmax_accel: 3000\n"
      "[stepper_arm]\nmicrosteps: 16\nrotation_distance: 40\nposition_endstop: 300\nposition_max: 300\n"
      "[stepper_z]\nmicrosteps: 16\nrotation_distance: 8\nposition_max: 200\n";
  EXPECT_EQ(cfg_error(base + "[stepper_bed]\nmicrosteps: 16\nrotation_distance: 40\n"),
            "printer.cfg:16:20: [stepper_bed] rotation_distance: not an option of a stepper that "
            "turns (its unit is the radian), expected gear_ratio instead");
  EXPECT_EQ(cfg_error(base + "[stepper_bed]\nmicrosteps: 16\ngear_ratio: 80:16\n[printer]\n"
                            "max_angular_velocty: 5\n"),
            "printer.cfg:18:22: option 'max_angular_velocty' is not valid in section [printer]; "
            "did you mean 'max_angular_velocity'?");
  EXPECT_NE(cfg_error(base + "[stepper_bed]\nmicrosteps: 16\n")
                .find("option 'gear_ratio' in section [stepper_bed] must be specified"),
            std::string::npos);
}

TEST(RotaryDeltaCfg, BuildVolumeAndHomeByForwardKinematics) {
  const Machine m = load_machine(kDir + "rotary_delta.cfg");
  EXPECT_TRUE(kinematics::is<kinematics::RotaryDelta>(m.kinematics));
  EXPECT_NEAR(*m.steppers.at("b").rotation_distance_rad,
              2.0 * std::numbers::pi / (107.0 / 16.0 * 60.0 / 16.0), 1e-15);
  const RotaryDeltaGeometry g = rotary_delta_geometry(m);
  // min(shoulder_radius + upper arm, lower arm - shoulder_radius) = min(203.9, 286.1).
  EXPECT_NEAR(std::sqrt(g.max_xy2_mm2), 203.9, 1e-12);
  EXPECT_EQ(g.max_z_mm, 252.0);
  // Klipper's start-up log for this file: "Delta max build height 252.00mm (radius tapered
  // above 211.65mm)".
  EXPECT_NEAR(g.limit_z_mm, 211.65, 0.005);
  // Equal endstops: the effector homes to the centre at the endstop height.
  EXPECT_NEAR(g.home_position_mm[0], 0.0, 1e-9);
  EXPECT_NEAR(g.home_position_mm[1], 0.0, 1e-9);
  EXPECT_NEAR(g.home_position_mm[2], 252.0, 1e-9);
  // Forward check of the arm angle anywhere in the volume: the elbow at that angle lies at
  // the lower arm's length from the effector, and outward of the other solution.
  for (const auto& p : {std::array<double, 3>{0, 0, 252}, {100, 50, 20}, {-150, 0, 0}, {0, 190, 100}}) {
    for (int i = 0; i < 3; ++i) {
      const double a = g.arm_angle_rad(i, p[0], p[1], p[2]);
      const auto e = g.elbow_mm(i, a);
      const double d = std::hypot(p[0] - e[0], p[1] - e[1], p[2] - e[2]);
      EXPECT_NEAR(d, 320.0, 1e-9) << i;
    }
  }
  // The taper: above limit_z the radius is max_z - z.
  EXPECT_NEAR(g.limit_xy2_at(g.max_z_mm - 10.0), std::min(g.max_xy2_mm2, 100.0), 1e-9);
  EXPECT_EQ(parse_machine_toml(to_toml(m), "r.toml"), without_cfg_sections(m));
  EXPECT_NE(cfg_error("[printer]\nkinematics: rotary_delta\nmax_velocity: 300\nmax_accel: 3000\n"
                      "shoulder_radius: 33.9\n")
                .find("option 'shoulder_height' in section [printer] must be specified"),
            std::string::npos);
}

TEST(GenericCartesianToml, CarriageTablesAndTheirErrors) {
  const std::string base =
      "[printer]\nkinematics = \"generic_cartesian\"\n"
      "[carriage.cx]\naxis = \"x\"\nposition_max = 300\nposition_endstop = 0\n"
      "[carriage.cy]\naxis = \"y\"\nposition_max = 200\nposition_endstop = 0\n"
      "[carriage.cz]\naxis = \"z\"\nposition_max = 100\nposition_endstop = 0\n"
      "[stepper_front]\ncarriages = \"cx+cy\"\n[stepper_b]\ncarriages = \"cx-cy\"\n"
      "[stepper_z]\ncarriages = \"cz\"\n";
  const Machine m = parse_machine_toml(base, "g.toml");
  EXPECT_EQ(generic_cartesian_geometry(m).steppers.size(), 3u);
  auto toml_error = [](const std::string& text) {
    return error_of([&] { (void)parse_machine_toml(text, "g.toml"); });
  };
  EXPECT_EQ(toml_error(base + "[carriage.cu]\ntyp = \"dual_carriage\"\n"),
            "g.toml:22:1: unknown key 'typ' in [carriage.cu], expected one of type, axis, "
            "primary_carriage, position_min, position_max, position_endstop, homing_speed, "
            "safe_distance; did you mean 'type'?");
  EXPECT_EQ(toml_error(base + "[carriage.cu]\ntype = \"idex\"\n"),
            "g.toml:22:8: carriage.cu.type: found 'idex', expected one of carriage, "
            "extra_carriage, dual_carriage");
  // A free stepper name needs its carriages key; without one it is an unknown section.
  EXPECT_NE(toml_error(base + "[stepper_left_rear]\nmicrosteps = 32\n")
                .find("unknown section [stepper_left_rear]"),
            std::string::npos);
  // --set reaches a generic stepper by its name.
  Machine o = m;
  apply_override(o, "stepper_front.microsteps=32");
  EXPECT_EQ(o.steppers.at("front").microsteps, 32);
  // Carriages and free stepper names on another kinematics are refused.
  std::string cart = base;
  cart.replace(cart.find("generic_cartesian"), 17, "cartesian");
  EXPECT_NE(toml_error(cart).find("[carriage.cx] is a generic_cartesian section, expected none "
                                  "for kinematics cartesian"),
            std::string::npos);
  EXPECT_NE(toml_error("[printer]\nkinematics = \"cartesian\"\n[stepper_front]\ncarriages = \"cx\"\n")
                .find("unknown key 'carriages' in [stepper_front], expected a stepper key"),
            std::string::npos);
}

TEST(GenericCartesianCfg, IdexPairsWithAndWithoutAPrimaryAreParked) {
  // Klipper's test/klippy/generic_cartesian_iqex.cfg pattern: two IDEX pairs on X, t0/t1 and
  // t2/t3, where t2 is a dual carriage of its own axis; only t0 moves X at start.
  const std::string text =
      "[printer]\nkinematics: generic_cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
      "[carriage carriage_t0]\naxis: x\nposition_endstop: 0\nposition_max: 300\n"
      "[dual_carriage carriage_t1]\nprimary_carriage: carriage_t0\nposition_endstop: 300\nposition_max: 300\n"
      "[dual_carriage carriage_t2]\naxis: x\nposition_endstop: 0\nposition_max: 300\n"
      "[dual_carriage carriage_t3]\nprimary_carriage: carriage_t2\naxis: x\nposition_endstop: 300\nposition_max: 300\n"
      "[carriage y]\nposition_endstop: 0\nposition_max: 200\n"
      "[carriage z]\nposition_endstop: 0\nposition_max: 100\n"
      "[stepper t0]\ncarriages: carriage_t0\nmicrosteps: 16\nrotation_distance: 40\n"
      "[stepper t1]\ncarriages: carriage_t1\nmicrosteps: 16\nrotation_distance: 40\n"
      "[stepper t2]\ncarriages: carriage_t2\nmicrosteps: 16\nrotation_distance: 40\n"
      "[stepper t3]\ncarriages: carriage_t3\nmicrosteps: 16\nrotation_distance: 40\n"
      "[stepper y]\ncarriages: y\nmicrosteps: 16\nrotation_distance: 40\n"
      "[stepper z]\ncarriages: z\nmicrosteps: 16\nrotation_distance: 8\n";
  const Machine m = parse_klipper_cfg(text, "printer.cfg");
  std::map<std::string, std::array<double, 3>> rows;
  for (const GenericStepper& s : generic_cartesian_geometry(m).steppers) rows[s.name] = s.coeffs;
  EXPECT_EQ(rows.at("t0"), (std::array<double, 3>{1, 0, 0}));
  EXPECT_EQ(rows.at("t1"), (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(rows.at("t2"), (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(rows.at("t3"), (std::array<double, 3>{0, 0, 0}));
  EXPECT_EQ(parse_machine_toml(to_toml(m), "g.toml"), without_cfg_sections(m));
  // A dual carriage's axis must match its primary's (Klipper: "Mismatching axes").
  std::string bad = text;
  bad.replace(bad.find("primary_carriage: carriage_t2\naxis: x"), 37, "primary_carriage: carriage_t2\naxis: y");
  EXPECT_NE(cfg_error(bad).find("carriage carriage_t3: axis y does not match its primary carriage "
                                "carriage_t2 (axis x)"),
            std::string::npos);
}

}  // namespace
}  // namespace amctl::machine
