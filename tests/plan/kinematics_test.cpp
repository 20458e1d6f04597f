// The planner's kinematics-specific limits (Klipper's check_move of delta.py, corexz.py,
// hybrid_*.py, none.py), each against a hand calculation of a single rest-to-rest move:
// t = d / v + v / a when the move reaches v, also under Klipper's minimum_cruise_ratio 0.5
// (the smoothed pass lets a lone move peak at sqrt(d a_smooth) with a_smooth = min(a,
// max_accel / 2), so every case here has d a_smooth >= v^2).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

const std::string kDir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/";

double trapezoid_s(double d, double v, double a) { return d / v + v / a; }

EstimateReport delta_estimate(const std::string& moves) {
  // tests/reference/klipper/delta.cfg: 300 mm/s, 3000 mm/s^2, slowed past r = 141.17 mm
  // (1/2) and 153.73 mm (1/4), build radius 157.11 mm, z in [-5, 297.05].
  return estimate_text("SET_KINEMATIC_POSITION X=0 Y=0 Z=10\n" + moves, "d.gcode",
                       machine::load_machine(kDir + "delta.cfg"));
}

TEST(DeltaLimits, InnerZoneRunsAtTheToolheadLimits) {
  EXPECT_NEAR(delta_estimate("G1 X100 F18000\n").total_time_s, trapezoid_s(100, 300, 3000), 1e-9);
}

TEST(DeltaLimits, HalfSpeedBeyondTheSlowRadius) {
  // r = 150 > 141.17: v = 150, a = 1500.
  EXPECT_NEAR(delta_estimate("G1 X150 F18000\n").total_time_s, trapezoid_s(150, 150, 1500), 1e-9);
}

TEST(DeltaLimits, QuarterSpeedBeyondTheVerySlowRadius) {
  // r = 155 > 153.73: v = 75, a = 750.
  EXPECT_NEAR(delta_estimate("G1 X155 F18000\n").total_time_s, trapezoid_s(155, 75, 750), 1e-9);
}

TEST(DeltaLimits, TheStartCountsAsMuchAsTheEnd) {
  // From r = 150 back to the centre: still the half-speed move (Klipper takes the larger of
  // the start and end radius).
  const auto r = delta_estimate("G1 X150 F18000\nG4 P0\nG1 X0\n");
  EXPECT_NEAR(r.total_time_s, 2.0 * trapezoid_s(150, 150, 1500), 1e-9);
}

TEST(DeltaLimits, ZMovesUseTheZLimits) {
  // max_z_velocity 150, max_z_accel 1500; a pure Z move of 50 mm at 300 mm/s requested.
  EXPECT_NEAR(delta_estimate("G1 Z60 F18000\n").total_time_s, trapezoid_s(50, 150, 1500), 1e-9);
}

TEST(DeltaLimits, LeavingTheBuildVolumeIsARangeError) {
  const auto r = delta_estimate("G1 X100 F18000\nG4 P0\nG1 X158\n");
  ASSERT_TRUE(r.range_error.has_value());
  EXPECT_EQ(r.range_error->axis, 'r');
  EXPECT_EQ(r.range_error->line, 4u);
  EXPECT_NEAR(r.range_error->limit_mm, 157.11, 0.005);
  EXPECT_NEAR(r.range_error->at_s, trapezoid_s(100, 300, 3000), 1e-9);
  const auto high = delta_estimate("G1 Z298\n");
  ASSERT_TRUE(high.range_error.has_value());
  EXPECT_EQ(high.range_error->axis, 'z');
  EXPECT_DOUBLE_EQ(high.range_error->limit_mm, 297.05);
  // Above the cone start the radius shrinks: x = 40 is fine at z = 200, not at z = 280.
  EXPECT_FALSE(delta_estimate("G1 X40 Z200\n").range_error.has_value());
  EXPECT_TRUE(delta_estimate("G1 X40 Z280\n").range_error.has_value());
  EXPECT_NE(describe_range_error(*r.range_error).find("build radius"), std::string::npos);
}

TEST(DeltaLimits, HomingPutsTheEffectorAtTheTop) {
  // G28 on a delta: every tower at its endstop, effector at (0, 0, 297.05); the move down to
  // Z 10 is a Z move limited to 150 mm/s and 1500 mm/s^2.
  const auto r = estimate_text("G28 X\nG1 Z10 F18000\n", "h.gcode",
                               machine::load_machine(kDir + "delta.cfg"));
  EXPECT_NEAR(r.total_time_s, trapezoid_s(287.05, 150, 1500), 1e-9);
}

machine::Machine gantry(kinematics::Params k) {
  machine::Machine m;
  m.kinematics = k;
  m.max_z_velocity_mm_s = 10;
  m.max_z_accel_mm_s2 = 100;
  return m;
}

