// Step generation of the kinematics beyond cartesian/CoreXY: the linear gantries (CoreXZ,
// hybrid) against their motor rows, and the delta towers (non-linear) against the carriage
// height computed here from the geometry (c = z + sqrt(L^2 - (x - tx)^2 - (y - ty)^2), with
// the towers placed by hand from delta_radius and the angles) on the exact trajectory.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/steppers/steps.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "step_run.hpp"

namespace amctl::steppers {
namespace {

using machine::Machine;

constexpr double kRadius = 174.75, kArm = 333.0, kEndstop = 297.05;

Machine delta_machine() {
  Machine m;
  kinematics::Delta d;
  d.radius_mm = kRadius;
  d.minimum_z_position_mm = -5.0;
  d.towers["a"] = {kArm, std::nullopt, kEndstop};
  m.kinematics = d;
  for (const char* t : {"a", "b", "c"}) m.steppers[t] = {40.0, 16, 200};  // 0.0125 mm
  m.steppers["e"] = {33.5, 16, 200};
  return m;
}

// Carriage height of tower i (0 = a at 210 degrees, 1 = b at 330, 2 = c at 90).
double carriage(int i, double x, double y, double z) {
  const double angle = (210.0 + 120.0 * i) * std::numbers::pi / 180.0;
  const double tx = kRadius * std::cos(angle), ty = kRadius * std::sin(angle);
  return z + std::sqrt(kArm * kArm - (x - tx) * (x - tx) - (y - ty) * (y - ty));
}

using test::run;
using KinRun = test::StepRun;

TEST(DeltaSteps, ChannelsAreTheTowersAndTheExtruder) {
  const auto ch = machine::motors(delta_machine());
  ASSERT_EQ(ch.size(), 4u);
  EXPECT_EQ(ch[0].name, "stepper_a");
  EXPECT_EQ(ch[2].name, "stepper_c");
  EXPECT_EQ(ch[3].name, "extruder");
  // The towers' curves are the carriage heights (b's arm defaults to a's).
  for (int i = 0; i < 3; ++i) {
    ASSERT_FALSE(ch[static_cast<std::size_t>(i)].linear());
    for (const auto& p : {kinematics::Vec3{0, 0, 0}, {30, -40, 12}, {-70, 55, 3}}) {
      EXPECT_NEAR(ch[static_cast<std::size_t>(i)].curve->position(p), carriage(i, p[0], p[1], p[2]),
                  1e-9);
    }
  }
}

// Every step puts its carriage on the half-step level (to 1e-9 mm), and the number of steps
// per tower equals the number of grid changes of round((c - c0) / h) sampled densely along
// the exact trajectory (an independent count: no root finding).
void check_delta(const std::string& gcode) {
  const Machine m = delta_machine();
  const KinRun r = run(gcode, m);
  ASSERT_FALSE(r.moves.empty());
  const trajectory::Trajectory traj(r.moves);
  const auto p0 = traj.evaluate(r.moves.front().start_time_s);
  for (int i = 0; i < 3; ++i) {
    const double origin = carriage(i, p0.pos_mm[0], p0.pos_mm[1], p0.pos_mm[2]);
    const double h = r.motors[static_cast<std::size_t>(i)].step_distance.value;
    long n = 0, count = 0;
    double last_t = -1.0;
    for (const Step& s : r.steps) {
      if (s.stepper != static_cast<std::uint32_t>(i)) continue;
      const double level = origin + (static_cast<double>(n) + 0.5 * s.direction) * h;
      n += s.direction;
      ++count;
      const auto p = traj.evaluate(s.time_s);
      ASSERT_NEAR(carriage(i, p.pos_mm[0], p.pos_mm[1], p.pos_mm[2]), level, 1e-9)
          << "tower " << i << " t=" << s.time_s;
      ASSERT_GE(s.time_s, last_t);
      last_t = s.time_s;
    }
    // Dense sampling: 2e5 samples per second of motion, far finer than any step interval here.
    const double t0 = r.moves.front().start_time_s, t1 = r.moves.back().end_time_s();
    const auto samples = static_cast<long>((t1 - t0) * 2e5) + 1;
    long changes = 0;
    long prev = 0;
    for (long k = 0; k <= samples; ++k) {
      const double t = t0 + (t1 - t0) * static_cast<double>(k) / static_cast<double>(samples);
      const auto p = traj.evaluate(t);
      const long g = std::lround((carriage(i, p.pos_mm[0], p.pos_mm[1], p.pos_mm[2]) - origin) / h);
      changes += std::labs(g - prev);
      prev = g;
    }
    EXPECT_EQ(count, changes) << "tower " << i;
    EXPECT_EQ(n, prev) << "tower " << i;
  }
}

TEST(DeltaSteps, StraightMovesAcrossTheBed) {
  check_delta("SET_KINEMATIC_POSITION X=0 Y=0 Z=10\nG1 X60 Y0 F6000\nG1 X60 Y60\nG1 X-50 Y-20 Z12\n");
}

TEST(DeltaSteps, CarriageTurnsWithinAMovePassingItsTower) {
  // Tower c stands at (0, 174.75): along y = 100 from x = -80 to 80 its carriage rises while
  // the effector approaches x = 0 and falls after: up steps, then down steps, in one move.
  const KinRun r = run("SET_KINEMATIC_POSITION X=-80 Y=100 Z=10\nG1 X80 Y100 F3000\n", delta_machine());
  int ups = 0, downs = 0;
  bool down_seen = false, up_after_down = false;
  for (const Step& s : r.steps) {
    if (s.stepper != 2) continue;
    if (s.direction > 0) {
      ++ups;
      up_after_down = up_after_down || down_seen;
    } else {
      ++downs;
      down_seen = true;
    }
  }
  const double rise = carriage(2, 0, 100, 10) - carriage(2, -80, 100, 10);
  EXPECT_EQ(ups, std::lround(rise / 0.0125));
  EXPECT_EQ(downs, ups);  // symmetric about x = 0
  EXPECT_FALSE(up_after_down);
  check_delta("SET_KINEMATIC_POSITION X=-80 Y=100 Z=10\nG1 X80 Y100 F3000\n");
}

TEST(DeltaSteps, ZOnlyMoveStepsEveryTowerAlike) {
  const KinRun r = run("SET_KINEMATIC_POSITION X=0 Y=0 Z=10\nG1 Z20 F600\n", delta_machine());
  std::array<int, 3> count{};
  for (const Step& s : r.steps) {
    if (s.stepper < 3) ++count[s.stepper];
  }
  EXPECT_EQ(count[0], 800);  // 10 mm / 0.0125 mm
  EXPECT_EQ(count[1], 800);
  EXPECT_EQ(count[2], 800);
}

TEST(DeltaSteps, ArcsZHopsAndRetractsStayOnTheGrid) {
  check_delta(
      "SET_KINEMATIC_POSITION X=0 Y=0 Z=5\nG1 X40 Y0 F9000\nG2 X-40 Y0 I-40 J0 E3\n"
      "G1 E-1 F2400\nG1 Z6\nG1 X0 Y-120 F12000\nG1 Z5\nG1 E1\nG1 X100 Y40 E4 F3000\n");
}

TEST(DeltaSteps, OutOfReachIsAnErrorNamingTheTower) {
  Machine m = delta_machine();
  try {
    (void)run("SET_KINEMATIC_POSITION X=0 Y=0 Z=10\nG1 X400 Y0 F6000\n", m);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("out of reach of stepper_"), std::string::npos) << e.what();
  }
}

// A winch (the anchors of Klipper's config/example-winch.cfg): cable length |p - anchor|,
// convex along a move, so a cable can shorten then lengthen within one move.
constexpr std::array<std::array<double, 3>, 4> kAnchors{
    {{0, -2000, -100}, {2000, 1000, -100}, {-2000, 1000, -100}, {0, 0, 3000}}};

Machine winch_machine() {
  Machine m;
  kinematics::Winch w;
  for (std::size_t i = 0; i < 4; ++i) {
    const std::string k(1, static_cast<char>('a' + i));
    w.anchors[k] = {kAnchors[i][0], kAnchors[i][1], kAnchors[i][2]};
    m.steppers[k] = {40.0, 16, 200};
  }
  m.kinematics = w;
  m.steppers["e"] = {33.5, 16, 200};
  return m;
}

double cable(std::size_t i, double x, double y, double z) {
  const auto& a = kAnchors[i];
  return std::sqrt((x - a[0]) * (x - a[0]) + (y - a[1]) * (y - a[1]) + (z - a[2]) * (z - a[2]));
}

TEST(WinchSteps, CablesStayOnTheGridAndCountAsSampled) {
  // The move along y = -1000... passes the point of cable a nearest its anchor (x = 0): a
  // turning point; the others are monotone or turn elsewhere.
  const std::string g =
      "SET_KINEMATIC_POSITION X=-150 Y=-100 Z=10\nG1 X150 Y-100 F6000\nG1 X0 Y100 Z40\n"
      "G1 E-1 F2400\nG1 X-50 Y0 Z10 F9000\n";
  const KinRun r = run(g, winch_machine());
  ASSERT_EQ(r.motors.size(), 5u);
  EXPECT_EQ(r.motors[3].name, "stepper_d");
  const trajectory::Trajectory traj(r.moves);
  const auto p0 = traj.evaluate(r.moves.front().start_time_s);
  for (std::size_t i = 0; i < 4; ++i) {
    const double origin = cable(i, p0.pos_mm[0], p0.pos_mm[1], p0.pos_mm[2]);
    const double h = 0.0125;
    long n = 0, count = 0;
    for (const Step& s : r.steps) {
      if (s.stepper != i) continue;
      const double level = origin + (static_cast<double>(n) + 0.5 * s.direction) * h;
      n += s.direction;
      ++count;
      const auto p = traj.evaluate(s.time_s);
      ASSERT_NEAR(cable(i, p.pos_mm[0], p.pos_mm[1], p.pos_mm[2]), level, 1e-9) << i;
    }
    const double t0 = r.moves.front().start_time_s, t1 = r.moves.back().end_time_s();
    const auto samples = static_cast<long>((t1 - t0) * 2e5) + 1;
    long changes = 0, prev = 0;
    for (long k = 0; k <= samples; ++k) {
      const auto p = traj.evaluate(t0 + (t1 - t0) * static_cast<double>(k) / static_cast<double>(samples));
      const long gk = std::lround((cable(i, p.pos_mm[0], p.pos_mm[1], p.pos_mm[2]) - origin) / h);
      changes += std::labs(gk - prev);
      prev = gk;
    }
    EXPECT_EQ(count, changes) << "cable " << i;
    EXPECT_EQ(n, prev) << "cable " << i;
  }
  // Cable a shortens while x runs from -150 to 0 and lengthens after: both directions.
  int down = 0, up = 0;
  for (const Step& s : r.steps) {
    if (s.stepper == 0 && s.time_s < r.moves.front().end_time_s()) (s.direction < 0 ? down : up)++;
  }
  EXPECT_GT(down, 0);
  EXPECT_GT(up, 0);
}

TEST(DeltesianSteps, TowersInTheXZPlaneStayOnTheGrid) {
  // tests/reference/klipper/deltesian.cfg geometry: arms 217, arm_x 160; left tower at
  // x = -160, right at +160; y is cartesian.
  Machine m;
  kinematics::Deltesian d;
  d.towers["left"] = {160.0, 217.0, 268.0};
  d.rails["y"] = {0.0, 200.0, std::nullopt};
  m.kinematics = d;
  m.steppers["left"] = {40.0, 16, 200};
  m.steppers["right"] = {40.0, 16, 200};
  m.steppers["y"] = {40.0, 16, 200};
  m.steppers["e"] = {33.5, 16, 200};
  const KinRun r = run("SET_KINEMATIC_POSITION X=0 Y=100 Z=10\nG1 X40 Y120 F6000\nG1 X-40 Z20\nG1 Y20\n", m);
  ASSERT_EQ(r.motors.size(), 4u);
  EXPECT_EQ(r.motors[0].name, "stepper_left");
  EXPECT_EQ(r.motors[1].name, "stepper_right");
  EXPECT_EQ(r.motors[2].name, "stepper_y");
  const trajectory::Trajectory traj(r.moves);
  const auto p0 = traj.evaluate(r.moves.front().start_time_s);
  auto carriage_lr = [](int i, double x, double z) {
    const double tx = i == 0 ? -160.0 : 160.0;
    return z + std::sqrt(217.0 * 217.0 - (x - tx) * (x - tx));
  };
  for (int i = 0; i < 2; ++i) {
    const double origin = carriage_lr(i, p0.pos_mm[0], p0.pos_mm[2]);
    long n = 0;
    for (const Step& s : r.steps) {
      if (s.stepper != static_cast<std::uint32_t>(i)) continue;
      const double level = origin + (static_cast<double>(n) + 0.5 * s.direction) * 0.0125;
      n += s.direction;
      const auto p = traj.evaluate(s.time_s);
      ASSERT_NEAR(carriage_lr(i, p.pos_mm[0], p.pos_mm[2]), level, 1e-9) << i;
    }
    const auto pe = traj.evaluate(r.moves.back().end_time_s());
    EXPECT_EQ(n, std::lround((carriage_lr(i, pe.pos_mm[0], pe.pos_mm[2]) - origin) / 0.0125)) << i;
  }
}

TEST(LinearGantrySteps, CoreXZAndHybridRowsAreKlippers) {
  Machine m;
  m.steppers["x"] = {40.0, 16, 200};
  m.steppers["y"] = {40.0, 16, 200};
  m.steppers["z"] = {40.0, 16, 200};
  m.steppers["e"] = {33.5, 16, 200};
  struct Case {
    kinematics::Params k;
    std::array<double, 4> x, y, z;
  };
  const Case cases[] = {
      {kinematics::CoreXZ{}, {1, 0, 1, 0}, {0, 1, 0, 0}, {1, 0, -1, 0}},
      {kinematics::HybridCoreXY{}, {1, -1, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}},
      {kinematics::HybridCoreXZ{}, {1, 0, -1, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}},
  };
  for (const Case& c : cases) {
    m.kinematics = c.k;
    const auto ch = machine::motors(m);
    EXPECT_EQ(ch[0].row, c.x);
    EXPECT_EQ(ch[1].row, c.y);
    EXPECT_EQ(ch[2].row, c.z);
    // A move of 10 mm in X and 4 mm in Z: the counts follow the rows, x + z = 14 mm on the
    // CoreXZ '+' motor.
    const KinRun r = run("G1 X10 Z4 F3000\n", m);
    std::array<long, 3> net{};
    for (const Step& s : r.steps) {
      if (s.stepper < 3) net[s.stepper] += s.direction;
    }
    EXPECT_EQ(net[0], std::lround((10.0 * c.x[0] + 4.0 * c.x[2]) / 0.0125));
    EXPECT_EQ(net[2], std::lround((10.0 * c.z[0] + 4.0 * c.z[2]) / 0.0125));
  }
}

TEST(LinearGantrySteps, NoneHasOnlyTheExtruder) {
  Machine m;
  m.kinematics = kinematics::None{};
  m.steppers["e"] = {33.5, 16, 200};
  const auto ch = machine::motors(m);
  ASSERT_EQ(ch.size(), 1u);
  EXPECT_EQ(ch[0].name, "extruder");
}

TEST(GenericCartesianSteps, EachStepperFollowsItsCarriageRow) {
  // generic_cartesian.cfg: my_stepper_x = X + Y, my_stepper_u = -Y (its dual carriage parked),
  // y0 = y1 = Y, z0 = z1 = Z; 40 mm / 3200 steps (z: 8 mm).
  const Machine m = machine::load_machine(std::string(AMCTL_SOURCE_DIR) +
                                          "/tests/reference/klipper/generic_cartesian.cfg");
  const KinRun r = run("SET_KINEMATIC_POSITION X=150 Y=100 Z=10\nG1 X170 Y90 Z11 F6000\n", m);
  ASSERT_EQ(r.motors.size(), 7u);
  EXPECT_EQ(r.motors[0].name, "stepper my_stepper_u");
  EXPECT_EQ(r.motors[6].name, "extruder");
  const std::map<std::string, long> net = {
      {"stepper my_stepper_x", std::lround(10 / 0.0125)},  {"stepper my_stepper_u", std::lround(10 / 0.0125)},
      {"stepper my_stepper_y0", std::lround(-10 / 0.0125)}, {"stepper my_stepper_y1", std::lround(-10 / 0.0125)},
      {"stepper my_stepper_z0", std::lround(1 / 0.0025)},   {"stepper my_stepper_z1", std::lround(1 / 0.0025)}};
  for (std::size_t i = 0; i + 1 < r.motors.size(); ++i) {
    EXPECT_EQ(r.stats[i].position_steps, net.at(r.motors[i].name)) << r.motors[i].name;
  }
}

TEST(PolarSteps, BedAngleAndArmRadiusStayOnTheGrid) {
  // The polar.cfg drive: bed 2 pi / (200 16 5) rad per step, arm 0.0125 mm. Moves around the
  // centre, one across the +-pi seam of atan2 and one close to the centre.
  const Machine m = machine::load_machine(std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/polar.cfg");
  const KinRun r = run("SET_KINEMATIC_POSITION X=100 Y=0 Z=10\nG1 X0 Y100 F6000\nG1 X-100 Y-5\n"
                       "G1 X-100 Y5\nG1 X3 Y2\nG1 X80 Y-40 Z12\n", m);
  ASSERT_EQ(r.motors.size(), 4u);
  EXPECT_EQ(r.motors[0].name, "stepper_bed");
  EXPECT_EQ(r.motors[1].name, "stepper_arm");
  const trajectory::Trajectory traj(r.moves);
  const double bed_step = 2.0 * std::numbers::pi / 16000.0;
  for (int i = 0; i < 2; ++i) {
    const double step = i == 0 ? bed_step : 0.0125;
    double unwrapped = 0.0;  // the bed angle followed continuously from the start
    auto position = [&](const trajectory::AxisState& p) {
      if (i == 1) return std::hypot(p.pos_mm[0], p.pos_mm[1]);
      const double a = std::atan2(p.pos_mm[1], p.pos_mm[0]);
      unwrapped += std::remainder(a - unwrapped, 2.0 * std::numbers::pi);
      return unwrapped;
    };
    const double origin = position(traj.evaluate(r.moves.front().start_time_s));
    long n = 0;
    for (const Step& s : r.steps) {
      if (s.stepper != static_cast<std::uint32_t>(i)) continue;
      const double level = origin + (static_cast<double>(n) + 0.5 * s.direction) * step;
      n += s.direction;
      ASSERT_NEAR(position(traj.evaluate(s.time_s)), level, 1e-9) << i;
    }
    const double end = position(traj.evaluate(r.moves.back().end_time_s()));
    EXPECT_EQ(n, std::lround((end - origin) / step)) << i;
  }
  // Anticlockwise past the seam at pi, then back clockwise: the path does not wind around the
  // centre, so the bed's net turn is the end's angle, atan2(-40, 80).
  EXPECT_EQ(r.stats[0].position_steps, std::lround(std::atan2(-40.0, 80.0) / bed_step));
}

TEST(RotaryDeltaSteps, ArmAnglesPutTheElbowsAtTheLowerArmLength) {
  // rotary_delta.cfg: at each step time the arm sits at its half-step level; the elbow there
  // (forward kinematics from the shoulder) must be one lower arm (320 mm) from the effector.
  const Machine m =
      machine::load_machine(std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/rotary_delta.cfg");
  const kinematics::RotaryDeltaGeometry g = kinematics::rotary_delta_geometry(
      std::get<kinematics::RotaryDelta>(m.kinematics));
  const KinRun r = run("SET_KINEMATIC_POSITION X=0 Y=0 Z=10\nG1 X100 Y40 F6000\nG1 X-120 Y-20 Z40\nG1 X0 Y150 Z5\n", m);
  ASSERT_EQ(r.motors.size(), 4u);
  const trajectory::Trajectory traj(r.moves);
  const double step = r.motors[0].step_distance.value;
  EXPECT_NEAR(step, 2.0 * std::numbers::pi / (3200.0 * 107.0 / 16.0 * 60.0 / 16.0), 1e-18);
  const auto p0 = traj.evaluate(r.moves.front().start_time_s);
  for (int i = 0; i < 3; ++i) {
    const double origin = g.arm_angle_rad(i, p0.pos_mm[0], p0.pos_mm[1], p0.pos_mm[2]);
    long n = 0, count = 0;
    for (const Step& s : r.steps) {
      if (s.stepper != static_cast<std::uint32_t>(i)) continue;
      const double level = origin + (static_cast<double>(n) + 0.5 * s.direction) * step;
      n += s.direction;
      ++count;
      const auto p = traj.evaluate(s.time_s);
      const auto e = g.elbow_mm(i, level);
      ASSERT_NEAR(std::hypot(p.pos_mm[0] - e[0], p.pos_mm[1] - e[1], p.pos_mm[2] - e[2]), 320.0, 1e-6)
          << i;
    }
    EXPECT_GT(count, 100) << i;
    const auto pe = traj.evaluate(r.moves.back().end_time_s());
    const double end = g.arm_angle_rad(i, pe.pos_mm[0], pe.pos_mm[1], pe.pos_mm[2]);
    EXPECT_EQ(n, std::lround((end - origin) / step)) << i;
  }
}

}  // namespace
}  // namespace amctl::steppers
