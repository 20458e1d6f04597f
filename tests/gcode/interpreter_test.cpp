#include "amctl/gcode/interpreter.hpp"

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::gcode {
namespace {

/// n zeros: G-code has no exponent, so big numbers are written out in full.
std::string zeros(int n) { return std::string(static_cast<std::size_t>(n), '0'); }

struct Record : EventSink {
  std::vector<MoveRequest> moves;
  std::vector<double> dwells;
  std::vector<LimitsCommand> limits;
  std::vector<HeaterCommand> heaters;
  std::vector<std::string> untimed;
  int waits = 0;
  void on_move(const MoveRequest& m) override { moves.push_back(m); }
  void on_dwell(double s, std::uint64_t) override { dwells.push_back(s); }
  void on_limits(const LimitsCommand& c) override { limits.push_back(c); }
  void on_heater(const HeaterCommand& h) override { heaters.push_back(h); }
  void on_wait_moves(std::uint64_t) override { ++waits; }
  void on_untimed(std::string_view n, std::uint64_t) override { untimed.emplace_back(n); }
};

Record run(std::string_view text, InterpreterOptions o = {}) {
  Record r;
  Interpreter in(o, "t.gcode");
  LineReader reader(text, "t.gcode");
  in.run(reader, r);
  return r;
}

TEST(Interpreter, AbsoluteAndRelativeModesAndG92) {
  auto r = run("G90\nM83\nG1 X10 Y5 E1 F600\nG91\nG1 X1 E0.5\nG90\nG92 X0 E0\nG1 X2\n");
  ASSERT_EQ(r.moves.size(), 3u);
  EXPECT_DOUBLE_EQ(r.moves[0].end_mm[0], 10.0);
  EXPECT_DOUBLE_EQ(r.moves[0].end_mm[3], 1.0);
  EXPECT_DOUBLE_EQ(r.moves[0].speed_mm_s, 10.0);
  EXPECT_DOUBLE_EQ(r.moves[1].end_mm[0], 11.0);
  EXPECT_DOUBLE_EQ(r.moves[1].end_mm[3], 1.5);
  // After G92 X0 the file's X2 is machine X13.
  EXPECT_DOUBLE_EQ(r.moves[2].end_mm[0], 13.0);
}

TEST(Interpreter, AbsoluteExtrusionWithG92E) {
  auto r = run("M82\nG1 X1 E2 F600\nG1 X2 E3\nG92 E0\nG1 X3 E0.5\n");
  ASSERT_EQ(r.moves.size(), 3u);
  EXPECT_DOUBLE_EQ(r.moves[1].end_mm[3] - r.moves[1].start_mm[3], 1.0);
  EXPECT_DOUBLE_EQ(r.moves[2].end_mm[3] - r.moves[2].start_mm[3], 0.5);
}

TEST(Interpreter, SpeedAndExtrusionFactors) {
  auto r = run("M83\nM220 S50\nM221 S200\nG1 X10 E1 F6000\n");
  ASSERT_EQ(r.moves.size(), 1u);
  EXPECT_DOUBLE_EQ(r.moves[0].speed_mm_s, 50.0);
  EXPECT_DOUBLE_EQ(r.moves[0].end_mm[3], 2.0);
}

TEST(Interpreter, InchesScaleEveryAxis) {
  auto r = run("G20\nG1 X1 F60\n");
  ASSERT_EQ(r.moves.size(), 1u);
  EXPECT_DOUBLE_EQ(r.moves[0].end_mm[0], 25.4);
  EXPECT_DOUBLE_EQ(r.moves[0].speed_mm_s, 25.4);
}

TEST(Interpreter, DwellUnits) {
  auto r = run("G4 P250\nG4 S2\n");
  ASSERT_EQ(r.dwells.size(), 2u);
  EXPECT_DOUBLE_EQ(r.dwells[0], 0.25);
  EXPECT_DOUBLE_EQ(r.dwells[1], 2.0);
}

TEST(Interpreter, ArcWithIJEndsExactlyAndStaysOnTheCircle) {
  // Quarter circle CCW from (10,0) around the origin to (0,10): length 5 pi = 15.7 mm ->
  // floor(15.7 / 1) = 15 chords.
  auto r = run("G1 X10 Y0 F600\nG3 X0 Y10 I-10 J0 E1\n");
  ASSERT_EQ(r.moves.size(), 1u + 15u);
  for (std::size_t i = 1; i < r.moves.size(); ++i) {
    const auto& e = r.moves[i].end_mm;
    EXPECT_NEAR(std::hypot(e[0], e[1]), 10.0, 1e-9);
    EXPECT_TRUE(r.moves[i].from_arc);
  }
  EXPECT_DOUBLE_EQ(r.moves.back().end_mm[0], 0.0);
  EXPECT_DOUBLE_EQ(r.moves.back().end_mm[1], 10.0);
  EXPECT_NEAR(r.moves.back().end_mm[3], 1.0, 1e-12);
}

TEST(Interpreter, ArcRFormPicksTheCentreOnTheCorrectSide) {
  // G2 (clockwise) from (0,0) to (10,0) with R5: semicircle through (5,5)?? Clockwise travel
  // from (0,0) to (10,0) with the centre at (5,0) passes y > 0.
  auto r = run("G2 X10 Y0 R5 F600\n", InterpreterOptions{0.5});
  double max_y = -1e9;
  for (const auto& m : r.moves) max_y = std::max(max_y, m.end_mm[1]);
  EXPECT_NEAR(max_y, 5.0, 0.05);
  // G3 goes below.
  auto r3 = run("G3 X10 Y0 R5 F600\n", InterpreterOptions{0.5});
  double min_y = 1e9;
  for (const auto& m : r3.moves) min_y = std::min(min_y, m.end_mm[1]);
  EXPECT_NEAR(min_y, -5.0, 0.05);
  // R smaller than half the chord is an error.
  EXPECT_THROW(run("G2 X10 Y0 R2 F600\n"), Error);
}

TEST(Interpreter, FirmwareRetractionUsesConfiguredLengths) {
  InterpreterOptions o;
  o.retract_length_mm = 0.8;
  o.retract_speed_mm_s = 35;
  o.unretract_extra_length_mm = 0.1;
  auto r = run("G10\nG10\nG11\n", o);
  ASSERT_EQ(r.moves.size(), 2u);
  EXPECT_DOUBLE_EQ(r.moves[0].end_mm[3], -0.8);
  EXPECT_DOUBLE_EQ(r.moves[0].speed_mm_s, 35.0);
  EXPECT_NEAR(r.moves[1].end_mm[3], 0.1, 1e-12);
}

TEST(Interpreter, LimitsAndHeatersArePassedOn) {
  auto r = run("M204 P1000 T2000\nSET_VELOCITY_LIMIT ACCEL=3000 MINIMUM_CRUISE_RATIO=0.3\n"
               "M109 S215\nM140 S60\nTEMPERATURE_WAIT SENSOR=heater_bed MINIMUM=58\n");
  ASSERT_EQ(r.limits.size(), 2u);
  EXPECT_DOUBLE_EQ(r.limits[0].params.get('T'), 2000.0);
  ASSERT_TRUE(r.limits[1].accel && r.limits[1].minimum_cruise_ratio);
  EXPECT_DOUBLE_EQ(*r.limits[1].accel, 3000.0);
  EXPECT_DOUBLE_EQ(*r.limits[1].minimum_cruise_ratio, 0.3);
  ASSERT_EQ(r.heaters.size(), 3u);
  EXPECT_TRUE(r.heaters[0].wait);
  EXPECT_EQ(r.heaters[1].kind, HeaterCommand::Kind::bed);
  EXPECT_TRUE(r.heaters[2].wait);
  EXPECT_EQ(r.heaters[2].kind, HeaterCommand::Kind::bed);
}

TEST(Interpreter, HomingAndProbingAreUntimedStops) {
  auto r = run("G1 X5 F600\nG28\nG29\nBED_MESH_CALIBRATE\n");
  ASSERT_EQ(r.untimed.size(), 3u);
  EXPECT_EQ(r.untimed[0], "G28");
}

TEST(Interpreter, BadInputNamesFileLineColumn) {
  try {
    run("G1 X1\nG1 Y2\nM220 S-5\n");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.where().line, 3u);
    EXPECT_EQ(e.where().column, 6u);
    EXPECT_NE(std::string(e.what()).find("t.gcode:3:6"), std::string::npos) << e.what();
  }
  EXPECT_THROW(run("G4 P-1\n"), Error);
  EXPECT_THROW(run("SET_VELOCITY_LIMIT ACCEL=fast\n"), Error);
  EXPECT_THROW(run("SET_VELOCITY_LIMIT ACCEL=-1\n"), Error);
  EXPECT_THROW(run("M204 S-100\n"), Error);
  EXPECT_THROW(run("G2 X1 Y1\n"), Error);  // no centre
  EXPECT_THROW(run("G1 X10 F600\nG1 Y10 E"), Error);  // cut off after a letter
  EXPECT_NO_THROW(run("G28 X Y\n"));                  // bare letters are flags for G28
}

// Found by fuzz_gcode: coordinates that overflow to inf/NaN (or are merely absurd) must be
// errors naming the line and the axis, not moves the planner turns into NaN times.
TEST(Interpreter, CoordinatesBeyondAThousandKilometresAreErrors) {
  auto expect_range_error = [](std::string_view g, std::uint64_t line, std::uint32_t col) {
    try {
      run(g);
      FAIL() << "expected an error for " << g;
    } catch (const Error& e) {
      EXPECT_EQ(e.where().line, line) << g;
      EXPECT_EQ(e.where().column, col) << g;
      EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
    }
  };
  expect_range_error("G20\nG1 X1" + zeros(308) + " F100\n", 2, 4);         // 25.4 * 1e308 = inf
  expect_range_error("G91\nG1 X17" + zeros(307) + " F100\nG1 X17" + zeros(307) + "\n", 2, 4);  // beyond 1e9 already
  expect_range_error("G1 X1 F60\nG92 X-15" + zeros(307) + "\nG1 X15" + zeros(307) + "\n", 3, 4);  // v - offset = inf
  // M221 is refused itself now (a factor of 1e308 % is no machine's: docs/machine.md,
  // "Physical ranges"); a large but physical factor still puts E beyond the bound.
  expect_range_error("M221 S1" + zeros(6) + "\nM83\nG1 X10 E1" + zeros(6) + " F100\n", 3, 8);
  // An arc through 2e300 mm is refused for its segment count before any point is emitted.
  EXPECT_THROW(run("G1 X1 F60\nG2 X1 Y0 I1" + zeros(300) + " J0\n"), Error);
  // The bound itself is accepted: 1e9 mm.
  EXPECT_EQ(run("G1 X1" + zeros(9) + " F60\n").moves.size(), 1u);
}

// Found by fuzz_gcode: SET_VELOCITY_LIMIT VELOCITY=1e308 made v^2 = inf in the planner.
TEST(Interpreter, AbsurdlyLargeLimitsAreErrors) {
  EXPECT_THROW(run("SET_VELOCITY_LIMIT VELOCITY=1e308\n"), Error);
  EXPECT_THROW(run("SET_VELOCITY_LIMIT ACCEL=1e10\n"), Error);
  EXPECT_THROW(run("M203 X1" + zeros(300) + "\n"), Error);
  EXPECT_THROW(run("M204 S2" + zeros(9) + "\n"), Error);
  // Extended commands take Python float() syntax (Klipper), exponents included. The bounds
  // are the physical ranges: 1e6 mm/s, 1e9 mm/s^2 (docs/machine.md, "Physical ranges").
  EXPECT_EQ(run("SET_VELOCITY_LIMIT VELOCITY=1e6 ACCEL=1e9\nM204 S1" + zeros(9) + "\n").limits.size(), 2u);
  EXPECT_THROW(run("SET_VELOCITY_LIMIT VELOCITY=1.1e6\n"), Error);
}

TEST(Interpreter, LenientModeCountsSkippedLines) {
  InterpreterOptions o;
  o.strict = false;
  auto in = Interpreter(o, "t");
  Record r;
  in.feed("G1 X1 F60", 1, r);
  in.feed("@@@", 2, r);
  EXPECT_EQ(in.skipped_lines(), 1u);
  EXPECT_EQ(r.moves.size(), 1u);
  // A malformed number in a parameter is a malformed line too (found by the Python tests:
  // it used to raise even in lenient mode); the state is left as it was.
  in.feed("G1 X1.2.3", 3, r);
  in.feed("M204 S1.2.3", 4, r);
  EXPECT_EQ(in.skipped_lines(), 3u);
  in.feed("G1 X2", 5, r);
  ASSERT_EQ(r.moves.size(), 2u);
  EXPECT_DOUBLE_EQ(r.moves[1].start_mm[0], 1.0);
  EXPECT_DOUBLE_EQ(r.moves[1].end_mm[0], 2.0);
  // Strict mode still stops there with the column of the bad number.
  auto strict = Interpreter({}, "t.gcode");
  try {
    strict.feed("G1 X1.2.3", 7, r);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().line, 7u);
    EXPECT_GT(e.where().column, 0u);
  }
}

