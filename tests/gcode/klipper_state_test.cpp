// Klipper state commands (src/gcode/klipper_state.cpp): SAVE_/RESTORE_GCODE_STATE,
// EXCLUDE_OBJECT*, SET_DUAL_CARRIAGE and SAVE_/RESTORE_DUAL_CARRIAGE_STATE. Expected positions,
// speeds and ranges are worked out by hand from the rules of Klipper's gcode_move.py,
// exclude_object.py and idex_modes.py (docs/gcode.md); times against Klipper's batch mode are
// in tests/plan/klipper_gstate_test.cpp.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::gcode {
namespace {

struct Range {
  int axis;
  double min_mm, max_mm;
};

struct Record : EventSink {
  std::vector<MoveRequest> moves;
  std::vector<Range> ranges;
  std::vector<std::array<double, 4>> set_positions;
  int waits = 0, step_flushes = 0;
  void on_move(const MoveRequest& m) override { moves.push_back(m); }
  void on_wait_moves(std::uint64_t) override { ++waits; }
  void on_step_flush(std::uint64_t) override { ++step_flushes; }
  void on_set_position(const std::array<double, 4>& p, std::uint64_t) override {
    set_positions.push_back(p);
  }
  void on_axis_range(int axis, double lo, double hi, std::uint64_t) override {
    ranges.push_back({axis, lo, hi});
  }
};

struct Run {
  Record r;
  std::vector<ExcludedObject> excluded;
  std::uint64_t excluded_moves = 0;
  std::vector<UnknownCommand> unknown;
  std::map<std::string, std::uint64_t> ignored;
};

Run run(std::string_view text, InterpreterOptions o = {}) {
  Run out;
  Interpreter in(o, "t.gcode");
  LineReader reader(text, "t.gcode");
  in.run(reader, out.r);
  out.excluded = in.excluded_objects();
  out.excluded_moves = in.excluded_moves();
  out.unknown = in.unknown_commands();
  out.ignored = in.ignored_commands();
  return out;
}

// ---- SAVE_GCODE_STATE / RESTORE_GCODE_STATE
// ------------------------------------------------------

TEST(GcodeState, SetKinematicPositionKeepsTheG92Offset) {
  // gcode_move.py: SET_KINEMATIC_POSITION moves the toolhead's idea of where it is; the G92
  // base stays. At X0, G92 X10 makes the base -10; SET_KINEMATIC_POSITION X=0 leaves the head
  // at 0 with the file at 10; G1 X20 then goes to 20 - 10 = 10 mm.
  const auto r = run("G90\nG92 X10\nSET_KINEMATIC_POSITION X=0\nG1 X20 F600\n");
  ASSERT_EQ(r.r.moves.size(), 1u);
  EXPECT_DOUBLE_EQ(r.r.moves[0].end_mm[0], 10.0);
}

TEST(GcodeState, KlippersCommandsTestSequenceMakesNoMove) {
  // Klipper's test/klippy/commands.test: every G1 after a restore lands where the toolhead is
  // (G92 Z-5 puts the base at Z 5; the restores bring back G90 and that base, then the base
  // 0 of the first save). Before issue 14 amctl stayed in G91 and moved Z to -5.
  const auto out =
      run("G28\nSAVE_GCODE_STATE\nG92 Z-5\nG92 E5\nSAVE_GCODE_STATE NAME=test\n"
          "G1 Z-5\nG91\nG1 Z0\nRESTORE_GCODE_STATE NAME=test\nG1 Z-5\n"
          "RESTORE_GCODE_STATE\nG1 Z0 E0\nRESTORE_GCODE_STATE MOVE=1\n");
  EXPECT_TRUE(out.r.moves.empty());
}

TEST(GcodeState, RestoreMoveGoesBackAtTheSavedSpeedOrMoveSpeed) {
  const auto out =
      run("G90\nG1 X10 Y20 Z1 F600\nSAVE_GCODE_STATE NAME=a\nM220 S50\nG1 X50 F3000\n"
          "RESTORE_GCODE_STATE NAME=a MOVE=1\nG1 X60\n"
          "RESTORE_GCODE_STATE NAME=a MOVE=1 MOVE_SPEED=40\n");
  const auto& m = out.r.moves;
  ASSERT_EQ(m.size(), 5u);
  EXPECT_DOUBLE_EQ(m[1].speed_mm_s, 25.0);  // 3000 mm/min at M220 50 %
  // Back to the saved point at the saved speed, 600 mm/min x 100 % (the factor comes back).
  EXPECT_EQ(m[2].end_mm, (std::array<double, 4>{10, 20, 1, 0}));
  EXPECT_DOUBLE_EQ(m[2].speed_mm_s, 10.0);
  EXPECT_DOUBLE_EQ(m[3].speed_mm_s, 10.0);  // F600 and M220 100 % again
  EXPECT_DOUBLE_EQ(m[3].end_mm[0], 60.0);
  EXPECT_EQ(m[4].end_mm, (std::array<double, 4>{10, 20, 1, 0}));
  EXPECT_DOUBLE_EQ(m[4].speed_mm_s, 40.0);  // MOVE_SPEED in mm/s
}

TEST(GcodeState, RestoreBringsBackTheBaseAndTheFilesE) {
  // G92 X0 after the save shifts the file's X by 5; the restore takes the shift back. E
  // continues from the saved file E (5): E6 feeds 1 mm.
  const auto out =
      run("M82\nG1 X5 E5 F600\nSAVE_GCODE_STATE\nG92 X0 E0\nG1 X2 E1\n"
          "RESTORE_GCODE_STATE\nG1 X3 E6\n");
  const auto& m = out.r.moves;
  ASSERT_EQ(m.size(), 3u);
  EXPECT_DOUBLE_EQ(m[1].end_mm[0], 7.0);
  EXPECT_DOUBLE_EQ(m[2].end_mm[0], 3.0);
  EXPECT_DOUBLE_EQ(m[2].end_mm[3] - m[2].start_mm[3], 1.0);
}

TEST(GcodeState, UnknownStateIsKlippersError) {
  try {
    run("G90\nRESTORE_GCODE_STATE NAME=nope\n");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("t.gcode:2:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Unknown g-code state: nope"), std::string::npos)
        << e.what();
  }
}

