// --motor-space (machine::motor_space): the two motors that move X and Y on every kinematics
// whose motors are linear in X, Y, Z, each against the transform Klipper's chelper/kin_*.c
// writes by hand (corexy: A = X + Y, B = X - Y; hybrid_corexy: stepper_x = X - Y, ...), and a
// clear error naming --motor-space on the others.
#include <gtest/gtest.h>

#include <array>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/machine/kinematics.hpp"
#include "amctl/machine/loader.hpp"

namespace amctl::machine {
namespace {

// A printer.cfg of `kin` with stepper_x, stepper_y, stepper_z (and nothing else it needs).
Machine printer(const std::string& kin) {
  std::string cfg = "[printer]\nkinematics: " + kin + "\nmax_velocity: 300\nmax_accel: 3000\n";
  for (const char* s : {"x", "y", "z"}) {
    cfg += std::string("[stepper_") + s +
           "]\nrotation_distance: 40\nmicrosteps: 16\nposition_endstop: 0\nposition_max: 200\n";
  }
  return parse_klipper_cfg(cfg, "p.cfg");
}

struct Expected {
  const char* kinematics;
  std::array<std::array<double, 3>, 2> rows;  // stepper_x, stepper_y over (X, Y, Z)
};

TEST(MotorSpace, EveryLinearKinematicsGivesItsXYMotorsRows) {
  const Expected cases[] = {
      {"cartesian", {{{1, 0, 0}, {0, 1, 0}}}},
      {"corexy", {{{1, 1, 0}, {1, -1, 0}}}},         // kin_corexy.c: '+' X + Y, '-' X - Y
      {"hybrid_corexy", {{{1, -1, 0}, {0, 1, 0}}}},  // hybrid_corexy.py rail 0: '-' callback
      {"corexz", {{{1, 0, 1}, {0, 1, 0}}}},          // kin_corexz.c: '+' X + Z; Y cartesian
      {"hybrid_corexz", {{{1, 0, -1}, {0, 1, 0}}}},  // hybrid_corexz.py rail 0: X - Z
  };
  for (const Expected& c : cases) {
    SCOPED_TRACE(c.kinematics);
    const MotorSpace s = motor_space(printer(c.kinematics));
    EXPECT_EQ(s.motors[0], "stepper_x");
    EXPECT_EQ(s.motors[1], "stepper_y");
    for (std::size_t m = 0; m < 2; ++m) {
      for (std::size_t a = 0; a < 3; ++a) EXPECT_DOUBLE_EQ(s.rows[m][a], c.rows[m][a]);
    }
  }
}

TEST(MotorSpace, NonLinearKinematicsIsAnErrorNamingTheFlag) {
  const std::string dir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/";
  for (const char* cfg : {"delta.cfg", "deltesian.cfg", "winch.cfg", "polar.cfg", "rotary_delta.cfg"}) {
    SCOPED_TRACE(cfg);
    try {
      (void)motor_space(load_machine(dir + cfg));
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--motor-space"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("no linear motor map"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace amctl::machine