TEST(Interpreter, SlicerAnnotationsFromFourSlicers) {
  for (const char* text :
       {";LAYER_CHANGE\n;TYPE:Perimeter\nG1 X1 F60\n;LAYER_CHANGE\n;TYPE:Perimeter\nG1 X2\n",
        ";LAYER:0\n;TYPE:WALL-OUTER\nG1 X1 F60\n;LAYER:1\nG1 X2\n",
        "; CHANGE_LAYER\n; FEATURE: Outer wall\nG1 X1 F60\n; CHANGE_LAYER\nG1 X2\n",
        // ideaMaker (the fourth; named in the test but missing): Cura's markers, its types.
        ";Sliced by ideaMaker 4.2.2\n;LAYER:0\n;TYPE:SKIRT\nG1 X1 F60\n;LAYER:1\nG1 X2\n"}) {
    auto r = run(text);
    ASSERT_EQ(r.moves.size(), 2u) << text;
    EXPECT_EQ(r.moves[0].layer, 0) << text;
    EXPECT_EQ(r.moves[1].layer, 1) << text;
    EXPECT_EQ(r.moves[0].feature, 1) << text;
  }
}

Annotations annotations_of(std::string_view text) {
  Record r;
  Interpreter in({}, "t.gcode");
  LineReader reader(text, "t.gcode");
  in.run(reader, r);
  return in.annotations();
}

