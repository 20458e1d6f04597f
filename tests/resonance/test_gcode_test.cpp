// Resonance-test G-code planned by amctl itself: every half period of the planned motion lasts
// 1/(2f), accelerates at the commanded amplitude (accel_per_hz * f for Klipper's pattern, a
// constant for the Marlin-style sweep), starts and ends at rest, reverses direction, and the
// whole sweep lasts the closed form (f_N - f0) / rate.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
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

}  // namespace
}  // namespace amctl::resonance
