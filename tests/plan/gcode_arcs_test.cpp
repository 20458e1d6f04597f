// Klipper registers G2/G3 (and G17-G19) only with a [gcode_arcs] section
// (klippy/extras/gcode_arcs.py); without it they are "Unknown command" (klippy/gcode.py
// cmd_default) and the print goes on. Expected times are closed forms; segment counts follow
// gcode_arcs.py: segments = max(1, floor(arc length / resolution)).
#include <cmath>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

// Full stops at every corner (scv 0) and no cruise ratio: each move is a closed form.
const std::string kPrinter =
    "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 5000\n"
    "square_corner_velocity: 0\nminimum_cruise_ratio: 0\n";
// X0 -> X10 at 100 mm/s, then a half circle of radius 5 back towards X20 (I5 J0).
const std::string kGcode = "G1 X10 F6000\nG17\nG2 X20 Y0 I5 J0\nG3 X10 Y0 I-5 J0\nG1 X0\n";
constexpr double kT10 = 0.12;  // 10 mm, 100 mm/s, 5000 mm/s^2, rest to rest

const gcode::UnknownCommand* find(const EstimateReport& r, const std::string& name) {
  for (const auto& u : r.unknown_commands) {
    if (u.name == name) return &u;
  }
  return nullptr;
}

TEST(GcodeArcs, WithoutTheSectionArcsAreUnknownCommandsAndSkipped) {
  const machine::Machine m = machine::parse_klipper_cfg(kPrinter, "printer.cfg");
  EXPECT_FALSE(m.arcs.enabled);
  const EstimateReport r = estimate_text(kGcode, "arcs.gcode", m);
  // Only the two straight moves remain: X0->X10 and X10->X0.
  EXPECT_EQ(r.moves, 2u);
  EXPECT_NEAR(r.total_time_s, 2 * kT10, 1e-12);
  const gcode::UnknownCommand* g2 = find(r, "G2");
  const gcode::UnknownCommand* g3 = find(r, "G3");
  const gcode::UnknownCommand* g17 = find(r, "G17");
  ASSERT_NE(g2, nullptr);
  ASSERT_NE(g3, nullptr);
  ASSERT_NE(g17, nullptr);
  EXPECT_EQ(g2->first_line, 3u);
  EXPECT_EQ(g3->first_line, 4u);
  EXPECT_EQ(g2->count, 1u);
}

TEST(GcodeArcs, WithTheSectionItsResolutionSetsTheSegmentCount) {
  for (double resolution : {1.0, 0.5, 0.3}) {
    const machine::Machine m = machine::parse_klipper_cfg(
        kPrinter + "[gcode_arcs]\nresolution: " + std::to_string(resolution) + "\n",
        "printer.cfg");
    EXPECT_TRUE(m.arcs.enabled);
    const EstimateReport r = estimate_text(kGcode, "arcs.gcode", m);
    EXPECT_TRUE(r.unknown_commands.empty());
    const double half_circle_mm = std::numbers::pi * 5.0;
    const auto per_arc = static_cast<std::uint64_t>(std::floor(half_circle_mm / resolution));
    EXPECT_EQ(r.moves, 2 + 2 * per_arc) << resolution;
  }
}

TEST(GcodeArcs, TomlMachinesKeepArcsUnlessTheySayOtherwise) {
  machine::Machine m = machine::load_machine("default");
  EXPECT_TRUE(m.arcs.enabled);
  EXPECT_TRUE(estimate_text(kGcode, "arcs.gcode", m).unknown_commands.empty());
  machine::apply_override(m, "arcs.enabled=false");
  const EstimateReport r = estimate_text(kGcode, "arcs.gcode", m);
  EXPECT_NE(find(r, "G2"), nullptr);
  EXPECT_EQ(r.moves, 2u);
  const machine::Machine back =
      machine::parse_machine_toml(machine::to_toml(m), "roundtrip.toml");
  EXPECT_FALSE(back.arcs.enabled);
}

}  // namespace
}  // namespace amctl::plan