TEST(Interpreter, SlicerEstimatesAndNamesFromComments) {
  // PrusaSlicer: 1 h 2 min 3 s = 3723 s.
  auto a = annotations_of("; generated by PrusaSlicer 2.6.0 on 2023-06-01\n"
                          "; estimated printing time (normal mode) = 1h 2m 3s\n");
  EXPECT_EQ(a.slicer_name, "PrusaSlicer");
  ASSERT_TRUE(a.slicer_estimate_s.has_value());
  EXPECT_DOUBLE_EQ(*a.slicer_estimate_s, 3723.0);
  // Cura: the first ;TIME: counts.
  a = annotations_of(";Generated with Cura_SteamEngine 5.3.0\n;TIME:6666\n;TIME:1\n");
  EXPECT_EQ(a.slicer_name, "Cura_SteamEngine");
  ASSERT_TRUE(a.slicer_estimate_s.has_value());
  EXPECT_DOUBLE_EQ(*a.slicer_estimate_s, 6666.0);
  // OrcaSlicer/Bambu: days too, 1 d 2 h 3 min 4 s = 93784 s, or after the model time.
  a = annotations_of("; total estimated time: 1d 2h 3m 4s\n");
  ASSERT_TRUE(a.slicer_estimate_s.has_value());
  EXPECT_DOUBLE_EQ(*a.slicer_estimate_s, 93784.0);
  a = annotations_of("; model printing time: 1h 2m; total estimated time: 1h 5m 0s\n");
  ASSERT_TRUE(a.slicer_estimate_s.has_value());
  EXPECT_DOUBLE_EQ(*a.slicer_estimate_s, 3900.0);
  // ideaMaker.
  a = annotations_of(";Sliced by ideaMaker 4.2.3\n;Print Time: 1234\n");
  EXPECT_EQ(a.slicer_name, "ideaMaker");
  ASSERT_TRUE(a.slicer_estimate_s.has_value());
  EXPECT_DOUBLE_EQ(*a.slicer_estimate_s, 1234.0);
  // Not a duration: no estimate.
  EXPECT_FALSE(annotations_of("; estimated printing time (normal mode) = soon\n").slicer_estimate_s);
  // Feature names are listed in order of first appearance, after "unknown".
  a = annotations_of(";TYPE:Skirt\n;TYPE:Perimeter\n;TYPE:Skirt\n");
  EXPECT_EQ(a.feature_names, (std::vector<std::string>{"unknown", "Skirt", "Perimeter"}));
  EXPECT_EQ(a.feature, 1);
}

TEST(LineReader, StreamsFilesInBoundedBufferAndFlagsMissingNewline) {
  const std::string path = ::testing::TempDir() + "/amctl_reader.gcode";
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    for (int i = 0; i < 20000; ++i) std::fputs("G1 X1.000 Y2.000 E0.1\r\n", f);
    std::fputs("G1 X9", f);
    std::fclose(f);
  }
  LineReader reader(std::make_unique<InputFile>(path, gcode_input_options()), path, 4096);
  std::string_view line;
  std::uint64_t n = 0;
  while (reader.next(line)) {
    ++n;
    if (n <= 20000) EXPECT_EQ(line, "G1 X1.000 Y2.000 E0.1");
  }
  EXPECT_EQ(n, 20001u);
  EXPECT_EQ(line, "G1 X9");
  EXPECT_TRUE(reader.ended_without_newline());
  EXPECT_THROW(InputFile("/nonexistent/file.gcode", gcode_input_options()), Error);
}

}  // namespace
}  // namespace amctl::gcode
