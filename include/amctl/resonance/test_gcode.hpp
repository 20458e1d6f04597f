#pragma once
// Resonance-test G-code (docs/resonance.md, "Resonance-test G-code"): the move pattern of
// Klipper's TEST_RESONANCES, or a Marlin-style sine-like sweep, written as plain G-code that any
// printer (and amctl's planner) can run.
//
// Both styles are a train of rest-to-rest half periods along one axis: half period k at
// frequency f_k lasts 1/(2 f_k); it accelerates at +a_k for a quarter period and decelerates at
// -a_k for the next, so its velocity is a triangle with peak a_k / (4 f_k) and it covers
// a_k / (16 f_k^2) mm; successive half periods alternate in direction. The frequency then
// advances by rate / (2 f_k), so f rises linearly in time at `rate` Hz/s, and a sweep from f0
// that stops at the first f_N above f1 lasts exactly (f_N - f0) / rate seconds.
//   klipper: a_k = accel_per_hz * f_k (Klipper's VibrationPulseTestGenerator).
//   marlin:  a_k = accel (constant amplitude).
#include <array>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/machine/machine.hpp"

namespace amctl::resonance {

enum class TestStyle { klipper, marlin };

struct TestGcodeOptions {
  TestStyle style = TestStyle::klipper;
  char axis = 'x';                 ///< 'x' or 'y'
  double freq_start_hz = 5.0;
  double freq_end_hz = 135.0;      ///< Klipper [resonance_tester] max_freq default
  double accel_per_hz = 60.0;      ///< klipper style: mm/s^2 per Hz (Klipper default)
  double accel_mm_s2 = 4000.0;     ///< marlin style: constant amplitude
  double hz_per_sec = 1.0;         ///< sweep rate [Hz/s]
  double point_mm[3] = {100.0, 100.0, 20.0};
  bool point_given = false;        ///< false: the default point (noted in the header)
  /// The test points in order, as Klipper's [resonance_tester] probe_points: the test runs at
  /// each in turn (one record per point). Empty: point_mm alone.
  std::vector<std::array<double, 3>> probe_points;
  /// Where the point(s) and the test parameters came from, for the header ("[resonance_tester]
  /// probe_points of printer.cfg:40", "the middle of the machine's position limits", ...).
  std::string point_source;
  std::string parameter_source;
  /// Where each probe point is written (errors about a point name its line); empty: not from
  /// a file.
  std::vector<SourceLocation> probe_point_locations;
  /// Start with G28 (every firmware refuses moves before homing).
  bool home = true;
  /// Speed of the move to each test point [mm/s] (Klipper [resonance_tester] move_speed).
  double move_speed_mm_s = 50.0;
  /// Klipper: the accelerometer section that records this axis ([resonance_tester] accel_chip,
  /// or accel_chip_x / accel_chip_y), e.g. "adxl345" or "adxl345 bed"; its
  /// ACCELEROMETER_MEASURE commands bracket each test. Empty: "adxl345", Klipper's default.
  std::string accel_chip;
};

/// The style's defaults with the machine's own where it has them: Klipper's
/// [resonance_tester] section (probe_points, accel_chip / accel_chip_x / accel_chip_y,
/// min_freq, max_freq, accel_per_hz, hz_per_sec, move_speed) when the printer.cfg has one;
/// otherwise the test point is the middle of the machine's X and Y position limits at
/// Z = min(20 mm, the middle of Z), or 100, 100, 20 when the machine has no limits. Throws
/// amctl::Error (file:line) for a malformed [resonance_tester] value.
[[nodiscard]] TestGcodeOptions machine_test_options(TestStyle style, char axis,
                                                    const machine::Machine& machine);

/// The range one test moves along its axis, relative to the test point [mm]: the lowest and
/// the highest offset the half periods reach.
struct TestExcursion {
  double min_mm = 0.0, max_mm = 0.0;
};
[[nodiscard]] TestExcursion test_excursion(const TestGcodeOptions& o);

/// Defaults of a style (klipper: 5..135 Hz, 60 mm/s^2/Hz, 1 Hz/s; marlin: 5..80 Hz,
/// 4000 mm/s^2, 4 Hz/s as the corpus sweeps).
[[nodiscard]] TestGcodeOptions default_test_options(TestStyle style);

/// One rest-to-rest half period.
struct TestHalfPeriod {
  double freq_hz = 0.0;
  double accel_mm_s2 = 0.0;        ///< magnitude
  double start_time_s = 0.0;
  double direction = 1.0;          ///< +1 or -1 along the axis
  [[nodiscard]] double duration_s() const { return 0.5 / freq_hz; }
  [[nodiscard]] double distance_mm() const { return accel_mm_s2 / (16.0 * freq_hz * freq_hz); }
  [[nodiscard]] double peak_velocity_mm_s() const { return accel_mm_s2 / (4.0 * freq_hz); }
};

/// The half periods of the test. Throws amctl::Error naming the parameter for bad options
/// (frequencies <= 0 or end < start, rate <= 0 or > 2 for klipper style as Klipper, accels <= 0,
/// a point that is not finite, axis not x/y, more than 10^6 half periods).
[[nodiscard]] std::vector<TestHalfPeriod> test_half_periods(const TestGcodeOptions& o);

/// (f_N - f0) / rate: the closed-form duration of the half periods.
[[nodiscard]] double test_duration_s(const TestGcodeOptions& o);

/// The whole program: a header of comments (style, parameters and where they came from,
/// duration, peak accel and velocity, the points), G28 (unless o.home is false), G90, input
/// shaping off when the machine has it (Klipper SET_INPUT_SHAPER SHAPER_FREQ_X=0 ..., Marlin
/// M593 F0), the limits (Klipper: SET_VELOCITY_LIMIT VELOCITY ACCEL MINIMUM_CRUISE_RATIO=0
/// SQUARE_CORNER_VELOCITY=0 once, then ACCEL per half period; Marlin: M204 S per half period,
/// M205 X0 Y0 so that a reversal stops), then for each test point: the move to it, M400 and a
/// 0.5 s dwell (as TEST_RESONANCES), Klipper's ACCELEROMETER_MEASURE CHIP=... NAME=... to start
/// the record (Marlin has no accelerometer command: a comment marks where to start one), the
/// half periods (G1 with F = peak velocity), M400 and the ACCELEROMETER_MEASURE that stops the
/// record and writes it; finally the machine's limits and input shaping restored.
/// Throws amctl::Error when a test point or the strokes around it leave the machine's position
/// limits.
[[nodiscard]] std::string test_gcode(const TestGcodeOptions& o, const machine::Machine& machine);

}  // namespace amctl::resonance
