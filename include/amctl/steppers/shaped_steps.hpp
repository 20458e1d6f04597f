#pragma once
// Step generation with input shaping and pressure advance (docs/steppers.md, "Input shaping"): Klipper's
// kin_shaper wraps any kinematics, so every motor follows its kinematics applied to the
// shaped toolhead position x_s(t) = sum_i a_i x(t - d_i) (per axis; the extruder is not
// shaped). shaping::ShapedPieceStream turns the plan into per-axis polynomial pieces in time;
// here each motor is stepped on them with Klipper's half-step convention (steps.hpp):
//  - a linear motor q = row . x_s is a polynomial on each piece; its turning points are the
//    real roots of q' (isolated recursively through the roots of q'', ...), and each
//    half-step crossing on a monotone interval is one root (closed form for degree <= 2,
//    safeguarded Newton above);
//  - a non-linear motor q = curve(x_s) is sampled for turning points every kCurveSampleS (and
//    at least 8 times a piece), each sign change of its slope bisected, then stepped as above.
#include <cstdint>
#include <deque>
#include <span>
#include <vector>

#include "amctl/kinematics/kinematics.hpp"
#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/shaped_pieces.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {

/// Sampling interval of a non-linear motor's turning points on a shaped piece [s].
inline constexpr double kCurveSampleS = 0.25e-3;

class ShapedStepGenerator {
 public:
  ShapedStepGenerator(std::vector<kinematics::Motor> motors, const shaping::AxisShapers& shapers,
                      const shaping::PressureAdvance& pa = {});

  /// Appends the steps the move completes (time-ordered; ties: motor order) to `out`. The
  /// steps of a move come out up to the shaper's look-ahead later, with a later move.
  void add_move(const plan::PlannedMove& move, std::vector<Step>& out);
  /// The steps left at the end of the plan.
  void finish(std::vector<Step>& out);

  /// Klipper's SET_PRESSURE_ADVANCE with an unchanged smoothing time: the moves added from now
  /// on are advanced by `advance_s` (extruder.py's look-ahead callback).
  void set_advance(double advance_s);
  /// Klipper's SET_INPUT_SHAPER or a new smoothing time, after its step-generation flush: the
  /// steps of the settings so far to `out` (every move has ended), then the new settings for
  /// the moves added from now on. Klipper's flush moves every finished move out of the motion
  /// queue its position reads (trapq_finalize_moves up to the last move's end), so the new
  /// position starts at rest where the toolhead stands: no motor jumps.
  void reconfigure(const shaping::AxisShapers& shapers, const shaping::PressureAdvance& pa,
                   std::vector<Step>& out);
  /// Takes over from a plain generator (after a flush: every move it was given has ended):
  /// its motors' positions, counts and statistics go on.
  void continue_from(const StepGenerator& plain);

  [[nodiscard]] const std::vector<kinematics::Motor>& motors() const { return motors_; }
  [[nodiscard]] const std::vector<StepperStats>& stats() const { return stats_; }
  [[nodiscard]] const shaping::ShapedPieceStream& stream() const { return stream_; }

 private:
  struct State {
    bool started = false;
    double origin = 0.0;  ///< motor position of step 0
    std::int64_t n = 0;
    double last_step_s = -std::numeric_limits<double>::infinity();
    /// Before the last recorded step: its predecessor's time and the stats' peak then (to take
    /// back a step that the next one cancels at the same instant).
    double before_last_step_s = -std::numeric_limits<double>::infinity();
    double before_min_interval_s = std::numeric_limits<double>::infinity();
    double before_peak_time_s = 0.0;
    /// After a change of settings: the next piece's start is `resume_mm` past step 0's position.
    bool resume = false;
    double resume_mm = 0.0;
  };
  /// Steps the new pieces of both streams and hands out, in time order, the steps before both
  /// streams' ends (all when `final`).
  void step_pieces(std::vector<Step>& out, bool final);
  void make_streams(const shaping::AxisShapers& shapers, const shaping::PressureAdvance& pa);
  /// Motor c is the extruder stepped on the pressure-advance stream.
  [[nodiscard]] bool on_extruder_stream(std::size_t c) const;
  /// Motor c's position at the toolhead point x (X, Y, Z, E).
  [[nodiscard]] double motor_position(std::size_t c, const std::array<double, 4>& x) const;
  void linear_piece(std::uint32_t c, const shaping::AxisPiece& piece);
  void curve_piece(std::uint32_t c, const shaping::AxisPiece& piece);
  void record(std::uint32_t c, double t, int dir);

