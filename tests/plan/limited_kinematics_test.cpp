// Kalico's limited kinematics (limited_cartesian, limited_corexy, limited_corexz): the print
// time of single rest-to-rest moves against a hand calculation of their check_move limits,
// t = d / v + v / a (every case has d a_smooth >= v^2 under minimum_cruise_ratio 0.5, so the
// move reaches v; see kinematics_test.cpp). The printer.cfg options and their checks.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

double trapezoid_s(double d, double v, double a) { return d / v + v / a; }

// 200 mm/s and 3000 mm/s^2 at the toolhead; Z 10 mm/s, 100 mm/s^2.
machine::Machine machine_with(kinematics::Params k) {
  machine::Machine m;
  m.kinematics = std::move(k);
  m.max_velocity_mm_s = 200;
  m.max_accel_mm_s2 = 3000;
  m.max_z_velocity_mm_s = 10;
  m.max_z_accel_mm_s2 = 100;
  return m;
}

kinematics::AxisLimits limits(double vx, double vy, double ax, double ay, bool scale = false) {
  kinematics::AxisLimits l;
  if (vx > 0) l.max_x_velocity_mm_s = vx;
  if (vy > 0) l.max_y_velocity_mm_s = vy;
  l.max_x_accel_mm_s2 = ax;
  l.max_y_accel_mm_s2 = ay;
  l.scale_xy_accel = scale;
  return l;
}

double time_of(const machine::Machine& m, const std::string& moves) {
  return estimate_text(moves, "k.gcode", m).total_time_s;
}

TEST(LimitedCartesian, EachAxisAtItsOwnLimits) {
  kinematics::LimitedCartesian k;
  k.limits = limits(100, 50, 2000, 1000);
  const auto m = machine_with(k);
  // Along X: 100 mm/s, 2000 mm/s^2 (200 mm/s requested).
  EXPECT_NEAR(time_of(m, "G1 X100 F12000\n"), trapezoid_s(100, 100, 2000), 1e-9);
  // Along Y: 50 mm/s, 1000 mm/s^2.
  EXPECT_NEAR(time_of(m, "G1 Y100 F12000\n"), trapezoid_s(100, 50, 1000), 1e-9);
  // The diagonal: r = (1, 1) / sqrt2, Y binds: v = 50 sqrt2, a = 1000 sqrt2.
  const double s2 = std::sqrt(2.0);
  EXPECT_NEAR(time_of(m, "G1 X100 Y100 F12000\n"), trapezoid_s(100 * s2, 50 * s2, 1000 * s2), 1e-9);
  // Z keeps the toolhead's Z limits.
  EXPECT_NEAR(time_of(m, "G1 Z20 F6000\n"), trapezoid_s(20, 10, 100), 1e-9);
}

TEST(LimitedCartesian, DefaultsAreSqrt2TimesMaxVelocityAndMaxAccel) {
  // Unset: velocities sqrt2 * 200 = 282.8 (the toolhead's 200 binds), accels 3000.
  auto m = machine_with(kinematics::LimitedCartesian{});
  EXPECT_NEAR(time_of(m, "G1 X100 F15000\n"), trapezoid_s(100, 200, 3000), 1e-9);
  // Z without max_z_velocity and max_z_accel: no lower than the toolhead's limits.
  m.max_z_velocity_mm_s = 0;
  m.max_z_accel_mm_s2 = 0;
  m.max_accel_mm_s2 = 30000;  // so that v^2 <= d a_smooth below
  EXPECT_NEAR(time_of(m, "G1 Z100 F15000\n"), trapezoid_s(100, 200, 30000), 1e-9);
}

TEST(LimitedCartesian, ScaleXyAccelFollowsTheAccelInForce) {
  kinematics::LimitedCartesian k;
  k.limits = limits(0, 0, 2000, 1000, true);
  const auto m = machine_with(k);
  // X: 2000 * 3000 / hypot(2000, 1000) = 2683.28 mm/s^2.
  const double a = 2000.0 * 3000.0 / std::hypot(2000.0, 1000.0);
  EXPECT_NEAR(time_of(m, "G1 X100 F6000\n"), trapezoid_s(100, 100, a), 1e-9);
  // After M204 S1000: 2000 * 1000 / 2236.07 = 894.43 mm/s^2.
  const double a2 = 2000.0 * 1000.0 / std::hypot(2000.0, 1000.0);
  EXPECT_NEAR(time_of(m, "M204 S1000\nG1 X100 F3000\n"), trapezoid_s(100, 50, a2), 1e-9);
}

