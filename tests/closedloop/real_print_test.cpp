// The closed loop on real prints, a representative subset of scripts/closedloop_sweep.py
// (docs/closedloop.md, section 4.3): the print the issue found diverging (a PrusaSlicer box on
// the Voron V0 config, 16000 mm/s^2) and the corner example on a bed slinger and a CoreXY
// preset, open loop and every controller. The figures the closed loop is held to:
//   - no controller loses a step where open loop loses none;
//   - feedforward's maximum and rms tracking error are at most open loop's on each axis;
//   - feedforward never runs at the drive's step-rate cap.
#include <cstdio>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "amctl/closedloop/simulate.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"
#include "amctl/steppers/shaped_steps.hpp"
#include "amctl/trajectory/build.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::closedloop {
namespace {

std::string fmt_line(double x, double y) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "G1 X%.3f Y%.3f\n", x, y);
  return buf;
}

void check_print(const std::string& gcode, const machine::Machine& m) {
  std::map<ControllerKind, SimulationResult> r;
  for (ControllerKind k : all_controllers()) {
    SimulationOptions o;
    o.controller = k;
    o.gains.max_accel_mm_s2 = m.max_accel_mm_s2;
    r[k] = simulate_file(gcode, m, o);
  }
  const SimulationResult& open = r[ControllerKind::open];
  for (std::size_t i = 0; i < open.axes.size(); ++i) {
    const AxisResult& o = open.axes[i];
    for (ControllerKind k : all_controllers()) {
      const AxisResult& a = r[k].axes[i];
      if (o.lost_full_steps == 0) {
        EXPECT_EQ(a.lost_full_steps, 0u) << to_string(k) << " axis " << a.name << " " << gcode;
      }
    }
    const AxisResult& ff = r[ControllerKind::feedforward].axes[i];
    EXPECT_LE(ff.max_tracking_error_mm, o.max_tracking_error_mm) << ff.name << " " << gcode;
    EXPECT_LE(ff.rms_tracking_error_mm, o.rms_tracking_error_mm) << ff.name << " " << gcode;
    EXPECT_EQ(ff.step_rate_limited_periods, 0u) << ff.name << " " << gcode;
  }
}

TEST(RealPrints, TheBoxOnTheVoronV0HoldsWithEveryController) {
  const std::string src = AMCTL_SOURCE_DIR;
  check_print(src + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
              machine::load_machine(src + "/configs/klipper-voron-v0.cfg"));
}

// The box on the creality-k1 preset (20 000 mm/s^2, a CoreXY whose motor axes see 28 300
// mm/s^2 on a 72 mm pulley): the first move needs more torque than the motor has at the design
// angle (open loop itself slips on A); on B, before the lead cap, feedforward slipped a cycle
// on a move the governor passed (its lead over the carriage grew past what the rotor and the
// belt hold).
TEST(RealPrints, TheBoxOnTheCrealityK1HoldsWithEveryController) {
  const std::string src = AMCTL_SOURCE_DIR;
  check_print(src + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode",
              machine::load_machine("creality-k1"));
}

TEST(RealPrints, TheCornerHoldsOnABedSlingerAndACoreXY) {
  const std::string src = AMCTL_SOURCE_DIR;
  for (const char* preset : {"ender3", "voron24"}) {
    check_print(src + "/examples/30_belt_corner.gcode", machine::load_machine(preset));
  }
}

// On a machine with an input shaper the reference is the shaped plan: every sample of the
// trace's reference equals the convolution sum_i a_i x(t - d_i) evaluated here on plain cursors
// over the whole plan (a second method: no window, no streaming).
// The Cura benchy's first 5000 lines (its first layers, 336 s of print: short moves whose
// acceleration flips at 65-80 Hz, above the axis's mode) on the two presets where the static
// lead cap was not enough: on bambu-p1 feedforward swung the command at the belt mode and
// slipped 8 full steps (open loop none), on creality-k1 its maximum and rms exceeded open
// loop's. The rotor's dynamic bound holds both. From the shared corpus: skipped without it.
TEST(RealPrints, TheCuraBenchysFirstLayersHoldOnBambuP1AndCrealityK1) {
  const std::string corpus = "/work/shared/corpus/gcode/benchy_cura-5.3.gcode";
  std::ifstream in(corpus);
  if (!in) GTEST_SKIP() << corpus << " is not here (the shared corpus): nothing to check";
  const std::string head = (std::filesystem::temp_directory_path() /
                            ("amctl_cura_head_" + std::to_string(::getpid()) + ".gcode")).string();
  {
    std::ofstream out(head);
    std::string line;
    for (int n = 0; n < 5000 && std::getline(in, line); ++n) out << line << '\n';
  }
  for (const char* preset : {"bambu-p1", "creality-k1"}) {
    check_print(head, machine::load_machine(preset));
  }
  std::filesystem::remove(head);
}