TEST(GcodeState, SetGcodeOffsetShiftsTheFileOrMovesTheToolhead) {
  // Z=0.2: the file's Z1 is machine Z 1.2. X_ADJUST=5 MOVE=1 moves X by 5 at the F in force
  // (10 mm/s) and the file's X stays; G28 then keeps the offset as its base: Z1 is Z 1.2 again.
  const auto out =
      run("G90\nSET_GCODE_OFFSET Z=0.2\nG1 X10 Z1 F600\nSET_GCODE_OFFSET X_ADJUST=5 MOVE=1\n"
          "G1 X20\nSAVE_GCODE_STATE\nSET_GCODE_OFFSET Z=0\nRESTORE_GCODE_STATE\nG28\nG1 X1 Z1\n");
  const auto& m = out.r.moves;
  ASSERT_EQ(m.size(), 4u);
  EXPECT_DOUBLE_EQ(m[0].end_mm[2], 1.2);
  EXPECT_DOUBLE_EQ(m[1].end_mm[0], 15.0);
  EXPECT_DOUBLE_EQ(m[1].speed_mm_s, 10.0);
  EXPECT_DOUBLE_EQ(m[2].end_mm[0], 25.0);  // the file's X20 + the offset 5
  EXPECT_DOUBLE_EQ(m[3].end_mm[0], 6.0);   // after G28: X1 + 5 (the restored offset)
  EXPECT_DOUBLE_EQ(m[3].end_mm[2], 1.2);
}

// ---- EXCLUDE_OBJECT
// -------------------------------------------------------------------------------

InterpreterOptions exclusion() {
  InterpreterOptions o;
  o.exclude_object = InterpreterOptions::ExcludeObjectMode::active;
  return o;
}

TEST(ExcludeObject, WithoutTheSectionTheCommandsAreIgnoredOrUnknown) {
  const std::string text = "EXCLUDE_OBJECT_START NAME=a\nEXCLUDE_OBJECT NAME=a\nG1 X10 E1 F600\n";
  const auto ignored = run(text);
  EXPECT_EQ(ignored.ignored.at("EXCLUDE_OBJECT"), 1u);
  EXPECT_EQ(ignored.r.moves.size(), 1u);
  InterpreterOptions o;
  o.exclude_object = InterpreterOptions::ExcludeObjectMode::unknown;
  const auto unknown = run(text, o);
  ASSERT_EQ(unknown.unknown.size(), 2u);
  EXPECT_EQ(unknown.unknown[0].name, "EXCLUDE_OBJECT_START");
  EXPECT_EQ(unknown.r.moves.size(), 1u);
}