TEST(GantryLimits, CoreXZAndHybridLimitZLikeCartesian) {
  for (const kinematics::Params& k : {kinematics::Params{kinematics::CoreXZ{}}, kinematics::Params{kinematics::HybridCoreXY{}},
                                    kinematics::Params{kinematics::HybridCoreXZ{}}}) {
    const auto r = estimate_text("G1 Z20 F6000\n", "z.gcode", gantry(k));
    EXPECT_NEAR(r.total_time_s, trapezoid_s(20, 10, 100), 1e-9) << kinematics::name_of(k);
  }
}

EstimateReport deltesian_estimate(const std::string& moves) {
  // tests/reference/klipper/deltesian.cfg: 500 mm/s, 3000 mm/s^2, moves with X motion
  // slowed past |x| = 45.86 mm (1/2) and 51.21 mm (1/4), x in [-56, 56], y in [0, 200].
  return estimate_text("SET_KINEMATIC_POSITION X=0 Y=100 Z=10\n" + moves, "d.gcode",
                       machine::load_machine(kDir + "deltesian.cfg"));
}

TEST(DeltesianLimits, SlowZonesByX) {
  EXPECT_NEAR(deltesian_estimate("G1 X40 F12000\n").total_time_s, trapezoid_s(40, 200, 3000), 1e-9);
  EXPECT_NEAR(deltesian_estimate("G1 X50 F18000\n").total_time_s, trapezoid_s(50, 250, 1500), 1e-9);
  EXPECT_NEAR(deltesian_estimate("G1 X55 F18000\n").total_time_s, trapezoid_s(55, 125, 750), 1e-9);
  // A Y move out at x = 50 has no X motion: not slowed.
  EXPECT_NEAR(deltesian_estimate("G1 X50 F18000\nG4 P0\nG1 Y190\n").total_time_s,
              trapezoid_s(50, 250, 1500) + trapezoid_s(90, 300, 3000), 1e-9);
}

TEST(DeltesianLimits, RangesOfEachAxis) {
  const auto r = deltesian_estimate("G1 X57 F18000\n");
  ASSERT_TRUE(r.range_error.has_value());
  EXPECT_EQ(r.range_error->axis, 'x');
  EXPECT_DOUBLE_EQ(r.range_error->limit_mm, 56.0);
  EXPECT_TRUE(deltesian_estimate("G1 Y201\n").range_error.has_value());
  EXPECT_FALSE(deltesian_estimate("G1 Y200 Z100\n").range_error.has_value());
}

TEST(GantryLimits, WinchHasNoZLimit) {
  // winch.py check_move checks nothing: a Z move runs at the toolhead's limits.
  const auto r = estimate_text("SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG1 Z100 F18000\n", "w.gcode",
                               machine::load_machine(kDir + "winch.cfg"));
  EXPECT_NEAR(r.total_time_s, trapezoid_s(100, 300, 3000), 1e-9);
}

TEST(GantryLimits, NoneHasNoZLimit) {
  // Klipper's none kinematics checks nothing: the toolhead's 300 mm/s and 3000 mm/s^2 apply.
  const auto r = estimate_text("G1 Z100 F18000\n", "z.gcode", gantry(kinematics::None{}));
  EXPECT_NEAR(r.total_time_s, trapezoid_s(100, 300, 3000), 1e-9);
}

EstimateReport reference_estimate(const std::string& cfg, const std::string& text) {
  return estimate_text(text, "k.gcode", machine::load_machine(kDir + cfg));
}

TEST(GenericCartesianLimits, ZLikeCartesianAndTheCarriageRanges) {
  // generic_cartesian.cfg: 500 mm/s, 3000 mm/s^2, max_z_velocity 20, max_z_accel 100,
  // carriages x [0, 300], y [0, 200], z [0, 100].
  const std::string at = "SET_KINEMATIC_POSITION X=150 Y=100 Z=10\n";
  EXPECT_NEAR(reference_estimate("generic_cartesian.cfg", at + "G1 Z60 F6000\n").total_time_s,
              trapezoid_s(50, 20, 100), 1e-9);
  EXPECT_NEAR(reference_estimate("generic_cartesian.cfg",
                                 "SET_KINEMATIC_POSITION X=10 Y=100 Z=10\nG1 X290 F30000\n")
                  .total_time_s,
              trapezoid_s(280, 500, 3000), 1e-9);
  const auto r = reference_estimate("generic_cartesian.cfg", at + "G1 X301 F30000\n");
  ASSERT_TRUE(r.range_error.has_value());
  EXPECT_EQ(r.range_error->axis, 'x');
  EXPECT_DOUBLE_EQ(r.range_error->limit_mm, 300.0);
}

