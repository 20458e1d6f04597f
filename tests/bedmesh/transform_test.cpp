// The mesh's move transform (docs/bedmesh.md section 3) against closed forms: where a move
// is split, the z of every piece, fade, the inverse after homing, BED_MESH_CLEAR; then the
// whole stream (a printer.cfg with a saved mesh, macros, errors with FILE:LINE:COL).
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/bedmesh/config.hpp"
#include "amctl/bedmesh/transform.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::bedmesh {
namespace {

struct Recorder final : gcode::EventSink {
  std::vector<gcode::MoveRequest> moves;
  std::vector<std::array<double, 4>> positions;
  void on_move(const gcode::MoveRequest& m) override { moves.push_back(m); }
  void on_set_position(const std::array<double, 4>& p, std::uint64_t) override { positions.push_back(p); }
};

/// z = a + b x + c y on a 3x3 lagrange grid over [0, 200]^2 (exact everywhere).
Settings plane_settings(double a, double b, double c) {
  Settings s;
  Profile p;
  p.name = "default";
  p.params = {0.0, 200.0, 0.0, 200.0, 3, 3, 2, 2, Algorithm::lagrange, 0.2};
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) p.points_mm.push_back(a + b * 100.0 * i + c * 100.0 * j);
  }
  s.profiles.push_back(p);
  return s;
}

gcode::BedMeshCommand load(const std::string& name) {
  gcode::BedMeshCommand c;
  c.kind = gcode::BedMeshCommand::Kind::load;
  c.profile = name;
  c.line = 7;
  c.column = 23;
  return c;
}

gcode::MoveRequest move(std::array<double, 4> from, std::array<double, 4> to) {
  gcode::MoveRequest m;
  m.start_mm = from;
  m.end_mm = to;
  m.speed_mm_s = 100.0;
  m.line = 9;
  return m;
}

TEST(BedMeshTransform, WithoutALoadedProfileMovesPassUnchanged) {
  Recorder r;
  MeshTransform t(plane_settings(0.1, 1e-3, 0.0), r);
  t.on_move(move({0, 0, 0.2, 0}, {150, 30, 0.2, 5}));
  ASSERT_EQ(r.moves.size(), 1u);
  EXPECT_EQ(r.moves[0].end_mm, (std::array<double, 4>{150, 30, 0.2, 5}));
}

TEST(BedMeshTransform, SplitsWhereTheMeshRisesBySplitDeltaZAndAddsItsZToEveryPiece) {
  // Slope 0.004 along X: 0.02 mm per 5 mm check, so a split every second check (0.04 >= 0.025),
  // i.e. every 10 mm; a 47 mm move has checks at 5..45 mm and pieces ending at 10, 20, 30,
  // 40 mm and at its end.
  Recorder r;
  MeshTransform t(plane_settings(0.05, 0.004, 0.0), r);
  t.on_set_position({3, 50, 0, 0}, 1);
  t.on_bed_mesh(load("default"));
  t.on_move(move({3, 50, 0, 0}, {3, 50, 0.3, 0}));  // Z only: no split, the mesh's z added
  ASSERT_EQ(r.moves.size(), 1u);
  EXPECT_NEAR(r.moves[0].end_mm[2], 0.3 + 0.05 + 0.004 * 3, 1e-12);
  t.on_move(move({3, 50, 0.3, 0}, {50, 50, 0.3, 4.7}));
  ASSERT_EQ(r.moves.size(), 6u);
  const double xs[5] = {13, 23, 33, 43, 50};
  for (std::size_t k = 0; k < 5; ++k) {
    const gcode::MoveRequest& m = r.moves[k + 1];
    EXPECT_NEAR(m.end_mm[0], xs[k], 1e-12);
    EXPECT_NEAR(m.end_mm[2], 0.3 + 0.05 + 0.004 * xs[k], 1e-12);
    EXPECT_NEAR(m.end_mm[3], 4.7 * (xs[k] - 3) / 47, 1e-12);  // E shared by length
    EXPECT_EQ(m.start_mm, r.moves[k].end_mm);
    EXPECT_EQ(m.line, 9u);
  }
  EXPECT_EQ(t.stats().moves_in, 2u);
  EXPECT_EQ(t.stats().pieces_out, 6u);
}

TEST(BedMeshTransform, AFlatMeshOnlyShiftsZAndAMoveAlongAContourIsNotSplit) {
  Recorder r;
  MeshTransform t(plane_settings(-0.07, 0.0, 0.002), r);
  t.on_bed_mesh(load("default"));
  t.on_move(move({0, 0, 0, 0}, {180, 40, 0.2, 0}));  // z depends on y only: 0.08 over 40 mm
  t.on_move(move({180, 40, 0.2, 0}, {10, 40, 0.2, 0}));  // along a contour: no split
  ASSERT_GE(r.moves.size(), 2u);
  const gcode::MoveRequest& last = r.moves.back();
  EXPECT_EQ(last.start_mm[0], 180);
  EXPECT_NEAR(last.end_mm[2], 0.2 - 0.07 + 0.08, 1e-12);
}