TEST(LimitedCoreXY, BeltSpeedAndPerAxisAccel) {
  kinematics::LimitedCoreXY k;
  k.limits = limits(0, 0, 2000, 1000);
  const auto m = machine_with(k);
  // Along X: both belts at |x| = d, v = 200; a = d / (x / 2000) = 2000.
  EXPECT_NEAR(time_of(m, "G1 X100 F12000\n"), trapezoid_s(100, 200, 2000), 1e-9);
  // The diagonal X100 Y100 (d = 141.42): one belt moves 200 mm, v = 200 d / 200 = 141.42;
  // a = d / max(|0.05 + 0.1|, |0.05 - 0.1|) = d / 0.15 = 942.8.
  const double d = 100 * std::sqrt(2.0);
  EXPECT_NEAR(time_of(m, "G1 X100 Y100 F12000\n"), trapezoid_s(d, d, d / 0.15), 1e-9);
  // Z: the toolhead's Z limits.
  EXPECT_NEAR(time_of(m, "G1 Z20 F6000\n"), trapezoid_s(20, 10, 100), 1e-9);
}

TEST(LimitedCoreXY, ScaleXyAccel) {
  kinematics::LimitedCoreXY k;
  k.limits = limits(0, 0, 2000, 1000, true);
  const auto m = machine_with(k);
  // a = 3000 d / (0.15 * max(2000, 1000)) = 10 d = 1414.2 on the diagonal.
  const double d = 100 * std::sqrt(2.0);
  EXPECT_NEAR(time_of(m, "G1 X100 Y100 F12000\n"), trapezoid_s(d, d, 10 * d), 1e-9);
}

TEST(LimitedCoreXZ, PerAxisLimitsWithToolheadDefaults) {
  kinematics::LimitedCoreXZ k;
  k.limits = limits(150, 0, 2500, 0);
  k.limits.max_y_accel_mm_s2.reset();
  const auto m = machine_with(k);
  EXPECT_NEAR(time_of(m, "G1 X100 F12000\n"), trapezoid_s(100, 150, 2500), 1e-9);
  // Y: defaults max_velocity (200) and max_accel (3000).
  EXPECT_NEAR(time_of(m, "G1 Y100 F15000\n"), trapezoid_s(100, 200, 3000), 1e-9);
  EXPECT_NEAR(time_of(m, "G1 Z20 F6000\n"), trapezoid_s(20, 10, 100), 1e-9);
}

// A printer.cfg of the named kinematics, loaded from a file of this process (tests run in
// parallel) that is removed once read.
machine::Machine load_cfg(const std::string& name, const std::string& printer_extra) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("amctl_limited_test_" + std::to_string(::getpid()) + "_" + name + ".cfg");
  struct Remove {
    std::filesystem::path p;
    ~Remove() {
      std::error_code ec;
      std::filesystem::remove(p, ec);
    }
  } remove{path};
  std::ofstream(path) << "[printer]\nkinematics: " << name
                      << "\nmax_velocity: 200\nmax_accel: 3000\n" << printer_extra
                      << "\n[stepper_x]\nstep_pin: a\ndir_pin: b\nrotation_distance: 40\n"
                         "microsteps: 16\nposition_endstop: 0\nposition_max: 200\n"
                         "[stepper_y]\nstep_pin: a\ndir_pin: b\nrotation_distance: 40\n"
                         "microsteps: 16\nposition_endstop: 0\nposition_max: 200\n"
                         "[stepper_z]\nstep_pin: a\ndir_pin: b\nrotation_distance: 8\n"
                         "microsteps: 16\nposition_endstop: 0\nposition_max: 200\n";
  return machine::load_machine(path.string());
}

TEST(LimitedKinematics, ReadFromPrinterCfg) {
  const auto m = load_cfg(
      "limited_cartesian", "max_x_velocity: 100\nmax_y_velocity: 50\nmax_x_accel: 2000\n"
                           "max_y_accel: 1000\nscale_xy_accel: False\nminimum_cruise_ratio: 0.5");
  EXPECT_NEAR(time_of(m, "G28\nG1 X100 Y100 F12000\n"),
              trapezoid_s(100 * std::sqrt(2.0), 50 * std::sqrt(2.0), 1000 * std::sqrt(2.0)), 1e-9);
  const auto xy =
      load_cfg("limited_corexy", "max_x_accel: 2000\nmax_y_accel: 1000\nscale_xy_accel: true");
  const double d = 100 * std::sqrt(2.0);
  EXPECT_NEAR(time_of(xy, "G28\nG1 X100 Y100 F12000\n"), trapezoid_s(d, d, 10 * d), 1e-9);
}

TEST(LimitedKinematics, BadOptionsNameTheirPlace) {
  // limited_cartesian refuses a velocity above max_velocity (Kalico's maxval).
  try {
    (void)load_cfg("limited_cartesian", "max_x_velocity: 250");
    FAIL() << "accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(":5:"), std::string::npos) << what;
    EXPECT_NE(what.find("max_x_velocity"), std::string::npos) << what;
  }
  EXPECT_THROW((void)load_cfg("limited_corexy", "max_x_accel: -1"), Error);
  EXPECT_THROW((void)load_cfg("limited_corexy", "scale_xy_accel: maybe"), Error);
  // limited_corexy has no per-axis velocity: an unknown option as in Kalico.
  EXPECT_THROW((void)load_cfg("limited_corexy", "max_x_velocity: 100"), Error);
}

}  // namespace
}  // namespace amctl::plan