TEST(RealPrints, OnAShapedMachineTheReferenceIsTheShapedPlan) {
  const machine::Machine m = machine::load_machine("prusa-mini");
  ASSERT_TRUE(m.input_shaper.active());
  std::vector<trajectory::MoveSpec> specs(3);
  specs[0].to_mm = {30.0, 0.0, 0.0, 0.0};
  specs[1].to_mm = {30.0, 20.0, 0.0, 0.0};
  specs[1].end_v_mm_s = 10.0;
  specs[2].to_mm = {0.0, 5.0, 0.0, 0.0};
  std::vector<plan::PlannedMove> moves =
      trajectory::chain_moves({0, 0, 0, 0}, specs, m.max_accel_mm_s2, plan::VelocityProfile::trapezoid);
  for (std::size_t k = 0; k < moves.size(); ++k) moves[k].line = k + 1;
  const std::string csv = (std::filesystem::temp_directory_path() /
                           ("amctl_shaped_ref_" + std::to_string(::getpid()) + ".csv")).string();
  SimulationOptions o;
  o.csv_path = csv;
  (void)simulate_moves(moves, m, o);
  const shaping::AxisShapers sh = steppers::axis_shapers(m.input_shaper);
  const shaping::AppliedPulses px = shaping::applied_pulses(*sh.xyz[0]);
  const shaping::AppliedPulses py = shaping::applied_pulses(*sh.xyz[1]);
  const double t0 = moves.front().start_time_s;
  auto conv = [&](const shaping::AppliedPulses& p, int axis, double t) {
    double x = 0.0;
    for (std::size_t i = 0; i < p.weights.size(); ++i) {
      trajectory::Cursor c(moves);
      x += p.weights[i] * c.evaluate(t0 + t - p.delays_s[i]).pos_mm[axis];
    }
    return x;
  };
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  int rows = 0;
  double moved = 0.0;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
    ASSERT_GE(v.size(), 9u);
    EXPECT_NEAR(v[1], conv(px, 0, v[0]), 1e-5) << "x at " << v[0];  // the CSV's 6 decimals
    EXPECT_NEAR(v[8], conv(py, 1, v[0]), 1e-5) << "y at " << v[0];
    moved = std::max(moved, std::abs(v[1] - trajectory::Cursor(moves).evaluate(t0 + v[0]).pos_mm[0]));
    ++rows;
  }
  std::remove(csv.c_str());
  EXPECT_GT(rows, 100);
  EXPECT_GT(moved, 1e-3);  // the shaper did move the reference off the plan
}

// The same through the plan stream, over many batches (the window keeps the shaper's
// look-behind across batches and runs each to its end less the look-ahead): a zigzag of 9000
// short moves read from G-code on the shaped preset.
TEST(RealPrints, TheShapedReferenceHoldsAcrossThePlanStreamsBatches) {
  const machine::Machine m = machine::load_machine("prusa-mini");
  std::string gcode = "G21\nG90\nG1 X10 Y10 F6000\n";
  for (int k = 0; k < 9000; ++k) {
    gcode += fmt_line(10.0 + 2.0 * (k % 2), 10.0 + 0.05 * k);
  }
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("amctl_shaped_zigzag_" + std::to_string(::getpid()) + ".gcode")).string();
  std::ofstream(path) << gcode;
  // The plan, collected whole.
  struct Collect final : plan::Sink {
    std::vector<plan::PlannedMove> moves;
    std::size_t batches = 0;
    void consume(const plan::PlanBatch& b) override {
      moves.insert(moves.end(), b.moves.begin(), b.moves.end());
      ++batches;
    }
  } all;
  {
    plan::PlanSource src(path, m);
    plan::Sink* sinks[] = {&all};
    plan::run_pipeline(src, sinks);
  }
  ASSERT_GE(all.batches, 3u);
  const std::string csv = path + ".csv";
  SimulationOptions o;
  o.csv_path = csv;
  (void)simulate_file(path, m, o);
  const shaping::AxisShapers sh = steppers::axis_shapers(m.input_shaper);
  const shaping::AppliedPulses p[2] = {shaping::applied_pulses(*sh.xyz[0]), shaping::applied_pulses(*sh.xyz[1])};
  std::vector<trajectory::Cursor> cur[2];
  for (int a = 0; a < 2; ++a) {
    for (std::size_t i = 0; i < p[a].weights.size(); ++i) cur[a].emplace_back(all.moves);
  }
  const double t0 = all.moves.front().start_time_s;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  int rows = 0;
  double worst = 0.0;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
    for (int a = 0; a < 2; ++a) {
      double x = 0.0;
      for (std::size_t i = 0; i < p[a].weights.size(); ++i) {
        x += p[a].weights[i] * cur[a][i].evaluate(t0 + v[0] - p[a].delays_s[i]).pos_mm[a];
      }
      worst = std::max(worst, std::abs(v[a == 0 ? 1 : 8] - x));
    }
    ++rows;
  }
  std::remove(csv.c_str());
  std::remove(path.c_str());
  EXPECT_GT(rows, 1000);
  EXPECT_LT(worst, 1e-5);  // the CSV's 6 decimals
}

}  // namespace
}  // namespace amctl::closedloop
