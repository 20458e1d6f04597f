// The delta's printer.cfg and TOML forms and its derived geometry. Expected figures: Klipper's
// own start-up log for tests/reference/klipper/delta.cfg ("Delta max build height 297.05mm
// (radius tapered above 247.51mm)", "Delta max build radius 157.11mm (moves slowed past
// 141.17mm and 153.73mm)", Klipper 84104bbb) and hand calculations.
#include <cmath>
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

const std::string kDelta =
    "[printer]\nkinematics: delta\nmax_velocity: 300\nmax_accel: 3000\ndelta_radius: 174.75\n"
    "[stepper_a]\nstep_pin: gpio0\nmicrosteps: 16\nrotation_distance: 40\n"
    "position_endstop: 297.05\narm_length: 333.0\n"
    "[stepper_b]\nmicrosteps: 16\nrotation_distance: 40\n"
    "[stepper_c]\nmicrosteps: 16\nrotation_distance: 40\n";

std::string cfg_error(const std::string& text) {
  return error_of([&] { (void)parse_klipper_cfg(text, "printer.cfg"); });
}

// A printer.cfg machine keeps its sections as written (for the macros); TOML does not carry them.
Machine without_cfg_sections(Machine m) {
  m.klipper_config.clear();
  return m;
}

TEST(DeltaCfg, GeometryMatchesKlippersStartupLog) {
  const Machine m = load_machine(kDir + "delta.cfg");
  EXPECT_TRUE(kinematics::is<kinematics::Delta>(m.kinematics));
  const DeltaGeometry g = delta_geometry(m);
  EXPECT_NEAR(g.max_z_mm, 297.05, 1e-12);
  EXPECT_NEAR(g.limit_z_mm, 247.51, 0.005);
  EXPECT_NEAR(std::sqrt(g.max_xy2_mm2), 157.11, 0.005);
  EXPECT_NEAR(std::sqrt(g.slow_xy2_mm2), 141.17, 0.005);
  EXPECT_NEAR(std::sqrt(g.very_slow_xy2_mm2), 153.73, 0.005);
  EXPECT_DOUBLE_EQ(g.min_z_mm, -5.0);
  // Towers at 210, 330, 90 degrees; b and c inherit a's rods and endstop.
  EXPECT_NEAR(g.tower_x_mm[0], -174.75 * std::sqrt(3.0) / 2.0, 1e-9);
  EXPECT_NEAR(g.tower_y_mm[0], -87.375, 1e-9);
  EXPECT_NEAR(g.tower_y_mm[2], 174.75, 1e-9);
  EXPECT_DOUBLE_EQ(g.arm_length_mm[2], 333.0);
  EXPECT_DOUBLE_EQ(g.endstop_mm[1], 297.05);
  // Symmetric towers: home is straight below, at the endstop height.
  EXPECT_NEAR(g.home_position_mm[0], 0.0, 1e-9);
  EXPECT_NEAR(g.home_position_mm[1], 0.0, 1e-9);
  EXPECT_NEAR(g.home_position_mm[2], 297.05, 1e-9);
  // Carriage height at the centre, z = 0: sqrt(333^2 - 174.75^2).
  EXPECT_NEAR(g.carriage_mm(0, 0, 0, 0), std::sqrt(333.0 * 333.0 - 174.75 * 174.75), 1e-9);
}

TEST(DeltaCfg, TaperAboveTheConeStart) {
  const DeltaGeometry g = delta_geometry(load_machine(kDir + "delta.cfg"));
  EXPECT_DOUBLE_EQ(g.limit_xy2_at(100.0), g.max_xy2_mm2);
  // 32.49 mm above limit_z the shortest rod reaches R - sqrt(L^2 - (L - dz)^2) from the centre.
  const double dz = 280.0 - g.limit_z_mm;
  const double r = 174.75 - std::sqrt(333.0 * 333.0 - (333.0 - dz) * (333.0 - dz));
  EXPECT_NEAR(g.limit_xy2_at(280.0), r * r, 1e-9);
}

TEST(DeltaCfg, TrilaterationFindsAKnownPoint) {
  // Three spheres through (10, -20, 5): centres anywhere, radii their distances.
  const std::array<double, 3> p{10.0, -20.0, 5.0};
  const std::array<std::array<double, 3>, 3> c{{{-150, -80, 300}, {140, -70, 310}, {5, 170, 295}}};
  std::array<double, 3> r2{};
  for (std::size_t i = 0; i < 3; ++i) {
    for (std::size_t k = 0; k < 3; ++k) r2[i] += (c[i][k] - p[k]) * (c[i][k] - p[k]);
  }
  const auto q = trilaterate_below(c, r2);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(q[k], p[k], 1e-9);
}