TEST(BedMeshTransform, FadeScalesTheMeshBetweenFadeStartAndFadeEnd) {
  Settings s = plane_settings(0.2, 0.0, 0.0);  // a constant mesh of 0.2 mm
  s.fade_start_mm = 1.0;
  s.fade_end_mm = 5.0;
  s.fade_target_mm = 0.0;
  Recorder r;
  MeshTransform t(s, r);
  t.on_bed_mesh(load("default"));
  EXPECT_DOUBLE_EQ(t.fade_factor(0.5), 1.0);
  EXPECT_DOUBLE_EQ(t.fade_factor(2.0), 0.75);
  EXPECT_DOUBLE_EQ(t.fade_factor(5.0), 0.0);
  EXPECT_NEAR(t.adjusted_z(50, 50, 0.5), 0.7, 1e-15);
  EXPECT_NEAR(t.adjusted_z(50, 50, 3.0), 3.0 + 0.2 * 0.5, 1e-15);
  EXPECT_NEAR(t.adjusted_z(50, 50, 6.0), 6.0, 1e-15);
  // Without a fade_target the mesh's average (0.2) is the level fade converges to.
  Settings avg = s;
  avg.fade_target_mm.reset();
  MeshTransform ta(avg, r);
  ta.on_bed_mesh(load("default"));
  EXPECT_NEAR(ta.adjusted_z(50, 50, 6.0), 6.2, 1e-15);
}

TEST(BedMeshTransform, HomingWithAMeshKeepsTheGcodeZOfTheToolhead) {
  // After set_position the G-code Z is the toolhead's minus the mesh there: a move that does
  // not change Z keeps the toolhead's height above the bed, z_gcode + mesh(x, y).
  Recorder r;
  MeshTransform t(plane_settings(0.0, 0.001, 0.0), r);
  t.on_bed_mesh(load("default"));
  t.on_set_position({100, 100, 10, 0}, 3);  // mesh 0.1 here: G-code Z 9.9
  t.on_move(move({100, 100, 10, 0}, {0, 100, 10, 0}));
  EXPECT_NEAR(r.moves.back().end_mm[2], 9.9 + 0.0, 1e-12);
  t.on_move(move({0, 100, 10, 0}, {0, 100, 0.3, 0}));  // Z given: the mesh adds its 0
  EXPECT_NEAR(r.moves.back().end_mm[2], 0.3, 1e-12);
}

TEST(BedMeshTransform, ClearLeavesTheToolheadWhereItIsAndLaterMovesPlain) {
  Recorder r;
  MeshTransform t(plane_settings(0.15, 0.0, 0.0), r);
  t.on_bed_mesh(load("default"));
  t.on_move(move({0, 0, 0, 0}, {10, 10, 1, 0}));
  EXPECT_NEAR(r.moves.back().end_mm[2], 1.15, 1e-12);
  gcode::BedMeshCommand clear;
  clear.kind = gcode::BedMeshCommand::Kind::clear;
  t.on_bed_mesh(clear);
  t.on_move(move({10, 10, 1, 0}, {20, 10, 1, 0}));  // Z unchanged: stays at 1.15
  EXPECT_NEAR(r.moves.back().end_mm[2], 1.15, 1e-12);
  t.on_move(move({20, 10, 1, 0}, {20, 10, 2, 0}));
  EXPECT_EQ(r.moves.back().end_mm[2], 2.0);
  t.on_move(move({20, 10, 2, 0}, {30, 10, 2, 0}));
  EXPECT_EQ(r.moves.back().start_mm, (std::array<double, 4>{20, 10, 2, 0}));
}

