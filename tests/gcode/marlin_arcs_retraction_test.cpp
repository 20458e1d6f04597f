// Marlin's MIN_CIRCLE_SEGMENTS (arcs.min_circle_segments) and RETRACT_ZRAISE
// (firmware_retraction.lift_z, M207 Z). Expected values are worked out by hand from Marlin's
// rules (Marlin/src/gcode/motion/G2_G3.cpp, Marlin/src/feature/fwretract.cpp), not from
// the code under test.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::gcode {
namespace {

struct Record : EventSink {
  std::vector<MoveRequest> moves;
  void on_move(const MoveRequest& m) override { moves.push_back(m); }
};

std::vector<MoveRequest> run(std::string_view text, const InterpreterOptions& o) {
  Record r;
  Interpreter in(o, "t.gcode");
  LineReader reader(text, "t.gcode");
  in.run(reader, r);
  return r.moves;
}

/// Segments of the one arc in `text`, whose first line is a positioning G1.
std::size_t arc_segments(std::string_view text, const InterpreterOptions& o) {
  const auto moves = run(text, o);
  std::size_t n = 0;
  for (const auto& m : moves) n += m.from_arc ? 1 : 0;
  EXPECT_EQ(n + 1, moves.size()) << text;  // the G1, then only arc segments
  return n;
}

InterpreterOptions marlin_arcs(int min_circle_segments, double min_segment_mm = 0.1) {
  InterpreterOptions o;
  o.mm_per_arc_segment = 1.0;  // Marlin MAX_ARC_SEGMENT_MM 1
  o.min_arc_segment_mm = min_segment_mm;
  o.max_arc_segment_mm = 1.0;
  o.min_circle_segments = min_circle_segments;
  return o;
}

// Circle of radius 10 around the origin, started at (10, 0).
constexpr const char* kFullCircle = "G1 X10 Y0 F600\nG2 X10 Y0 I-10 J0\n";
// Quarter circle counter-clockwise from (10, 0) to (0, 10): 90 degrees.
constexpr const char* kQuarter = "G1 X10 Y0 F600\nG3 X0 Y10 I-10 J0\n";
// The same end points clockwise: the long way round, 270 degrees.
constexpr const char* kThreeQuarters = "G1 X10 Y0 F600\nG2 X0 Y10 I-10 J0\n";

TEST(MinCircleSegments, OffKeepsTheChordLengthRule) {
  // 2 pi 10 = 62.83 mm at 1 mm per chord: floor = 62. Quarter: 15.71 mm -> 15.
  EXPECT_EQ(arc_segments(kFullCircle, marlin_arcs(0)), 62u);
  EXPECT_EQ(arc_segments(kQuarter, marlin_arcs(0)), 15u);
}

TEST(MinCircleSegments, FullCircleGetsAtLeastNSegments) {
  // Marlin: a full circle gets MIN_CIRCLE_SEGMENTS = 72 (> 62 from the chord length); each
  // chord then spans 5 degrees.
  const auto moves = run(kFullCircle, marlin_arcs(72));
  ASSERT_EQ(moves.size(), 1u + 72u);
  for (std::size_t i = 1; i < moves.size(); ++i) {
    const auto& s = moves[i].start_mm;
    const auto& e = moves[i].end_mm;
    const double step_deg =
        std::acos((s[0] * e[0] + s[1] * e[1]) / (std::hypot(s[0], s[1]) * std::hypot(e[0], e[1]))) *
        180.0 / std::numbers::pi;
    EXPECT_NEAR(step_deg, 5.0, 1e-6) << "segment " << i;
  }
  EXPECT_EQ(moves.back().end_mm[0], 10.0);
  EXPECT_EQ(moves.back().end_mm[1], 0.0);
  // A count below the chord-length rule changes nothing: 20 < 62.
  EXPECT_EQ(arc_segments(kFullCircle, marlin_arcs(20)), 62u);
}

TEST(MinCircleSegments, PartOfACircleGetsItsShareRoundedUp) {
  // ceil(72 * 90 / 360) = 18 > 15; ceil(72 * 270 / 360) = 54 > floor(47.12) = 47.
  EXPECT_EQ(arc_segments(kQuarter, marlin_arcs(72)), 18u);
  EXPECT_EQ(arc_segments(kThreeQuarters, marlin_arcs(72)), 54u);
  // Prusa's 20: ceil(20 / 4) = 5 < 15, the chord rule stands.
  EXPECT_EQ(arc_segments(kQuarter, marlin_arcs(20)), 15u);
  // One radian on a circle of radius 2: 2 mm -> floor = 2; ceil(72 / (2 pi)) = ceil(11.46) = 12.
  char text[160];
  std::snprintf(text, sizeof text, "G1 X2 Y0 F600\nG3 X%.17g Y%.17g I-2 J0\n", 2.0 * std::cos(1.0),
                2.0 * std::sin(1.0));
  EXPECT_EQ(arc_segments(text, marlin_arcs(72)), 12u);
}

TEST(MinCircleSegments, NeverMakesChordsShorterThanTheMinimumSegment) {
  // Radius 5: 31.42 mm. 72 segments would be 0.436 mm < MIN_ARC_SEGMENT_MM 0.5, so Marlin
  // takes floor(31.42 / 0.5) = 62 instead.
  const char* small = "G1 X5 Y0 F600\nG2 X5 Y0 I-5 J0\n";
  EXPECT_EQ(arc_segments(small, marlin_arcs(72, 0.5)), 62u);
  // With MIN_ARC_SEGMENT_MM 0.1 the 72 stand (0.436 mm >= 0.1).
  EXPECT_EQ(arc_segments(small, marlin_arcs(72, 0.1)), 72u);
}

TEST(MinCircleSegments, CombinesWithSegmentsPerSecond) {
  // ARC_SEGMENTS_PER_SEC 50 at F6000 (100 mm/s): 2 mm chords, clamped to MAX 1 mm -> 15 on
  // the quarter; then MIN_CIRCLE_SEGMENTS 72 -> 18.
  InterpreterOptions o = marlin_arcs(72);
  o.arc_segments_per_second = 50;
  EXPECT_EQ(arc_segments("G1 X10 Y0 F6000\nG3 X0 Y10 I-10 J0\n", o), 18u);
  o.max_arc_segment_mm = 0.0;  // no upper clamp: floor(15.71 / 2) = 7, raised to 18
  EXPECT_EQ(arc_segments("G1 X10 Y0 F6000\nG3 X0 Y10 I-10 J0\n", o), 18u);
  o.min_circle_segments = 0;
  EXPECT_EQ(arc_segments("G1 X10 Y0 F6000\nG3 X0 Y10 I-10 J0\n", o), 7u);
}

InterpreterOptions hop_options(double lift_z_mm) {
  InterpreterOptions o;
  o.retract_length_mm = 0.8;
  o.retract_speed_mm_s = 35;
  o.unretract_speed_mm_s = 20;
  o.lift_z_mm = lift_z_mm;
  o.lift_z_speed_mm_s = 12;
  return o;
}

TEST(FirmwareRetractionLiftZ, G10RetractsThenHopsAndG11LowersThenRecovers) {
  const auto m = run("G1 Z0.3 F600\nG1 X10 E1\nG10\nG1 X20\nG11\nG1 X30 E2\n", hop_options(0.4));
  ASSERT_EQ(m.size(), 8u);
  // G10: E 1 -> 0.2 at the retract speed, Z untouched...
  EXPECT_DOUBLE_EQ(m[2].end_mm[3] - m[2].start_mm[3], -0.8);
  EXPECT_EQ(m[2].end_mm[2], 0.3);
  EXPECT_DOUBLE_EQ(m[2].speed_mm_s, 35.0);
  // ...then Z 0.3 -> 0.7 alone at the Z speed.
  EXPECT_DOUBLE_EQ(m[3].end_mm[2] - m[3].start_mm[2], 0.4);
  EXPECT_EQ(m[3].end_mm[3], m[3].start_mm[3]);
  EXPECT_EQ(m[3].end_mm[0], m[3].start_mm[0]);
  EXPECT_DOUBLE_EQ(m[3].speed_mm_s, 12.0);
  EXPECT_TRUE(m[2].from_firmware_retract);
  EXPECT_TRUE(m[3].from_firmware_retract);
  // The travel in between stays raised.
  EXPECT_DOUBLE_EQ(m[4].end_mm[2], 0.7);
  EXPECT_EQ(m[4].end_mm[0], 20.0);
  // G11: Z back to exactly 0.3 first, at the Z speed...
  EXPECT_EQ(m[5].end_mm[2], 0.3);
  EXPECT_EQ(m[5].end_mm[3], m[5].start_mm[3]);
  EXPECT_DOUBLE_EQ(m[5].speed_mm_s, 12.0);
  // ...then E recovers by 0.8 at the unretract speed.
  EXPECT_DOUBLE_EQ(m[6].end_mm[3] - m[6].start_mm[3], 0.8);
  EXPECT_EQ(m[6].end_mm[2], 0.3);
  EXPECT_DOUBLE_EQ(m[6].speed_mm_s, 20.0);
  EXPECT_TRUE(m[5].from_firmware_retract);
  EXPECT_TRUE(m[6].from_firmware_retract);
  // The print goes on at the file's Z.
  EXPECT_EQ(m[7].end_mm[2], 0.3);
  EXPECT_DOUBLE_EQ(m[7].end_mm[3], 2.0);
}

TEST(FirmwareRetractionLiftZ, OneHopOnlyAndTinyHopsIgnored) {
  // A repeated G10 or G11 does nothing: retract, hop, lower, recover.
  const auto m = run("G10\nG10\nG11\nG11\n", hop_options(0.4));
  ASSERT_EQ(m.size(), 4u);
  EXPECT_DOUBLE_EQ(m[1].end_mm[2], 0.4);
  EXPECT_EQ(m[2].end_mm[2], 0.0);
  // Marlin applies a hop only above 0.01 mm: just the E moves.
  const auto tiny = run("G10\nG11\n", hop_options(0.01));
  ASSERT_EQ(tiny.size(), 2u);
  for (const auto& mv : tiny) EXPECT_EQ(mv.end_mm[2], 0.0);
  // lift_z = 0 (the default of every preset): no Z move.
  ASSERT_EQ(run("G10\nG11\n", hop_options(0.0)).size(), 2u);
}

TEST(FirmwareRetractionLiftZ, ZMovesWhileRaisedKeepTheHopAsAnOffset) {
  // Absolute G1 Z1 while hopped by 0.4 goes to 1.4; G11 lowers by the hop to 1.0.
  const auto m = run("G10\nG1 Z1 F600\nG11\n", hop_options(0.4));
  ASSERT_EQ(m.size(), 5u);
  EXPECT_DOUBLE_EQ(m[2].end_mm[2], 1.4);
  EXPECT_DOUBLE_EQ(m[3].end_mm[2], 1.0);
}

TEST(FirmwareRetractionLiftZ, M207ZSetsTheHopInCurrentUnits) {
  InterpreterOptions o;  // Klipper defaults: no retraction, no hop
  auto m = run("M207 S1 F1800 Z0.5\nG10\nG11\n", o);
  ASSERT_EQ(m.size(), 4u);
  EXPECT_DOUBLE_EQ(m[0].end_mm[3], -1.0);
  EXPECT_DOUBLE_EQ(m[0].speed_mm_s, 30.0);
  EXPECT_DOUBLE_EQ(m[1].end_mm[2], 0.5);
  EXPECT_EQ(m[2].end_mm[2], 0.0);
  EXPECT_DOUBLE_EQ(m[3].end_mm[3], 0.0);
  // G20: Z0.02 inch = 0.508 mm.
  m = run("G20\nM207 Z0.02\nG21\nG10\n", o);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_DOUBLE_EQ(m[0].end_mm[2], 0.508);
  // M207 Z0 turns the hop off again.
  EXPECT_TRUE(run("M207 Z0\nG10\nG11\n", hop_options(0.4)).size() == 2u);
}

TEST(FirmwareRetractionLiftZ, NegativeOptionsAreErrors) {
  InterpreterOptions o;
  o.lift_z_mm = -1;
  EXPECT_THROW(Interpreter(o, "t"), Error);
  o = {};
  o.min_circle_segments = -3;
  EXPECT_THROW(Interpreter(o, "t"), Error);
  o = {};
  o.lift_z_speed_mm_s = 0;
  EXPECT_THROW(Interpreter(o, "t"), Error);
}

}  // namespace
}  // namespace amctl::gcode