  std::vector<kinematics::Motor> motors_;
  std::vector<State> state_;
  std::vector<StepperStats> stats_;
  shaping::ShapedPieceStream stream_;  ///< the toolhead (and the extruder without pressure advance)
  std::optional<shaping::ShapedPieceStream> e_stream_;  ///< the extruder with pressure advance
  std::vector<shaping::AxisPiece> pieces_, e_pieces_;
  double front_s_ = 0.0, e_front_s_ = 0.0;  ///< end of each stream's last piece
  std::vector<Step> merged_, merge_tmp_;
  std::vector<std::vector<Step>> scratch_;
  std::vector<double> bounds_;
};

/// The shapers `[input_shaper]` configures (an axis with frequency 0 is not shaped).
[[nodiscard]] shaping::AxisShapers axis_shapers(const machine::InputShaper& config);
/// The extruder's pressure advance (off without an extruder).
[[nodiscard]] shaping::PressureAdvance pressure_advance(const machine::Machine& m);

/// A sink of the plan stream running a ShapedStepGenerator (see StepSink).
class ShapedStepSink final : public plan::Sink {
 public:
  using Callback = std::function<void(std::span<const Step>)>;
  ShapedStepSink(std::vector<kinematics::Motor> motors, const shaping::AxisShapers& shapers,
                 const shaping::PressureAdvance& pa, Callback on_steps);
  void consume(const plan::PlanBatch& batch) override;
  void finish(const plan::StreamSummary& summary) override;
  [[nodiscard]] const ShapedStepGenerator& generator() const { return gen_; }

 private:
  ShapedStepGenerator gen_;
  Callback on_steps_;
  std::vector<Step> buf_;
};

/// The shapers of Klipper's per-axis settings (X, Y, Z; frequency 0: the axis unshaped).
[[nodiscard]] shaping::AxisShapers axis_shapers(const std::array<gcode::AxisShaperSetting, 3>& s);

/// The step sink of `amctl steps`: the plain generator while neither input shaping nor
/// pressure advance is on (its output as it always was), the shaped one from the start when
/// the machine has either, or from the first SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE that
/// turns one on (it takes the plain generator's motors over), and every later change as
/// Klipper applies it (plan::PlanEvent::Kind::step_tuning; docs/steppers.md section 8). The
/// stepped extruder is Klipper's "extruder"; the others' SET_PRESSURE_ADVANCE only time.
class TunedStepSink final : public plan::Sink {
 public:
  using Callback = std::function<void(std::span<const Step>)>;
  TunedStepSink(std::vector<kinematics::Motor> motors, const machine::Machine& m, Callback on_steps);
  void consume(const plan::PlanBatch& batch) override;
  void finish(const plan::StreamSummary& summary) override;
  [[nodiscard]] const std::vector<StepperStats>& stats() const;
  /// Whether the shaped generator ran (from the start or from a command on).
  [[nodiscard]] bool shaped() const { return shaped_.has_value(); }

 private:
  void on_move(const plan::PlannedMove& m);
  void on_tuning(const plan::PlanEvent& e);
  std::vector<kinematics::Motor> motors_;
  std::array<gcode::AxisShaperSetting, 3> shapers_{};
  shaping::PressureAdvance pa_;
  std::optional<StepGenerator> plain_;
  std::optional<ShapedStepGenerator> shaped_;
  Callback on_steps_;
  std::vector<Step> buf_;
};

namespace detail {
/// The real roots of the polynomial sum c[k] x^k (degree `degree` <= 6) in the open interval
/// (a, b), ascending, appended to `out`; a root where the polynomial touches zero without
/// changing sign may be left out.
void real_roots(const double* c, int degree, double a, double b, std::vector<double>& out);
}  // namespace detail

}  // namespace amctl::steppers
