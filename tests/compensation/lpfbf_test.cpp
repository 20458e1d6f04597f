// LPFBF (docs/compensation.md, section 3): the receding horizon against the global FBF on the
// seed base case, continuity at the window boundaries, bounded memory, bad input.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "amctl/compensation/compensate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::compensation {
namespace {

const std::string kGcode = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner.gcode";
const std::string kPrinter = std::string(AMCTL_SOURCE_DIR) + "/examples/30_belt_corner_printer.cfg";

std::vector<plan::PlannedMove> seed_plan() {
  const machine::Machine m = machine::load_machine(kPrinter, {});
  plan::PlanSource source(kGcode, m);
  plan::CollectSink collect;
  std::vector<plan::Sink*> sinks{&collect};
  plan::run_pipeline(source, sinks);
  return collect.moves;
}

CompensationOptions seed(Method method) {
  CompensationOptions o;
  o.method = method;
  o.model_x = o.model_y = o.plant_x = o.plant_y = dynamics::AxisModel::belt_rad_s(100.0, 0.5);
  return o;
}

double max_step_mm(const CompensationResult& r) {
  double s = 0.0;
  for (std::size_t k = 0; k + 1 < r.t_s.size(); ++k)
    s = std::max(s, std::hypot(r.x_cmd_mm[k + 1] - r.x_cmd_mm[k], r.y_cmd_mm[k + 1] - r.y_cmd_mm[k]));
  return s;
}

double max_diff_mm(const CompensationResult& a, const CompensationResult& b) {
  double d = 0.0;
  for (std::size_t k = 0; k < a.t_s.size(); ++k)
    d = std::max(d, std::hypot(a.x_cmd_mm[k] - b.x_cmd_mm[k], a.y_cmd_mm[k] - b.y_cmd_mm[k]));
  return d;
}

// The seed's settling time 4 / (zeta w) is 0.08 s. With a window of 4 settling times (the
// default) the receding horizon reproduces the global optimum to 1e-5 mm in the command.
TEST(Lpfbf, LongWindowEqualsFbfOnTheSeedBaseCase) {
  const auto moves = seed_plan();
  const CompensationResult fbf = compensate(moves, seed(Method::fbf));
  CompensationOptions o = seed(Method::lpfbf);
  o.window_s = 0.32;
  o.overlap_s = 0.16;
  const CompensationResult lp = compensate(moves, o);
  ASSERT_EQ(lp.status, compensation::CompensationStatus::ok);
  ASSERT_EQ(lp.t_s.size(), fbf.t_s.size());
  EXPECT_LT(max_diff_mm(lp, fbf), 1e-5);
  EXPECT_NEAR(lp.max_tracking_error_mm, fbf.max_tracking_error_mm, 1e-5);
  EXPECT_LE(lp.max_tracking_error_mm, 0.1 * lp.uncompensated_max_tracking_error_mm);
  // At rest at the start and the end positions.
  EXPECT_DOUBLE_EQ(lp.x_cmd_mm.front(), lp.x_des_mm.front());
  EXPECT_NEAR(lp.x_cmd_mm.back(), lp.x_des_mm.back(), 1e-12);
  EXPECT_NEAR(lp.y_cmd_mm.back(), lp.y_des_mm.back(), 1e-12);
}

// Short windows (1.25 settling times, half overlap): many windows, still <= 10 % of the
// uncompensated error, and the command has no jump at the window boundaries (its largest
// sample-to-sample step is within 5 % of the global FBF's).
TEST(Lpfbf, ShortWindowsStayAccurateAndContinuous) {
  const auto moves = seed_plan();
  const CompensationResult fbf = compensate(moves, seed(Method::fbf));
  CompensationOptions o = seed(Method::lpfbf);
  o.window_s = 0.1;
  o.overlap_s = 0.05;
  const CompensationResult lp = compensate(moves, o);
  ASSERT_EQ(lp.status, compensation::CompensationStatus::ok);
  EXPECT_GE(lp.windows, 6U);
  EXPECT_LE(lp.max_tracking_error_mm, 0.1 * lp.uncompensated_max_tracking_error_mm);
  EXPECT_LE(max_step_mm(lp), 1.05 * max_step_mm(fbf));
  EXPECT_LT(max_diff_mm(lp, fbf), 0.05);
}

// Bounded memory: an axis holds the window, the p knots it waits for and one step, whatever
// the plan's length.
TEST(Lpfbf, HeldSamplesBoundedByTheWindow) {
  const auto moves = seed_plan();
  CompensationOptions o = seed(Method::lpfbf);
  o.window_s = 0.1;
  o.overlap_s = 0.05;
  const CompensationResult lp = compensate(moves, o);
  const double T = lp.knot_spacing_s;
  const std::size_t q = static_cast<std::size_t>(std::llround(T * 1000.0));
  const std::size_t nw = static_cast<std::size_t>(std::llround(lp.window_s / T));
  const std::size_t step = nw - static_cast<std::size_t>(std::llround(lp.overlap_s / T));
  EXPECT_LE(lp.max_held_samples, (nw + static_cast<std::size_t>(lp.degree) + step) * q + 2);
  EXPECT_LT(lp.max_held_samples, lp.t_s.size());
}

TEST(Lpfbf, BadWindowAndOverlapNameTheParameter) {
  const auto moves = seed_plan();
  CompensationOptions o = seed(Method::lpfbf);
  o.window_s = 0.05;  // < 0.08 s settling
  try {
    (void)compensate(moves, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--window-s"), std::string::npos) << e.what();
  }
  o.window_s = 0.2;
  o.overlap_s = 0.2;
  try {
    (void)compensate(moves, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--overlap-s"), std::string::npos) << e.what();
  }
  o.overlap_s = 0.0;  // no preview: the kept command is blind to the path ahead
  try {
    (void)compensate(moves, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--overlap-s 0 is shorter than half"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amctl::compensation

namespace amctl::compensation {
namespace {

std::vector<std::vector<double>> read_csv(const std::string& path) {
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);
  std::vector<std::vector<double>> rows;
  while (std::getline(f, line)) {
    std::vector<double> row;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

// The stream (the CLI's path) writes the command the in-memory LPFBF computes, checks it on
// the plant to the same error, and leaves no .part behind.
TEST(LpfbfStream, EqualsInMemoryLpfbfOnTheSeed) {
  const machine::Machine m = machine::load_machine(kPrinter, {});
  CompensationOptions o = seed(Method::lpfbf);
  o.window_s = 0.1;
  o.overlap_s = 0.05;
  const CompensationResult mem = compensate(seed_plan(), o);
  const std::string csv = ::testing::TempDir() + "lpfbf_stream_seed.csv";
  const CompensationResult st = compensate_file_streaming(kGcode, m, o, csv);
  EXPECT_FALSE(std::filesystem::exists(csv + ".part"));
  const auto rows = read_csv(csv);
  ASSERT_EQ(rows.size(), mem.t_s.size());
  EXPECT_EQ(st.samples, mem.t_s.size());
  double d = 0.0, ds = 0.0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    d = std::max({d, std::abs(rows[k][1] - mem.x_cmd_mm[k]), std::abs(rows[k][2] - mem.y_cmd_mm[k])});
    ds = std::max({ds, std::abs(rows[k][5] - mem.x_sim_mm[k]), std::abs(rows[k][6] - mem.y_sim_mm[k])});
  }
  EXPECT_LT(d, 1e-9);   // CSV rounding (12 significant digits)
  EXPECT_LT(ds, 1e-8);  // the streamed plant against dynamics::Simulator
  EXPECT_NEAR(st.max_tracking_error_mm, mem.max_tracking_error_mm, 1e-8);
  EXPECT_NEAR(st.max_contour_error_mm, mem.max_contour_error_mm, 1e-8);
  // The plan sampled at 1 kHz as the uncompensated command, against the exact plan.
  EXPECT_NEAR(st.uncompensated_max_tracking_error_mm, mem.uncompensated_max_tracking_error_mm, 2e-3);
  EXPECT_EQ(st.windows, mem.windows);
}

// A whole print (809 s, 810 000 samples): the samples held by an axis stay those of one
// window (plus p knots and a step), the moves held those of the contour search (65 behind)
// plus the ones the held samples span; a small fraction of the print's moves.
TEST(LpfbfStream, WholePrintInBoundedMemory) {
  const machine::Machine m =
      machine::load_machine(std::string(AMCTL_SOURCE_DIR) + "/configs/klipper-voron-v0.cfg", {});
  CompensationOptions o;
  o.method = Method::lpfbf;
  o.model_x = o.model_y = o.plant_x = o.plant_y = dynamics::AxisModel::belt(40.0, 0.1);
  const std::string csv = ::testing::TempDir() + "lpfbf_stream_boxboss.csv";
  const CompensationResult r = compensate_file_streaming(
      std::string(AMCTL_SOURCE_DIR) + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode", m, o, csv);
  // The command is judged against the V0's max_accel (16000 mm/s^2): a 40 Hz / zeta 0.1 belt
  // needs more at the print's 8000 mm/s^2 infill ramps.
  ASSERT_TRUE(r.status == compensation::CompensationStatus::ok || r.status == compensation::CompensationStatus::machine_accel_limit_exceeded) << compensation::to_string(r.status);
  EXPECT_EQ(r.machine_accel_limit_mm_s2, 16000.0);
  EXPECT_EQ(r.status == compensation::CompensationStatus::ok, r.peak_command_accel_mm_s2 <= 16000.0) << r.peak_command_accel_mm_s2;
  EXPECT_GT(r.samples, 800000U);
  const std::size_t q = static_cast<std::size_t>(std::llround(r.knot_spacing_s * 1000.0));
  const std::size_t nw = static_cast<std::size_t>(std::llround(r.window_s / r.knot_spacing_s));
  const std::size_t step = nw - static_cast<std::size_t>(std::llround(r.overlap_s / r.knot_spacing_s));
  EXPECT_LE(r.max_held_samples, (nw + static_cast<std::size_t>(r.degree) + step) * q + 2);
  // Moves: the 65 of the contour search plus at most those meeting one span of the held
  // samples (counted on the whole plan here, which the stream never holds).
  const machine::Machine mm = m;
  plan::PlanSource source(std::string(AMCTL_SOURCE_DIR) + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode", mm);
  plan::CollectSink collect;
  std::vector<plan::Sink*> sinks{&collect};
  plan::run_pipeline(source, sinks);
  std::vector<plan::PlannedMove> xy;
  for (const auto& mv : collect.moves)
    if (!mv.extrude_only && mv.distance_mm > 0.0) xy.push_back(mv);
  const double span_s = static_cast<double>(r.max_held_samples + 1) / 1000.0;
  std::size_t most = 0, lo = 0;
  for (std::size_t hi = 0; hi < xy.size(); ++hi) {  // moves starting within span_s of one ending
    while (xy[hi].start_time_s - xy[lo].end_time_s() > span_s) ++lo;
    most = std::max(most, hi - lo + 1);
  }
  EXPECT_LE(r.max_held_moves, 65 + most) << "most moves in one window span: " << most;
  EXPECT_LT(r.max_held_moves, xy.size() / 100);
  EXPECT_LE(r.max_tracking_error_mm, 0.1 * r.uncompensated_max_tracking_error_mm);
  std::filesystem::remove(csv);
}

}  // namespace
}  // namespace amctl::compensation

namespace amctl::compensation {
namespace {

// Robust FBF on the seed base case, the plant's frequency off by -20 .. +20 %: its worst case
// over +-20 % is below FBF's (0.195 against 0.218 mm), at a cost in nominal accuracy (28 um
// against 6.3 um, still <= 10 % of the uncompensated 0.469 mm). It is not better everywhere:
// on the stiff side (+10, +20 %) FBF is (docs/compensation.md, section 2c).
TEST(Rfbf, LowerWorstCaseOverPlusMinus20PercentAtANominalCost) {
  const auto moves = seed_plan();
  double worst_fbf = 0.0, worst_rfbf = 0.0, nominal_fbf = 0.0, nominal_rfbf = 0.0, uncomp = 0.0;
  for (double f : {0.8, 1.0, 1.2}) {
    CompensationOptions o = seed(Method::fbf);
    o.plant_x = o.plant_y = dynamics::AxisModel::belt_rad_s(100.0 * f, 0.5);
    const CompensationResult a = compensate(moves, o);
    o.method = Method::rfbf;
    const CompensationResult b = compensate(moves, o);
    ASSERT_EQ(b.status, compensation::CompensationStatus::ok);
    if (f == 1.0) {
      nominal_fbf = a.max_tracking_error_mm;
      nominal_rfbf = b.max_tracking_error_mm;
      uncomp = b.uncompensated_max_tracking_error_mm;
    } else {
      worst_fbf = std::max(worst_fbf, a.max_tracking_error_mm);
      worst_rfbf = std::max(worst_rfbf, b.max_tracking_error_mm);
    }
  }
  EXPECT_LT(worst_rfbf, 0.95 * worst_fbf);
  EXPECT_GT(nominal_rfbf, nominal_fbf);
  EXPECT_LE(nominal_rfbf, 0.1 * uncomp);
}

}  // namespace
}  // namespace amctl::compensation