TEST(ExcludeObject, MovesOfAnExcludedObjectAreNotMadeAndTheToolheadGoesStraightOn) {
  // The transform registers at the first exclusion and lets 5 extruding moves through (to
  // learn the extruder's state): the 5th is B's first. B's next two are skipped; A's move then
  // starts where the toolhead is (X 50) and feeds its own 1 mm (the skipped 2 mm stay in the
  // offset; no retraction differs, so no adjustment).
  const auto out =
      run("M83\nEXCLUDE_OBJECT NAME=B\nEXCLUDE_OBJECT_START NAME=A\n"
          "G1 X10 E1 F600\nG1 X20 E1\nG1 X30 E1\nG1 X40 E1\nEXCLUDE_OBJECT_END\n"
          "EXCLUDE_OBJECT_START NAME=B\nG1 X50 E1\nG1 X60 E1\nG1 X70 E1\n"
          "EXCLUDE_OBJECT_END\nEXCLUDE_OBJECT_START NAME=A\nG1 X80 E1\n",
          exclusion());
  const auto& m = out.r.moves;
  ASSERT_EQ(m.size(), 6u);
  EXPECT_DOUBLE_EQ(m[4].end_mm[0], 50.0);
  EXPECT_EQ(m[5].start_mm, (std::array<double, 4>{50, 0, 0, 5}));
  EXPECT_EQ(m[5].end_mm, (std::array<double, 4>{80, 0, 0, 6}));
  EXPECT_EQ(out.excluded_moves, 2u);
  ASSERT_EQ(out.excluded.size(), 1u);
  EXPECT_EQ(out.excluded[0].name, "B");
  EXPECT_EQ(out.excluded[0].first_line, 2u);
}

TEST(ExcludeObject, RetractionDifferenceIsMadeUpOnLeaving) {
  // A ends retracted (E -0.8). Skipped B unretracts (+0.8), extrudes, and either retracts at
  // its end (balanced) or not. Klipper's extruder_adj on leaving = (max_excluded -
  // last_excluded E) - (max_extruded - last_extruded E): 0.8 - 0.8 = 0 when balanced, 0 - 0.8
  // when not, and it is taken up (as -offset, i.e. +0.8 of feed) by the first XY move.
  const std::string head =
      "M83\nEXCLUDE_OBJECT NAME=B\nEXCLUDE_OBJECT_START NAME=A\n"
      "G1 X10 E1 F600\nG1 X20 E1\nG1 X30 E1\nG1 X40 E1\nG1 X41 E1\nG1 E-0.8\nEXCLUDE_OBJECT_END\n"
      "EXCLUDE_OBJECT_START NAME=B\nG1 X50\nG1 E0.8\nG1 X60 E1\n";
  const std::string tail = "EXCLUDE_OBJECT_END\nG1 X100\nG1 E0.8\nG1 X110 E1\n";
  const auto balanced = run(head + "G1 E-0.8\n" + tail, exclusion());
  const auto unbalanced = run(head + tail, exclusion());
  auto feed = [](const MoveRequest& m) { return m.end_mm[3] - m.start_mm[3]; };
  const auto& b = balanced.r.moves;
  const auto& u = unbalanced.r.moves;
  ASSERT_EQ(b.size(), 9u);
  ASSERT_EQ(u.size(), 9u);
  EXPECT_EQ(b[6].start_mm, (std::array<double, 4>{41, 0, 0, 4.2}));
  EXPECT_DOUBLE_EQ(b[6].end_mm[0], 100.0);
  EXPECT_NEAR(feed(b[6]), 0.0, 1e-12);
  EXPECT_NEAR(feed(b[7]), 0.8, 1e-12);
  EXPECT_NEAR(feed(b[8]), 1.0, 1e-12);
  EXPECT_NEAR(feed(u[6]), 0.8, 1e-12);
  EXPECT_NEAR(feed(u[7]), 0.8, 1e-12);
  EXPECT_NEAR(feed(u[8]), 1.0, 1e-12);
}

TEST(ExcludeObject, CurrentWithoutAnObjectIsKlippersError) {
  EXPECT_THROW(run("EXCLUDE_OBJECT CURRENT=1\n", exclusion()), Error);
}