TEST(PolarLimits, MovesNearTheCentreSlowToTheAngularVelocity) {
  // polar.cfg: 300 mm/s, 3000 mm/s^2, max_angular_velocity 5 rad/s. A line passing 1 mm from
  // the centre at 300 mm/s would turn the bed at 300 rad/s: both limits scale by 5 / 300.
  const std::string at = "SET_KINEMATIC_POSITION X=100 Y=-1 Z=10\n";
  EXPECT_NEAR(reference_estimate("polar.cfg", at + "G1 X-100 Y-1 F18000\n").total_time_s,
              trapezoid_s(200, 5, 50), 1e-9);
  // Far from the centre (closest at (100, 0), 100 mm out: 3 rad/s): not slowed.
  EXPECT_NEAR(reference_estimate("polar.cfg", at + "G1 X100 Y99 F18000\n").total_time_s,
              trapezoid_s(100, 300, 3000), 1e-9);
  // Z: max_z_velocity 25, max_z_accel 30 as cartesian.
  EXPECT_NEAR(reference_estimate("polar.cfg", at + "G1 Z40 F3000\n").total_time_s,
              trapezoid_s(30, 25, 30), 1e-9);
  const auto r = reference_estimate("polar.cfg", at + "G1 X250 Y200 F18000\n");
  ASSERT_TRUE(r.range_error.has_value());
  EXPECT_EQ(r.range_error->axis, 'r');
  EXPECT_DOUBLE_EQ(r.range_error->limit_mm, 300.0);
}

TEST(RotaryDeltaLimits, AnyMoveWithZIsCappedUnscaled) {
  // rotary_delta.cfg: 300 mm/s, 3000 mm/s^2, max_z_velocity 50: a move with Z motion runs at
  // most 50 mm/s along its whole path (not scaled by its Z share), its accel untouched.
  const std::string at = "SET_KINEMATIC_POSITION X=0 Y=0 Z=10\n";
  EXPECT_NEAR(reference_estimate("rotary_delta.cfg", at + "G1 Z60 F18000\n").total_time_s,
              trapezoid_s(50, 50, 3000), 1e-9);
  EXPECT_NEAR(reference_estimate("rotary_delta.cfg", at + "G1 X100 Z20 F18000\n").total_time_s,
              trapezoid_s(std::hypot(100.0, 10.0), 50, 3000), 1e-9);
  EXPECT_NEAR(reference_estimate("rotary_delta.cfg", at + "G1 X100 F18000\n").total_time_s,
              trapezoid_s(100, 300, 3000), 1e-9);
  // Build radius min(33.9 + 170, 320 - 33.9) = 203.9; top at the endstop, 252.
  const auto r = reference_estimate("rotary_delta.cfg", at + "G1 X210 F18000\n");
  ASSERT_TRUE(r.range_error.has_value());
  EXPECT_EQ(r.range_error->axis, 'r');
  EXPECT_NEAR(r.range_error->limit_mm, 203.9, 1e-9);
  const auto z = reference_estimate("rotary_delta.cfg", at + "G1 Z253 F18000\n");
  ASSERT_TRUE(z.range_error.has_value());
  EXPECT_EQ(z.range_error->axis, 'z');
}

TEST(NoExtruder, MovesWithoutEPlanAndAMoveThatExtrudesStopsAtItsLine) {
  // A printer.cfg without [extruder] (valid in Klipper): the toolhead's extruder is a dummy
  // whose check_move refuses a move with an E component ("Extrude when no extruder present").
  const std::string cfg =
      "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
      "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 200\n"
      "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 200\n"
      "[stepper_z]\nrotation_distance: 8\nmicrosteps: 16\nposition_max: 200\n";
  const machine::Machine m = machine::parse_klipper_cfg(cfg, "p.cfg");
  EXPECT_FALSE(m.extruder.present);
  // 100 mm at 300 mm/s, 3000 mm/s^2 from rest to rest: 100/300 + 300/3000 s.
  EXPECT_NEAR(estimate_text("SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG1 X100 F18000\n", "t.gcode", m).total_time_s,
              trapezoid_s(100, 300, 3000), 1e-9);
  try {
    (void)estimate_text("SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG1 X100 F18000\nG1 X110 E1\n", "t.gcode", m);
    FAIL() << "a move that extrudes was planned";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_NE(std::string(e.what()).find("Extrude when no extruder present: 110.000 0.000 0.000 [1.000]"),
              std::string::npos)
        << e.what();
  }
  // A retract alone extrudes too (Klipper checks any E component).
  EXPECT_THROW((void)estimate_text("SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nG1 E-1 F1800\n", "t.gcode", m), Error);
}

}  // namespace
}  // namespace amctl::plan