TEST(DeltaCfg, MissingAndInconsistentKeysAreErrors) {
  EXPECT_NE(cfg_error("[printer]\nkinematics: delta\nmax_velocity: 300\nmax_accel: 3000\n")
                .find("option 'delta_radius' in section [printer] must be specified"),
            std::string::npos);
  std::string no_arm = kDelta;
  no_arm.replace(no_arm.find("arm_length: 333.0\n"), 18, "");
  EXPECT_NE(cfg_error(no_arm).find("option 'arm_length' in section [stepper_a] must be specified"),
            std::string::npos);
  std::string short_arm = kDelta;
  short_arm.replace(short_arm.find("333.0"), 5, "100");
  EXPECT_NE(cfg_error(short_arm).find("[stepper_a] arm_length: must be above 174.75, got 100"),
            std::string::npos)
      << cfg_error(short_arm);
  std::string no_c = kDelta.substr(0, kDelta.find("[stepper_c]"));
  EXPECT_NE(cfg_error(no_c).find("a delta needs [stepper_c]"), std::string::npos);
  EXPECT_NE(cfg_error(kDelta + "[printer]\nprint_radiuss: 100\n").find("did you mean 'print_radius'"),
            std::string::npos);
}

TEST(DeltaToml, RoundTripsAndKeepsTheTowers) {
  const Machine m = load_machine(kDir + "delta.cfg");
  const std::string text = to_toml(m);
  EXPECT_NE(text.find("[delta]\nradius = 174.75"), std::string::npos) << text;
  EXPECT_NE(text.find("[stepper_a]"), std::string::npos);
  EXPECT_NE(text.find("arm_length = 333"), std::string::npos);
  EXPECT_EQ(parse_machine_toml(text, "delta.toml"), without_cfg_sections(m));
  // A cartesian machine writes no [delta] section.
  EXPECT_EQ(to_toml(Machine{}).find("[delta]"), std::string::npos);
}

TEST(DeltaToml, DeltaWithoutRadiusIsAnError) {
  const std::string e = error_of([] {
    (void)parse_machine_toml("[printer]\nkinematics = \"delta\"\n", "d.toml");
  });
  EXPECT_NE(e.find("delta.radius"), std::string::npos) << e;
}

TEST(DeltaToml, OverridesReachTheTowers) {
  const Machine m = load_machine(kDir + "delta.cfg", {"stepper_b.arm_length=340", "delta.print_radius=120"});
  const DeltaGeometry g = delta_geometry(m);
  EXPECT_DOUBLE_EQ(g.arm_length_mm[1], 340.0);
  EXPECT_NEAR(std::sqrt(g.max_xy2_mm2), 120.0, 1e-12);
}

TEST(DeltesianCfg, GeometryMatchesKlippersStartupLog) {
  // Klipper's log for deltesian.cfg: "Deltesian kinematics: moves slowed past 45.86mm and
  // 51.21mm"; X limits from min_angle 5: floor(cos 5 deg 217 - 160) = 56.
  const Machine m = load_machine(kDir + "deltesian.cfg");
  EXPECT_TRUE(kinematics::is<kinematics::Deltesian>(m.kinematics));
  const DeltesianGeometry g = deltesian_geometry(m);
  EXPECT_NEAR(std::sqrt(g.slow_x2_mm2), 45.86, 0.005);
  EXPECT_NEAR(std::sqrt(g.very_slow_x2_mm2), 51.21, 0.005);
  EXPECT_DOUBLE_EQ(g.limits_mm[0][0], -56.0);
  EXPECT_DOUBLE_EQ(g.limits_mm[0][1], 56.0);
  EXPECT_DOUBLE_EQ(g.limits_mm[1][1], 200.0);
  // Symmetric arms: home straight below the middle, the carriages at 268: z = 268.
  EXPECT_NEAR(g.home_z_mm, 268.0, 1e-9);
  // Top of the volume at the X limits: there the far tower's arm stands steepest, its carriage
  // (at its endstop) holds the effector at abs_endstop - sqrt(L^2 - (160 - 56)^2).
  const double abs_endstop = 268.0 + std::sqrt(217.0 * 217.0 - 160.0 * 160.0);
  EXPECT_NEAR(g.limits_mm[2][1], abs_endstop - std::sqrt(217.0 * 217.0 - 104.0 * 104.0), 1e-9);
  EXPECT_EQ(parse_machine_toml(to_toml(m), "d.toml"), without_cfg_sections(m));
}

TEST(WinchCfg, CablesAndAnchorsAreRead) {
  const Machine m = load_machine(kDir + "winch.cfg");
  EXPECT_TRUE(kinematics::is<kinematics::Winch>(m.kinematics));
  ASSERT_EQ(m.steppers.count("d"), 1u);
  const auto& w = std::get<kinematics::Winch>(m.kinematics);
  EXPECT_DOUBLE_EQ(*w.anchors.at("d").z_mm, 3000.0);
  EXPECT_DOUBLE_EQ(*w.anchors.at("a").y_mm, -2000.0);
  EXPECT_EQ(parse_machine_toml(to_toml(m), "w.toml"), without_cfg_sections(m));
  const std::string no_anchor =
      "[printer]\nkinematics: winch\nmax_velocity: 300\nmax_accel: 3000\n"
      "[stepper_a]\nmicrosteps: 16\nrotation_distance: 40\nanchor_x: 0\nanchor_y: 0\n"
      "[stepper_b]\nmicrosteps: 16\nrotation_distance: 40\n"
      "[stepper_c]\nmicrosteps: 16\nrotation_distance: 40\n";
  EXPECT_NE(cfg_error(no_anchor).find("option 'anchor_z' in section [stepper_a] must be specified"),
            std::string::npos)
      << cfg_error(no_anchor);
}

}  // namespace
}  // namespace amctl::machine