TEST(BedMeshTransform, UnknownProfileIsKlippersErrorAtTheCommand) {
  Recorder r;
  MeshTransform t(plane_settings(0, 0, 0), r);
  try {
    t.on_bed_mesh(load("nope"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.where().line, 7u);
    EXPECT_EQ(e.where().column, 23u);
    EXPECT_NE(e.detail().find("bed_mesh: Unknown profile [nope]"), std::string::npos) << e.detail();
  }
}

std::string write(const std::string& name, const std::string& text) {
  const std::string path = std::string(AMCTL_BINARY_DIR) + "/" + name;
  std::ofstream(path) << text;
  return path;
}

const char* kCfg =
    "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\nmax_z_velocity: 5\n"
    "max_z_accel: 100\n"
    "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 250\n"
    "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 250\n"
    "[stepper_z]\nrotation_distance: 8\nmicrosteps: 16\nposition_min: -2\nposition_max: 250\n"
    "[extruder]\nnozzle_diameter: 0.4\nfilament_diameter: 1.75\nrotation_distance: 22\nmicrosteps: 16\n"
    "[bed_mesh]\nmesh_min: 0, 0\nmesh_max: 200, 200\nprobe_count: 3, 3\n"
    "[gcode_macro START]\ngcode:\n  BED_MESH_PROFILE LOAD={params.MESH}\n"
    "#*# <---------------------- SAVE_CONFIG ---------------------->\n"
    "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n"
    "#*#\n"
    "#*# [bed_mesh tilt]\n#*# version = 1\n#*# points =\n"
    "#*# \t  0.000000, 0.200000, 0.400000\n#*# \t  0.000000, 0.200000, 0.400000\n"
    "#*# \t  0.000000, 0.200000, 0.400000\n"
    "#*# min_x = 0.0\n#*# max_x = 200.0\n#*# min_y = 0.0\n#*# max_y = 200.0\n#*# x_count = 3\n"
    "#*# y_count = 3\n#*# mesh_x_pps = 2\n#*# mesh_y_pps = 2\n#*# algo = lagrange\n#*# tension = 0.2\n";

std::vector<plan::PlannedMove> plan_text(const machine::Machine& m, const std::string& gcode) {
  plan::PlanSource src(gcode, "in.gcode", m);
  std::vector<plan::PlannedMove> out;
  plan::PlanBatch b;
  while (src.next(b)) out.insert(out.end(), b.moves.begin(), b.moves.end());
  return out;
}

TEST(BedMeshStream, AProfileLoadedInAMacroMakesZFollowTheMeshAndTakesMoreTime) {
  const machine::Machine m = machine::load_machine(write("bedmesh_stream.cfg", kCfg));
  const std::string body = "G1 X0 Y100 Z0.2 F6000\nG1 X200 E10 F3000\n";
  const auto plain = plan_text(m, "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\n" + body);
  const auto meshed = plan_text(m, "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nSTART MESH=tilt\n" + body);
  ASSERT_EQ(plain.size(), 2u);
  // z = 0.002 x: 0.01 per 5 mm check, a split at every third check (0.03 >= 0.025), so a
  // piece every 15 mm: 13 pieces and the rest for the 200 mm move.
  ASSERT_EQ(meshed.size(), 1u + 14u);
  for (std::size_t k = 1; k < meshed.size(); ++k) {
    const auto& pm = meshed[k];
    const double x_end = pm.start_mm[0] + pm.axes_r[0] * pm.distance_mm;
    const double z_end = pm.start_mm[2] + pm.axes_r[2] * pm.distance_mm;
    EXPECT_NEAR(z_end, 0.2 + 0.002 * x_end, 1e-9);
  }
  const double t_plain = plain.back().end_time_s(), t_mesh = meshed.back().end_time_s();
  EXPECT_GT(t_mesh, t_plain);  // the pieces meet at junctions below the cruise speed
}

TEST(BedMeshStream, FadeEndNotAboveFadeStartTurnsFadeOffAsKlipperDoes) {
  std::string cfg = kCfg;
  const std::string probe = "probe_count: 3, 3\n";
  cfg.replace(cfg.find(probe), probe.size(), probe + "fade_start: 1\nfade_end: 0.5\n");
  const machine::Machine m = machine::load_machine(write("bedmesh_stream_fade.cfg", cfg));
  const auto settings = read_klipper(m.klipper_config, SourceLocation{m.name, 0, 0});
  ASSERT_TRUE(settings.has_value());
  EXPECT_FALSE(settings->fade_enabled);
  EXPECT_NE(to_text(*settings).find("Klipper disables fade"), std::string::npos) << to_text(*settings);
  // At 5 mm, far above fade_end, the mesh still applies in full: z = 5 + 0.002 x.
  const auto meshed = plan_text(m, "SET_KINEMATIC_POSITION X=0 Y=0 Z=0\nSTART MESH=tilt\n"
                                   "G1 X0 Y100 Z5 F6000\nG1 X200 F3000\n");
  const auto& last = meshed.back();
  EXPECT_NEAR(last.start_mm[2] + last.axes_r[2] * last.distance_mm, 5.0 + 0.002 * 200.0, 1e-9);
}

TEST(BedMeshStream, BadMeshInputNamesFileLineAndColumn) {
  const machine::Machine m = machine::load_machine(write("bedmesh_stream2.cfg", kCfg));
  try {
    (void)plan_text(m, "G1 X1\nBED_MESH_PROFILE LOAD=flat\n");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("in.gcode:2:23: bed_mesh: Unknown profile [flat]", 0), 0u) << e.what();
  }
}

}  // namespace
}  // namespace amctl::bedmesh