TEST(ExcludeObject, ResetBringsTheObjectBack) {
  const auto out =
      run("M83\nEXCLUDE_OBJECT_START NAME=A\nEXCLUDE_OBJECT CURRENT=1\n"
          "G1 X1 E1 F600\nG1 X2 E1\nG1 X3 E1\nG1 X4 E1\nG1 X5 E1\nG1 X6 E1\n"
          "EXCLUDE_OBJECT RESET=1 NAME=A\nG1 X7 E1\n",
          exclusion());
  // 5 learning moves, X6 skipped, X7 made from X5.
  ASSERT_EQ(out.r.moves.size(), 6u);
  EXPECT_DOUBLE_EQ(out.r.moves.back().start_mm[0], 5.0);
  EXPECT_DOUBLE_EQ(out.r.moves.back().end_mm[0], 7.0);
  EXPECT_EQ(out.excluded_moves, 1u);
}

// ---- IDEX
// -----------------------------------------------------------------------------------------

InterpreterOptions idex() {
  // Rails 0..250 mm; carriage 0 homes to 0, carriage 1 to 250; 50 mm apart at least.
  InterpreterOptions o;
  InterpreterOptions::DualCarriage d;
  d.axis = 0;
  d.position_min_mm = {0, 0};
  d.position_max_mm = {250, 250};
  d.position_endstop_mm = {0, 250};
  d.homing_positive_dir = {false, true};
  d.safe_distance_mm = 50.0;
  d.homing_speed_mm_s = {50.0, 40.0};
  o.dual_carriages.push_back(d);
  return o;
}

TEST(DualCarriage, SecondCarriageStartsFromItsParkingAndRangesKeepTheSafeDistance) {
  const auto out = run("G28\nG1 X10 F6000\nSET_DUAL_CARRIAGE CARRIAGE=1\nG1 X190\n", idex());
  const auto& m = out.r.moves;
  ASSERT_EQ(m.size(), 2u);
  // The toolhead's X becomes the second carriage's (parked at its endstop, 250).
  EXPECT_DOUBLE_EQ(m[1].start_mm[0], 250.0);
  EXPECT_DOUBLE_EQ(m[1].end_mm[0], 190.0);
  EXPECT_EQ(out.r.step_flushes, 1);
  // After G28: carriage 0 in [0, 250 - 50]; after the switch carriage 1 in [10 + 50, 250].
  ASSERT_GE(out.r.ranges.size(), 2u);
  EXPECT_DOUBLE_EQ(out.r.ranges.front().min_mm, 0.0);
  EXPECT_DOUBLE_EQ(out.r.ranges.front().max_mm, 200.0);
  EXPECT_DOUBLE_EQ(out.r.ranges.back().min_mm, 60.0);
  EXPECT_DOUBLE_EQ(out.r.ranges.back().max_mm, 250.0);
}

TEST(DualCarriage, CopyAndMirrorLimitTheRange) {
  // Carriage 1 parked at 190, carriage 0 at 10. COPY: carriage 1 follows at +180, so X <= 70.
  // MIRROR: carriage 1 at 200 - X; they meet 50 mm apart at X = 75.
  const std::string head =
      "G28\nG1 X10 F6000\nSET_DUAL_CARRIAGE CARRIAGE=1\nG1 X190\nSET_DUAL_CARRIAGE CARRIAGE=0\n";
  const auto copy = run(head + "SET_DUAL_CARRIAGE CARRIAGE=1 MODE=COPY\n", idex());
  EXPECT_DOUBLE_EQ(copy.r.ranges.back().min_mm, 0.0);
  EXPECT_DOUBLE_EQ(copy.r.ranges.back().max_mm, 70.0);
  const auto mirror = run(head + "SET_DUAL_CARRIAGE CARRIAGE=1 MODE=MIRROR\n", idex());
  EXPECT_DOUBLE_EQ(mirror.r.ranges.back().min_mm, 0.0);
  EXPECT_DOUBLE_EQ(mirror.r.ranges.back().max_mm, 75.0);
  EXPECT_THROW(run("G28\nSET_DUAL_CARRIAGE CARRIAGE=0 MODE=COPY\n", idex()),
               Error);  // needs another PRIMARY
}

