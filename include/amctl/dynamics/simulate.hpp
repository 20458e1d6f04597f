#pragma once
// Time simulation of the XY nozzle driven by the exact piecewise-polynomial command.
//
// The command acceleration u = x_b'' of each axis is a polynomial inside every piece of the
// plan (degree 0 trapezoid, 1 scurve7, 4 bezier5). Over one output step h that lies inside
// a piece the modal state is advanced exactly with x+ = Phi(h) x + sum_j Psi_j(h) u^(j)(t_k)
// (discretize.hpp); a step that crosses piece boundaries is split at them and each part is
// advanced with Phi(tau), Psi(tau) for its own duration tau (phi-function series for the
// 2x2 mode blocks, Eigen's matrix exponential when ||A tau|| is large). So the output is
// the exact response at the sample times, whatever h is; h only sets where it is reported.
// Each mode block is 2x2 and independent, so the cost is O(modes) per axis and step.
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "amctl/dynamics/model.hpp"
#include "amctl/dynamics/plant.hpp"
#include "amctl/dynamics/propagator.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planned_move.hpp"

namespace amctl::dynamics {

struct SimulationOptions {
  double sample_rate_hz = 1000.0;  ///< output rate; must exceed the models' Nyquist limit
  /// Simulated time after the last move ends, to let vibration decay. < 0: automatic,
  /// 5 time constants of the slowest-decaying mode, clamped to [0.05, 1] s.
  double settle_s = -1.0;
  /// false: the two models act on X and Y (seed 000). true: on two motors of a linear
  /// kinematics, motor i at position motor_rows[i] . (x, y, z) (machine::motor_space: Klipper's
  /// stepper_x and stepper_y; CoreXY A = X + Y, B = X - Y).
  bool motor_space = false;
  std::array<std::array<double, 3>, 2> motor_rows{{{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}}};
  /// Fill SimSample::vibration_mm on every sample (costs two square roots per sample).
  bool vibration_per_sample = false;
  /// Keep the free-vibration state of every mode of the current sample for
  /// Simulator::modal_state() (read it from the sample sink).
  bool modal_state_per_sample = false;
  /// First sample at the first move's start plus this [s] (<= 0: the tool is at rest on the
  /// commanded path before the first move). A shaped simulation runs one Simulator per
  /// shaper delay d on the same plan with offset -d (plus whole steps), so that its samples
  /// fall at t_k - d.
  double grid_offset_s = 0.0;
  /// Simulated beyond motion end + settle [s] (>= 0).
  double extra_settle_s = 0.0;
};

/// One output sample.
struct SimSample {
  double t_s = 0.0;
  std::array<double, 3> cmd_mm{};       ///< commanded X, Y, Z
  std::array<double, 2> cmd_vel_mm_s{};  ///< commanded X, Y velocity
  std::array<double, 2> sim_mm{};       ///< simulated nozzle X, Y
  /// Amplitude of the free vibration of each axis (only when
  /// SimulationOptions::vibration_per_sample; else 0): the modal state minus the static
  /// deflection under the current commanded acceleration a,
  /// sqrt(sum_i (e_i + g_i a / w_i^2)^2 + (e_i' / w_i)^2). Exact at rest, cruising and under
  /// constant acceleration; during jerk-limited ramps it also contains the ramp's lag term.
  std::array<double, 2> vibration_mm{};
  std::size_t move_index = 0;           ///< move whose geometry applies at t
  std::uint64_t line = 0;               ///< its G-code line
  bool holding = false;                 ///< commanded tool at rest (gap, before, after)
};

struct SimulationStats {
  std::size_t samples = 0;
  std::size_t axis_state_updates = 0;   ///< mode-block updates (2 axes x modes x sub-steps)
  std::size_t split_steps = 0;          ///< output steps that crossed a piece boundary
  double start_time_s = 0.0;
  double end_time_s = 0.0;              ///< last simulated time (motion end + settle)
  double motion_end_time_s = 0.0;
};

using SampleSink = std::function<void(const SimSample&)>;
/// Called at the exact end time of every move (also between output samples) with the free
/// vibration amplitude of each axis just after the end (right limit: the next piece's input).
using MoveEndSink = std::function<void(std::size_t move_index, double t_s,
                                       const std::array<double, 2>& vibration_mm)>;

/// Incremental simulation for streaming: feed windows of the (time-ordered) move stream,
/// each call producing the samples with t < t_stop (or, with final = true, up to the end of
/// the last move plus the settle time). `window` holds the moves with global indices
/// base .. base + size - 1 and must include every move active between the last sample
/// produced and t_stop plus one step (keep a few moves behind and ahead). Sample and move-end
/// indices are global. State: the modal states and the sample counter, O(modes).
class Simulator {
 public:
  Simulator(const AxisModel& model_0, const AxisModel& model_1, const SimulationOptions& options);
  ~Simulator();
  void advance(std::span<const plan::PlannedMove> window, std::size_t base, double t_stop,
               bool final, const SampleSink& sink, const MoveEndSink& move_end = nullptr);
  [[nodiscard]] const SimulationStats& stats() const { return stats_; }
  /// With SimulationOptions::modal_state_per_sample, during the sample sink: per mode (in
  /// the order of model_0's modes, then model_1's) the free-vibration state
  /// (e_i + g_i a / w_i^2, e_i' / w_i) [mm] of the sample, two numbers per mode. Linear in the
  /// command, so the state of a weighted sum of commands is the weighted sum of the states.
  [[nodiscard]] std::span<const double> modal_state() const { return modal_state_; }
  /// Axis (0 or 1) of each mode in modal_state() order.
  [[nodiscard]] std::vector<int> mode_axes() const;

 private:
  SimulationOptions opt_;
  double h_ = 0.0, settle_ = 0.0, t0_ = 0.0, motion_end_ = 0.0;
  bool started_ = false;
  ModalPlant plant_;
  std::size_t k_ = 0;
  double v_left_[2] = {0.0, 0.0};
  bool have_left_ = false;
  std::size_t next_end_ = 0;
  SimulationStats stats_;
  std::vector<double> modal_state_;
};

/// The settle time a simulation with these options runs after motion end [s]: settle_s, or
/// when it is < 0, 5 time constants of the slowest-decaying mode clamped to [0.05, 1] s
/// (0 for rigid models); plus extra_settle_s.
[[nodiscard]] double settle_time_s(const SimulationOptions& options, const AxisModel& model_0,
                                   const AxisModel& model_1);

/// Simulates the moves (time-ordered) from the first move's start, the nozzle at rest on
/// the commanded path, and passes every sample at t0 + k / sample_rate_hz to `sink`.
/// Memory use is O(modes), independent of the number of moves or samples.
/// Throws amctl::Error for a sample rate at or below the Nyquist limit or <= 0.
SimulationStats simulate(std::span<const plan::PlannedMove> moves, const AxisModel& model_0,
                         const AxisModel& model_1, const SimulationOptions& options,
                         const SampleSink& sink, const MoveEndSink& move_end = nullptr);

}  // namespace amctl::dynamics
