#pragma once
// Step generation: the exact step times of every stepper motor from the exact trajectory
// (docs/steppers.md). Klipper's convention (klippy/chelper/itersolve.c): a stepper sits on a
// grid of step positions spaced by its step distance and anchored where it starts; it takes
// a step (+1 or -1) the moment its commanded position reaches the half-step point between its
// current step position and the next one in the direction of motion. On each polynomial
// piece of a move the motor position is a monotone polynomial in t, so every crossing time is
// one root, solved exactly (closed form for degree <= 2, safeguarded Newton/bisection to
// 1e-13 s above).
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/output.hpp"
#include "amctl/core/table_output.hpp"
#include "amctl/core/json.hpp"
#include "amctl/kinematics/kinematics.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/velocity_profile.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::steppers {

/// A motor within this distance of its half-step level has reached it (Klipper's itersolve.c
/// accepts a step time when the position is within 1e-9 mm of the target): a move that ends
/// that close short of a level steps at its end, as Klipper does.
inline constexpr double kLevelToleranceMm = 1e-9;

/// One step. Steps are delivered in time order (ties: motor order).
struct Step {
  double time_s = 0.0;        ///< print time of the half-step crossing
  std::uint32_t stepper = 0;  ///< index into the motors
  std::int32_t direction = 1; ///< +1 or -1
};

/// Per-stepper figures.
struct StepperStats {
  std::uint64_t steps = 0;
  std::uint64_t steps_positive = 0;
  std::uint64_t steps_negative = 0;
  std::int64_t position_steps = 0;  ///< net steps from the start
  /// Shortest interval between two consecutive steps of this stepper [s] (+inf: < 2 steps).
  double min_interval_s = std::numeric_limits<double>::infinity();
  double peak_time_s = 0.0;         ///< time of the later step of that pair
  [[nodiscard]] double peak_step_rate_steps_s() const { return 1.0 / min_interval_s; }
};

inline constexpr double kSustainedWindowS = 0.010;  ///< default window of the sustained rate

/// Step rates a drive has to sustain (step_rate.hpp, StepRateMeter), per stepper. Rates are 0 and times NaN below the steps they need.
struct StepRateFigures {
  /// Shortest interval between consecutive steps after the step+back filter [s] (+inf: < 2).
  double filtered_min_interval_s = std::numeric_limits<double>::infinity();
  double filtered_peak_time_s = std::numeric_limits<double>::quiet_NaN();  ///< later step's time
  /// Most filtered steps in any window of the meter's length, per second of window.
  double sustained_step_rate_steps_s = 0.0;
  double sustained_time_s = std::numeric_limits<double>::quiet_NaN();  ///< end of that window
  [[nodiscard]] double filtered_peak_step_rate_steps_s() const {
    return 1.0 / filtered_min_interval_s;
  }
};

/// The step engine: feeds on moves in time order, keeps one grid state per motor (the motors
/// of machine::motors: a linear row or a kinematics::MotorCurve each).
class StepGenerator {
 public:
  explicit StepGenerator(std::vector<kinematics::Motor> motors);

  /// Appends the steps of `move` to `out`, sorted by time. Moves must come in time order.
  void add_move(const plan::PlannedMove& move, std::vector<Step>& out);

  [[nodiscard]] const std::vector<kinematics::Motor>& motors() const { return motors_; }
  [[nodiscard]] const std::vector<StepperStats>& stats() const { return stats_; }

  /// Where motor c stands: its step count, the motor position of step 0 and at the end of the
  /// last move (both with the motor's offset added), and its last step's time.
  struct MotorState {
    bool started = false;
    std::int64_t n = 0;
    double origin_mm = 0.0;
    double last_end_mm = 0.0;
    double last_step_s = -std::numeric_limits<double>::infinity();
  };
  [[nodiscard]] MotorState motor_state(std::size_t c) const {
    const State& s = state_[c];
    return MotorState{s.started, s.n, s.origin_mm, s.last_end_mm, s.last_step_s};
  }

 private:
  struct State {
    bool started = false;
    double offset_mm = 0.0;    ///< added to row . position (continuity across G92 / homing)
    double origin_mm = 0.0;    ///< motor position of step 0
    double last_end_mm = 0.0;  ///< motor position at the end of the previous move
    std::int64_t n = 0;        ///< current step position
    double last_step_s = -std::numeric_limits<double>::infinity();
    /// A non-linear motor's move starting at motor position `start_mm`: anchors the grid on
    /// the first move; a jump between moves (G92, homing) goes into the offset, so the motor
    /// position stays continuous. Returns the offset to add.
    double continue_at(double start_mm) {
      if (!started) {
        started = true;
        origin_mm = start_mm;
        last_end_mm = start_mm;
      }
      if (std::abs(start_mm + offset_mm - last_end_mm) > 1e-9 * (1.0 + std::abs(last_end_mm))) {
        offset_mm += last_end_mm - (start_mm + offset_mm);
      }
      return offset_mm;
    }
  };
  /// The steps of motor c over the move, appended to `out` in time order.
  void linear_move(std::uint32_t c, const plan::PlannedMove& move, std::vector<Step>& out);
  /// The same for a non-linear motor, on the intervals where its curve is monotone.
  void curve_move(std::uint32_t c, const plan::PlannedMove& move, std::vector<Step>& out);
  /// Records one step of motor c at time t.
  void record_step(std::uint32_t c, double t, int dir, std::vector<Step>& out);

  std::vector<kinematics::Motor> motors_;
  std::vector<State> state_;
  std::vector<StepperStats> stats_;
  std::array<plan::PathPiece, 7> pieces_{};
  std::size_t piece_count_ = 0;
  std::vector<std::vector<Step>> scratch_;  ///< per motor, one move
  std::vector<double> bounds_;             ///< curve_move's monotone intervals
};