TEST(DualCarriage, RestoreMovesTheCarriageWithTheLongerWayAtTheLowerHomingSpeed) {
  // Saved: carriage 1 at 190 (primary), carriage 0 at 10. Now carriage 0 at 60, 1 at 150:
  // carriage 0 has 50 mm to go, 1 has 40, so the move is carriage 0's, 60 -> 10 at
  // min(50, 40) mm/s; then carriage 1 is primary again at 190.
  const auto out =
      run("G28\nG1 X10 F6000\nSET_DUAL_CARRIAGE CARRIAGE=1\nG1 X190\nSAVE_DUAL_CARRIAGE_STATE\n"
          "SET_DUAL_CARRIAGE CARRIAGE=0\nG1 X60\nSET_DUAL_CARRIAGE CARRIAGE=1\nG1 X150\n"
          "RESTORE_DUAL_CARRIAGE_STATE\nG1 X200\n",
          idex());
  const auto& m = out.r.moves;
  ASSERT_EQ(m.size(), 6u);
  EXPECT_DOUBLE_EQ(m[4].start_mm[0], 60.0);
  EXPECT_DOUBLE_EQ(m[4].end_mm[0], 10.0);
  EXPECT_DOUBLE_EQ(m[4].speed_mm_s, 40.0);
  EXPECT_DOUBLE_EQ(m[5].start_mm[0], 190.0);
  EXPECT_DOUBLE_EQ(m[5].end_mm[0], 200.0);
  EXPECT_DOUBLE_EQ(out.r.ranges.back().min_mm, 60.0);
  EXPECT_THROW(run("G28\nRESTORE_DUAL_CARRIAGE_STATE NAME=x\n", idex()), Error);
}

// generic_cartesian with a dual carriage on X and one on Y (Klipper's test/klippy/corexyuv.cfg):
// carriage_x [0, 300] homing to 0 with carriage_u [0, 300] homing to 300, safe_distance 70;
// carriage_y [0, 200] homing to 0 with carriage_v [0, 200] homing to 200, safe_distance 50;
// every homing_speed 50 mm/s.
InterpreterOptions two_pairs() {
  InterpreterOptions o;
  InterpreterOptions::DualCarriage x;
  x.axis = 0;
  x.names = {"carriage_x", "carriage_u"};
  x.position_max_mm = {300, 300};
  x.position_endstop_mm = {0, 300};
  x.homing_positive_dir = {false, true};
  x.safe_distance_mm = 70.0;
  x.homing_speed_mm_s = {50.0, 50.0};
  InterpreterOptions::DualCarriage y = x;
  y.axis = 1;
  y.names = {"carriage_y", "carriage_v"};
  y.position_max_mm = {200, 200};
  y.position_endstop_mm = {0, 200};
  y.safe_distance_mm = 50.0;
  o.dual_carriages = {x, y};
  return o;
}

TEST(DualCarriage, TwoPairsByNameMoveAndRestoreTogether) {
  // corexyuv.test's sequence worked by hand with idex_modes.py's rules:
  //  G28: X = 0, Y = 0, carriage_u parked at 300, carriage_v at 200.
  //  G1 X10 Y20; carriage_u: X = 300, range [10 + 70, 300]; carriage_v: Y = 200, range
  //  [20 + 50, 200]. G1 X170 Y190 inside them.
  //  carriage_x: X = 10 (where it was parked), carriage_u parked at 170: X in [0, 170 - 70].
  //  SAVE: x primary at 20, u at 170; v primary at 190, y at 20. G1 Y150 (v to 150).
  //  carriage_y: Y = 20, v parked at 150: Y in [0, 100]. G1 X10 Y50.
  //  RESTORE: X pair: x 10 -> 20, u stays at 170: x leads. Y pair: y 50 -> 20 (30 mm),
  //  v 150 -> 190 (40 mm): v leads, Y = 150 first. One move (10, 150) -> (20, 190) at the
  //  lowest homing speed, 50 mm/s. Then X in [0, 100], Y in [190 + (20 - 190) + 50, 200] =
  //  [70, 200].
  const auto out = run(
      "G28\nG1 X10 Y20 F6000\nSET_DUAL_CARRIAGE CARRIAGE=carriage_u\n"
      "SET_DUAL_CARRIAGE CARRIAGE=carriage_v\nG1 X170 Y190 F6000\n"
      "SET_DUAL_CARRIAGE CARRIAGE=carriage_x\nG1 X20 F6000\nSAVE_DUAL_CARRIAGE_STATE\n"
      "G1 Y150 F6000\nSET_DUAL_CARRIAGE CARRIAGE=carriage_y\nG1 X10 Y50 F6000\n"
      "RESTORE_DUAL_CARRIAGE_STATE\nG1 X5\n",
      two_pairs());
  const auto& m = out.r.moves;
  ASSERT_EQ(m.size(), 7u);
  const double expect[7][4] = {{0, 0, 10, 20},    {300, 200, 170, 190}, {10, 190, 20, 190},
                               {20, 190, 20, 150}, {20, 20, 10, 50},     {10, 150, 20, 190},
                               {20, 190, 5, 190}};
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_DOUBLE_EQ(m[i].start_mm[0], expect[i][0]) << i;
    EXPECT_DOUBLE_EQ(m[i].start_mm[1], expect[i][1]) << i;
    EXPECT_DOUBLE_EQ(m[i].end_mm[0], expect[i][2]) << i;
    EXPECT_DOUBLE_EQ(m[i].end_mm[1], expect[i][3]) << i;
  }
  EXPECT_DOUBLE_EQ(m[5].speed_mm_s, 50.0);
  // Ranges: after carriage_u and carriage_v, after carriage_x, carriage_y, and the restore.
  const auto& r = out.r.ranges;
  auto find_after = [&](std::size_t from, int axis, double lo, double hi) {
    for (std::size_t i = from; i < r.size(); ++i) {
      if (r[i].axis == axis && r[i].min_mm == lo && r[i].max_mm == hi) return i;
    }
    return r.size();
  };
  std::size_t at = find_after(0, 0, 80.0, 300.0);
  ASSERT_LT(at, r.size());
  at = find_after(at, 1, 70.0, 200.0);
  ASSERT_LT(at, r.size());
  at = find_after(at, 0, 0.0, 100.0);
  ASSERT_LT(at, r.size());
  at = find_after(at, 1, 0.0, 100.0);
  ASSERT_LT(at, r.size());
  ASSERT_GE(r.size(), 2u);
  EXPECT_EQ(r[r.size() - 2].axis, 0);
  EXPECT_DOUBLE_EQ(r[r.size() - 2].min_mm, 0.0);
  EXPECT_DOUBLE_EQ(r[r.size() - 2].max_mm, 100.0);
  EXPECT_EQ(r.back().axis, 1);
  EXPECT_DOUBLE_EQ(r.back().min_mm, 70.0);
  EXPECT_DOUBLE_EQ(r.back().max_mm, 200.0);
}

