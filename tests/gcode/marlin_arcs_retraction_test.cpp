// Marlin's MIN_CIRCLE_SEGMENTS (arcs.min_circle_segments). Expected values are worked out by
// hand from Marlin's rule (Marlin/src/gcode/motion/G2_G3.cpp), not from the code under test.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace amctl::gcode
