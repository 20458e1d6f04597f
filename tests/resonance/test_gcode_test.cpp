// Resonance-test G-code planned by amctl itself: every half period of the planned motion lasts
// 1/(2f), accelerates at the commanded amplitude (accel_per_hz * f for Klipper's pattern, a
// constant for the Marlin-style sweep), starts and ends at rest, reverses direction, and the
// whole sweep lasts the closed form (f_N - f0) / rate.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/resonance/test_gcode.hpp"

namespace amctl::resonance {
namespace {

struct Planned {
  std::vector<plan::PlannedMove> moves;  // the half periods (the move to the point dropped)
};

Planned plan_text(const std::string& text, const machine::Machine& m) {
  plan::PlanSource src(std::string_view(text), "test.gcode", m);
  plan::CollectSink sink;
  plan::Sink* sinks[] = {&sink};
  (void)plan::run_pipeline(src, sinks);
  Planned p;
  p.moves.assign(sink.moves.begin() + 1, sink.moves.end());
  return p;
}

void check_planned(const TestGcodeOptions& o, const machine::Machine& m) {
  const std::vector<TestHalfPeriod> halves = test_half_periods(o);
  const Planned p = plan_text(test_gcode(o, m), m);
  ASSERT_EQ(p.moves.size(), halves.size());
  const int ai = o.axis == 'x' ? 0 : 1;
  const double v_min = m.firmware == machine::Firmware::marlin ? 0.05 : 0.0;
  double total_s = 0.0, total_tol_s = 0.0;
  for (std::size_t k = 0; k < halves.size(); ++k) {
    const plan::PlannedMove& mv = p.moves[k];
    const TestHalfPeriod& h = halves[k];
    SCOPED_TRACE(testing::Message() << "half period " << k << " at " << h.freq_hz << " Hz");
    // one half period of the oscillation: 1/(2f). The coordinates are written to 1e-6 mm: a
    // stroke is off by up to 1e-6 mm, which the planner covers in up to 2e-6 mm / V more time.
    const double v_peak = h.peak_velocity_mm_s();
    // Marlin plans a full reversal at MINIMUM_PLANNER_SPEED (0.05 mm/s), not at rest: each
    // ramp then ends v_min / a early.
    const double want_a0 = o.style == TestStyle::klipper ? o.accel_per_hz * h.freq_hz : o.accel_mm_s2;
    const double tol_s = 2e-6 / v_peak + 1e-9 + 2.0 * v_min / want_a0;
    EXPECT_NEAR(mv.duration_s(), 0.5 / h.freq_hz, tol_s);
    // the commanded acceleration amplitude (written to 1e-3 mm/s^2)
    const double want_a = o.style == TestStyle::klipper ? o.accel_per_hz * h.freq_hz : o.accel_mm_s2;
    EXPECT_NEAR(mv.accel_mm_s2, want_a, 1e-3);
    // rest to rest, a triangle: accelerate a quarter period, decelerate a quarter period
    EXPECT_NEAR(mv.start_v_mm_s, 0.0, v_min + 1e-9);
    EXPECT_NEAR(mv.end_v_mm_s, 0.0, v_min + 1e-9);
    EXPECT_NEAR(mv.cruise_t_s, 0.0, tol_s);
    EXPECT_NEAR(mv.accel_t_s, 0.25 / h.freq_hz, tol_s);
    EXPECT_NEAR(mv.cruise_v_mm_s, v_peak, v_peak * 1e-6 / h.distance_mm() + 1e-9);
    // alternating direction along the axis
    EXPECT_EQ(mv.axes_r[ai] > 0.0 ? 1.0 : -1.0, h.direction);
    EXPECT_NEAR(mv.axes_r[1 - ai], 0.0, 1e-12);
    // back to back: the next half period starts when this one ends
    if (k + 1 < halves.size()) {
      EXPECT_NEAR(p.moves[k + 1].start_time_s, mv.end_time_s(), 1e-9);
    }
    total_s += mv.duration_s();
    total_tol_s += tol_s;
  }
  const double closed_form_s = test_duration_s(o);
  EXPECT_NEAR(total_s, closed_form_s, total_tol_s);
  EXPECT_NEAR(p.moves.back().end_time_s() - p.moves.front().start_time_s, closed_form_s, total_tol_s);
}

TEST(TestGcode, KlipperPatternPlansAsIntended) {
  TestGcodeOptions o = default_test_options(TestStyle::klipper);
  EXPECT_EQ(o.freq_end_hz, 135.0);
  EXPECT_EQ(o.accel_per_hz, 60.0);
  check_planned(o, machine::load_machine("default"));
  o.axis = 'y';
  o.freq_end_hz = 40.0;
  o.accel_per_hz = 75.0;
  o.hz_per_sec = 2.0;
  check_planned(o, machine::load_machine("voron24"));
}

TEST(TestGcode, MarlinSweepPlansAsIntended) {
  TestGcodeOptions o = default_test_options(TestStyle::marlin);
  o.axis = 'y';
  EXPECT_EQ(o.accel_mm_s2, 4000.0);
  EXPECT_EQ(o.freq_end_hz, 80.0);
  check_planned(o, machine::load_machine("ender3"));
}

// The pattern follows the style, the commands the machine's firmware.
TEST(TestGcode, EitherStyleOnEitherFirmware) {
  TestGcodeOptions k = default_test_options(TestStyle::klipper);
  k.freq_end_hz = 30.0;
  check_planned(k, machine::load_machine("ender3"));
  check_planned(k, machine::load_machine("prusa-mk3s"));
  check_planned(k, machine::load_machine("default", {"printer.firmware=reprap"}));
  TestGcodeOptions mr = default_test_options(TestStyle::marlin);
  mr.freq_end_hz = 30.0;
  check_planned(mr, machine::load_machine("voron24"));
  check_planned(mr, machine::load_machine("default", {"printer.firmware=reprap"}));
  EXPECT_NE(test_gcode(k, machine::load_machine("ender3")).find("M204 S300.000\n"), std::string::npos);
  EXPECT_NE(test_gcode(mr, machine::load_machine("voron24")).find("SET_VELOCITY_LIMIT ACCEL=4000.000\n"),
            std::string::npos);
}

TEST(TestGcode, ClosedFormDuration) {
  TestGcodeOptions o = default_test_options(TestStyle::klipper);
  const std::vector<TestHalfPeriod> h = test_half_periods(o);
  double t = 0.0;
  for (const TestHalfPeriod& x : h) t += x.duration_s();
  EXPECT_NEAR(t, test_duration_s(o), 1e-9);
  // f rises at 1 Hz/s from 5 to just above 135 Hz
  EXPECT_NEAR(test_duration_s(o), 130.0, 0.01);
  EXPECT_EQ(h.front().freq_hz, 5.0);
  EXPECT_LE(h.back().freq_hz, 135.0 + 1e-6);
}

TEST(TestGcode, RejectsBadOptionsNamingTheParameter) {
  auto expect_error = [](TestGcodeOptions o, const std::string& name) {
    try {
      (void)test_half_periods(o);
      ADD_FAILURE() << "no error for " << name;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  TestGcodeOptions o;
  o.freq_start_hz = 0.0;
  expect_error(o, "--freq-start");
  o = {};
  o.freq_end_hz = 2.0;
  expect_error(o, "--freq-end");
  o = {};
  o.hz_per_sec = 3.0;
  expect_error(o, "--hz-per-sec");
  o = {};
  o.accel_per_hz = -1.0;
  expect_error(o, "--accel-per-hz");
  o = default_test_options(TestStyle::marlin);
  o.accel_mm_s2 = std::nan("");
  expect_error(o, "--accel-mm-s2");
  o = {};
  o.axis = 'z';
  expect_error(o, "--axis");
  o = {};
  o.hz_per_sec = 1e-5;
  expect_error(o, "--hz-per-sec");
}

// A printer.cfg with [resonance_tester]: its probe points, chips and frequencies drive the
// program, one record per point, as TEST_RESONANCES would run it.
constexpr const char* kTesterCfg =
    "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
    "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 100\nposition_endstop: 0\n"
    "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 100\nposition_endstop: 0\n"
    "[stepper_z]\nrotation_distance: 8\nmicrosteps: 16\nposition_max: 100\nposition_endstop: 0\n"
    "[input_shaper]\nshaper_freq_x: 50\nshaper_freq_y: 40\n"
    "[resonance_tester]\naccel_chip_x: adxl345 hotend\naccel_chip_y: adxl345 bed\n"
    "min_freq: 10\nmax_freq: 20\naccel_per_hz: 50\nmove_speed: 100\n"
    "probe_points:\n    20, 30, 10\n    80, 30, 10\n";

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

machine::Machine tester_machine() {
  const std::string path = testing::TempDir() + "resonance_tester.cfg";
  std::FILE* f = std::fopen(path.c_str(), "w");
  std::fputs(kTesterCfg, f);
  std::fclose(f);
  return machine::load_machine(path);
}

TEST(TestGcode, ResonanceTesterSectionGivesPointsChipsAndFrequencies) {
  const machine::Machine m = tester_machine();
  const TestGcodeOptions o = machine_test_options(TestStyle::klipper, 'y', m);
  ASSERT_EQ(o.probe_points.size(), 2u);
  EXPECT_EQ(o.probe_points[1], (std::array<double, 3>{80.0, 30.0, 10.0}));
  EXPECT_EQ(o.accel_chip, "adxl345 bed");
  EXPECT_EQ(machine_test_options(TestStyle::klipper, 'x', m).accel_chip, "adxl345 hotend");
  EXPECT_EQ(o.freq_start_hz, 10.0);
  EXPECT_EQ(o.freq_end_hz, 20.0);
  EXPECT_EQ(o.accel_per_hz, 50.0);
  EXPECT_EQ(o.hz_per_sec, 1.0);  // Klipper's default where the section is silent
  EXPECT_EQ(o.move_speed_mm_s, 100.0);

  const std::string g = test_gcode(o, m);
  // homed first, shaping off and back on, one start/stop pair per point (adxl345.py: CHIP is
  // the section's last word)
  EXPECT_EQ(g.find("G28\nG90\nSET_INPUT_SHAPER SHAPER_FREQ_X=0 SHAPER_FREQ_Y=0\n") != std::string::npos, true) << g.substr(0, 900);
  EXPECT_EQ(count(g, "ACCELEROMETER_MEASURE CHIP=bed NAME=resonances_y_1\n"), 2u);
  EXPECT_EQ(count(g, "ACCELEROMETER_MEASURE CHIP=bed NAME=resonances_y_2\n"), 2u);
  EXPECT_NE(g.find("G1 X80.0000 Y30.0000 Z10.0000 F6000\nM400\nG4 P500\nACCELEROMETER_MEASURE"), std::string::npos);
  EXPECT_NE(g.find("SET_INPUT_SHAPER SHAPER_FREQ_X=50 SHAPER_FREQ_Y=40\n"), std::string::npos);
  // amctl plans the whole program: every command known, the sweep twice
  const plan::EstimateReport r = plan::estimate_text(g, "test.gcode", m);
  EXPECT_TRUE(r.unknown_commands.empty()) << r.unknown_commands.front().name;
  EXPECT_FALSE(r.range_error.has_value());
  EXPECT_GT(r.total_time_s, 2.0 * test_duration_s(o));
}

TEST(TestGcode, WithoutProbePointsTheMiddleOfThePositionLimits) {
  const machine::Machine m = machine::load_machine(std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/ender3_cartesian.cfg");
  const TestGcodeOptions o = machine_test_options(TestStyle::klipper, 'x', m);
  EXPECT_TRUE(o.probe_points.empty());
  // ender3_cartesian.cfg: [stepper_x] and [stepper_y] position_min 0, position_max 300.
  EXPECT_EQ(o.point_mm[0], 0.5 * (0.0 + 300.0));
  EXPECT_EQ(o.point_mm[1], 0.5 * (0.0 + 300.0));
  EXPECT_EQ(o.point_mm[2], 20.0);
}

TEST(TestGcode, StrokesBeyondThePositionLimitsAreRefused) {
  // Klipper's pattern moves +a/(16 f0^2) first: 60 * 5 / (16 * 25) = 0.75 mm from the point.
  TestGcodeOptions o = default_test_options(TestStyle::klipper);
  EXPECT_NEAR(test_excursion(o).max_mm, 0.75, 1e-12);
  EXPECT_NEAR(test_excursion(o).min_mm, 0.0, 1e-12);
  const machine::Machine m = tester_machine();
  o.point_mm[0] = 99.5;  // 99.5 + 0.75 > position_max 100
  o.point_mm[1] = 50.0;
  o.point_given = true;
  o.point_source = "--point";
  try {
    (void)test_gcode(o, m);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--point: found test point 99.5,50,20, whose test moves X from "
                                         "99.5000 to 100.2500 mm"), std::string::npos) << e.what();
  }
  o.point_mm[0] = 99.25;  // exactly at the limit: allowed
  EXPECT_NO_THROW((void)test_gcode(o, m));
}

TEST(TestGcode, MalformedProbePointsNameTheirLine) {
  const std::string path = testing::TempDir() + "bad_probe_points.cfg";
  std::FILE* f = std::fopen(path.c_str(), "w");
  std::fputs("[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
             "[resonance_tester]\nprobe_points:\n  50, 50, 20\n  60, y, 20\n", f);
  std::fclose(f);
  const machine::Machine m = machine::load_machine(path);
  try {
    (void)machine_test_options(TestStyle::klipper, 'x', m);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().line, 8u) << e.what();
    EXPECT_NE(std::string(e.what()).find("found 'y' in '60, y, 20', expected a number"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amctl::resonance