TEST(DualCarriage, CarriageNamesAsKlipperTakesThem) {
  // Two pairs: only the names (as written); one named pair: the names or 0 / 1.
  EXPECT_THROW(run("G28\nSET_DUAL_CARRIAGE CARRIAGE=1\n", two_pairs()), Error);
  EXPECT_THROW(run("G28\nSET_DUAL_CARRIAGE CARRIAGE=Carriage_U\n", two_pairs()), Error);
  EXPECT_THROW(run("G28\nSET_DUAL_CARRIAGE CARRIAGE=dual_carriage\n", two_pairs()), Error);
  InterpreterOptions one = two_pairs();
  one.dual_carriages.pop_back();
  const auto by_index = run("G28\nSET_DUAL_CARRIAGE CARRIAGE=1\nG1 X200 F6000\n", one);
  const auto by_name = run("G28\nSET_DUAL_CARRIAGE CARRIAGE=carriage_u\nG1 X200 F6000\n", one);
  ASSERT_EQ(by_index.r.moves.size(), 1u);
  ASSERT_EQ(by_name.r.moves.size(), 1u);
  EXPECT_DOUBLE_EQ(by_index.r.moves[0].start_mm[0], 300.0);  // carriage_u parked at 300
  EXPECT_DOUBLE_EQ(by_name.r.moves[0].start_mm[0], 300.0);
  // Y has no pair here: carriage_v is not a carriage of this printer.
  EXPECT_THROW(run("G28\nSET_DUAL_CARRIAGE CARRIAGE=carriage_v\n", one), Error);
}

TEST(DualCarriage, BeforeHomingTheFirstCarriageIsActive) {
  // idex_modes.py starts each pair with the first carriage PRIMARY (scale 1) and the second
  // parked at 0: switching before G28 and back leaves X where it was.
  const auto out = run(
      "SET_KINEMATIC_POSITION X=40 Y=0 Z=0\nSET_DUAL_CARRIAGE CARRIAGE=carriage_u\n"
      "SET_DUAL_CARRIAGE CARRIAGE=carriage_x\nG1 X50 F6000\n",
      two_pairs());
  ASSERT_EQ(out.r.moves.size(), 1u);
  EXPECT_DOUBLE_EQ(out.r.moves[0].start_mm[0], 40.0);
}

TEST(DualCarriage, WithoutTheSectionTheCommandsAreUnknown) {
  const auto out = run("SET_DUAL_CARRIAGE CARRIAGE=1\nG1 X10 F600\n");
  ASSERT_EQ(out.unknown.size(), 1u);
  EXPECT_EQ(out.unknown[0].name, "SET_DUAL_CARRIAGE");
}

}  // namespace
}  // namespace amctl::gcode