/// Time of the crossing s(tau) = s_target on a piece with s non-decreasing on
/// [lo_s, duration]: closed form for degree <= 2, safeguarded Newton/bisection otherwise
/// (|error| < 1e-12 s). Returns tau in [lo_s, duration_s].
[[nodiscard]] double solve_crossing_s(const plan::PathPiece& p, double s_target_mm, double lo_s);

/// A sink of the plan stream: runs a StepGenerator and hands each move's steps (time-ordered)
/// to a callback. Memory: the steps of one move.
class StepSink final : public plan::Sink {
 public:
  using Callback = std::function<void(std::span<const Step>)>;
  StepSink(std::vector<kinematics::Motor> motors, Callback on_steps);
  void consume(const plan::PlanBatch& batch) override;
  void finish(const plan::StreamSummary& summary) override { end_time_s_ = summary.end_time_s; }
  [[nodiscard]] const StepGenerator& generator() const { return gen_; }
  [[nodiscard]] double end_time_s() const { return end_time_s_; }

 private:
  StepGenerator gen_;
  Callback on_steps_;
  std::vector<Step> buf_;
  double end_time_s_ = 0.0;
};

/// The steps table through amctl::OutputFile: CSV (header `stepper,time_s,direction`), or for
/// a path ending in ".npy" numpy's .npy format, one record per step with the fields `stepper`
/// (the stepper's name, |S bytes), `time_s` (<f8, the same double the CSV prints) and
/// `direction` (|i1, +1 or -1) (core/table_output.hpp). A regular file appears at commit()
/// whole or not at all; a device, FIFO or "-" is streamed (CSV only).
class StepsFile {
 public:
  StepsFile(std::string path, std::vector<std::string> names, OutputOptions options = {});
  StepsFile(const StepsFile&) = delete;
  StepsFile& operator=(const StepsFile&) = delete;
  void write(std::span<const Step> steps);
  void commit();
  [[nodiscard]] TableFormat format() const { return format_; }
  [[nodiscard]] std::uint64_t rows() const { return rows_; }
  [[nodiscard]] std::uint64_t bytes() const { return bytes_; }  ///< header and rows so far

 private:
  void flush();
  TableFormat format_;
  std::optional<OutputFile> csv_;
  std::optional<NpyTable> npy_;
  std::vector<std::string> names_;
  std::string buf_;
  std::uint64_t rows_ = 0;
  std::uint64_t bytes_ = 0;
};

/// Which steps `amctl steps` writes: amctl's exact ones, or what Klipper sends its MCU after
/// its step+direction+step filter (step_filter.hpp).
enum class StepFilter { none, klipper };
/// "none" or "klipper"; throws amctl::Error naming `flag` otherwise.
[[nodiscard]] StepFilter step_filter_from_string(std::string_view name, std::string_view flag);
[[nodiscard]] const char* to_string(StepFilter f);

/// What `amctl steps` reports.
struct StepsReport {
  std::string file;
  std::string machine_name;
  std::string kinematics;
  std::string csv_path;          ///< "" when no CSV was written
  double print_time_s = 0.0;
  std::uint64_t moves = 0;
  std::vector<kinematics::Motor> motors;
  std::vector<StepperStats> stats;    ///< of the steps written (after the filter)
  StepFilter step_filter = StepFilter::none;
  std::vector<std::uint64_t> filtered_pairs;  ///< per motor: step pairs the filter removed
  /// Per motor: the peak after the step+back filter and the sustained rate, whatever
  /// `step_filter` (StepRateMeter over the exact steps).
  std::vector<StepRateFigures> rates;
  double sustained_window_s = kSustainedWindowS;
  std::uint64_t csv_bytes = 0;  ///< bytes of the CSV written (0 without one)
  /// What shaped the steps (docs/steppers.md section 8): the printer's [input_shaper] when it
  /// shapes an axis, and pressure advance when it is above 0 (0 otherwise).
  machine::InputShaper input_shaper;
  double pressure_advance_s = 0.0;
  double pressure_advance_smooth_time_s = 0.0;
  [[nodiscard]] std::uint64_t total_steps() const;
};

/// The CSV reached `bytes` (called once, when it first passes kLargeStepsCsvBytes) at print
/// time `time_s`: a caller may warn its user.
using LargeCsvCallback = std::function<void(std::uint64_t bytes, double time_s)>;
inline constexpr std::uint64_t kLargeStepsCsvBytes = 1'000'000'000;
/// Bytes a steps CSV row takes on average besides the stepper's name: ',', the time in its
/// shortest round-trip form (17 significant digits mostly, 18-19 characters), ',', the
/// direction, a newline (measured: 21.7 on boxboss's 5.5 M steps on the V0).
inline constexpr double kStepsCsvRowBytesBesidesName = 21.7;

/// G-code file + machine -> steps (PlanSource -> StepSink), written as CSV to `csv_path`
/// when it is not empty (whole or not at all).
[[nodiscard]] StepsReport generate_steps_file(const std::string& gcode_path,
                                              const machine::Machine& m,
                                              const std::string& csv_path,
                                              StepFilter filter = StepFilter::none,
                                              const LargeCsvCallback& on_large_csv = {});

/// JSON form: step_filter, input_shaper (null, or x and y each null or {type, freq_hz,
/// damping_ratio}), pressure_advance (null, or {advance_s, smooth_time_s}), steppers[] with name, step_distance_mm, steps, steps_positive,
/// steps_negative, peak_step_rate_steps_s, peak_time_s, min_interval_s (null when fewer than
/// two steps), filtered_pairs.
[[nodiscard]] Json to_json(const StepsReport& r);

}  // namespace amctl::steppers
