// Real slicer output: the bundled model is sliced by Debian's prusa-slicer at test time and
// estimated. The slicer's own figure is checked only loosely (slicers do not model the
// firmware's planner); segments that start and end at rest are checked exactly against the
// seed 000 trapezoid closed form.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

namespace fs = std::filesystem;
const fs::path kSource = AMCTL_SOURCE_DIR;

double trapezoid_time(double D, double vd, double a) {  // from rest to rest, (3.1)-(3.5)
  const double vp = std::sqrt(a * D);
  if (vp > vd) return 2 * vd / a + (D - vd * vd / a) / vd;
  return 2 * vp / a;
}

class SlicedByPrusaSlicer : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (std::system("command -v prusa-slicer > /dev/null 2>&1") != 0) return;
    // One directory per process: CTest runs each test of this suite as its own process.
    dir_ = fs::path(::testing::TempDir()) / ("amctl_slicer_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const std::string models = "python3 " + (kSource / "examples/models/make_models.py").string() +
                               " " + dir_.string();
    const std::string slice = "prusa-slicer --export-gcode --load " +
                              (kSource / "examples/slicer/klipper_voron.ini").string() + " " +
                              (dir_ / "boxboss.stl").string() + " -o " +
                              (dir_ / "boxboss.gcode").string() + " > " +
                              (dir_ / "slicer.log").string() + " 2>&1";
    ok_ = std::system(models.c_str()) == 0 && std::system(slice.c_str()) == 0 &&
          fs::exists(dir_ / "boxboss.gcode");
  }
  // The sliced files are made per process: remove them with the process's last test.
  static void TearDownTestSuite() {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  void SetUp() override {
    if (!ok_) GTEST_SKIP() << "prusa-slicer not installed (scripts/install-deps.sh --with-slicer)";
  }
  static inline fs::path dir_;
  static inline bool ok_ = false;
};

TEST_F(SlicedByPrusaSlicer, EstimateIsSaneAgainstTheSlicersOwnFigure) {
  const auto m = machine::load_machine((kSource / "configs/klipper-voron-v0.cfg").string());
  const auto r = estimate_file((dir_ / "boxboss.gcode").string(), m);
  ASSERT_TRUE(r.slicer_estimate_s.has_value());
  EXPECT_EQ(r.slicer_name, "PrusaSlicer");
  // Loose: slicers are commonly 10-40 % off real firmware.
  EXPECT_GT(r.total_time_s, 0.6 * *r.slicer_estimate_s);
  EXPECT_LT(r.total_time_s, 1.5 * *r.slicer_estimate_s);
  EXPECT_EQ(r.layers.size(), 100u);  // 20 mm at 0.2 mm layers
  EXPECT_NEAR(r.layers.back().z_mm, 20.0, 1e-9);
  EXPECT_GT(r.filament_mm, 100.0);
  // The profile's bed is the printer's (120 mm): every move is in range.
  EXPECT_FALSE(r.range_error.has_value()) << describe_range_error(*r.range_error);
  // One heat-up: PRINT_START waits for the bed and the hotend, once each.
  ASSERT_EQ(r.heater_waits.size(), 2u);
  EXPECT_EQ(r.heater_waits[0].what, "M190 bed 100 C (wait)");
  EXPECT_EQ(r.heater_waits[1].what, "M109 hotend 240 C (wait)");
  // The config's PRINT_START/PRINT_END macros are expanded (docs/macros.md): nothing unknown.
  EXPECT_TRUE(r.unknown_commands.empty()) << r.unknown_commands.front().name;
  ASSERT_EQ(r.macros.size(), 2u);
  EXPECT_EQ(r.macros[0].name, "PRINT_START");
  EXPECT_EQ(r.macros[0].expanded, 1u);
  EXPECT_EQ(r.macros[1].name, "PRINT_END");
  EXPECT_EQ(r.macros[1].skipped, 0u);
  EXPECT_NEAR(r.motion_time_s + r.dwell_time_s, r.total_time_s, 1e-6);
  EXPECT_NEAR(r.extrude_time_s + r.travel_time_s + r.extrude_only_time_s, r.motion_time_s, 1e-6);
}

TEST_F(SlicedByPrusaSlicer, TravelsBetweenRetractionsMatchTheClosedFormExactly) {
  // Klipper plans a stop at every junction with an extrude-only move, so a travel between a
  // retraction and an unretraction starts and ends at rest: its time is the trapezoid of
  // seed 000 (3.1)-(3.5) with the speed and acceleration in force.
  const auto m = machine::load_machine((kSource / "configs/klipper-voron-v0.cfg").string());
  std::vector<PlannedMove> window;
  std::size_t checked = 0;
  auto check = [&](const PlannedMove& mv) {
    window.push_back(mv);
    if (window.size() > 3) window.erase(window.begin());
    if (window.size() == 3 && window[0].extrude_only && window[2].extrude_only &&
        !window[1].extrude_only && window[1].axes_r[3] == 0.0) {
      const PlannedMove& t = window[1];
      EXPECT_EQ(t.start_v_mm_s, 0.0);
      EXPECT_EQ(t.end_v_mm_s, 0.0);
      const double expected = trapezoid_time(t.distance_mm, t.cruise_v_mm_s, t.accel_mm_s2);
      EXPECT_NEAR(t.duration_s(), expected, 1e-12 * std::max(1.0, expected)) << "line " << t.line;
      // The cruise speed is the file's travel speed (300 mm/s) unless the move is too short.
      EXPECT_LE(t.cruise_v_mm_s, 300.0 + 1e-9);
      ++checked;
    }
  };
  PlanSource source((dir_ / "boxboss.gcode").string(), m);
  PlanBatch batch;
  while (source.next(batch)) {
    for (const PlannedMove& mv : batch.moves) check(mv);
  }
  EXPECT_GT(checked, 50u);
}

}  // namespace
}  // namespace amctl::plan
