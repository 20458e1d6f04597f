#pragma once
// The plant engine: the modal states of two simulated axes driven exactly by a
// piecewise-polynomial command (docs/dynamics.md, "The plant engine").
//
// Every command amctl simulates is a polynomial in time on each piece: the plan's pieces
// (degree <= 6), the input-shaped pieces (shaping::ShapedPieceStream: a weighted sum of
// shifted plan pieces, again degree <= 6) and a compensated command (linear or cubic between
// samples). For each mode i of an axis, with e_i the deflection from the command and
// q_i = e_i' / w_i,
//     e_i' = w_i q_i,   q_i' = -w_i e_i - 2 z_i w_i q_i - (g_i / w_i) u,   u = x_b'',
// and the nozzle is x = x_b + sum_i e_i. Over an interval tau on which u is a polynomial,
// u(s) = sum_j u_j s^j / j!, the state advances exactly as
//     x(tau) = Phi(tau) x(0) + sum_j psi_j(tau) u_j            (propagator.hpp),
// and a jump dv of the command's velocity (a corner at non-zero junction speed) is an
// impulse of u: e stays, q jumps by -g dv / w. Cost O(modes) per interval, memory O(modes).
//
// ModalPlant is the state and those two operations; PieceSimulator drives it from a stream of
// CommandPiece in time order and reports the exact response at the times t0 + k h.
// dynamics::Simulator (the plan's moves) and the shaped simulation (the shaped pieces) both
// advance a ModalPlant.
#include <array>
#include <cstddef>
#include <functional>
#include <span>
#include <vector>

#include "amctl/dynamics/model.hpp"
#include "amctl/dynamics/propagator.hpp"

namespace amctl::dynamics {

/// Input derivatives u^(j) at the start of an interval, per simulated axis.
using InputTerms = double[2][kMaxInputTerms];

class ModalPlant {
 public:
  /// The modes of model_0 act on simulated axis 0, those of model_1 on axis 1; step_s is the
  /// interval whose propagator is cached (the output step).
  ModalPlant(const AxisModel& model_0, const AxisModel& model_1, double step_s);

  /// Advances over the cached step with input u (its first `terms` derivatives; 0: u = 0).
  void step(int terms, const InputTerms& u);
  /// Advances over tau >= 0 (any duration) with input u.
  void advance(double tau_s, int terms, const InputTerms& u);
  /// The command's velocity jumps by (dv0, dv1) [mm/s] on the two axes.
  void velocity_jump(double dv0_mm_s, double dv1_mm_s);

  /// Nozzle minus command per axis: sum of the modes' e [mm].
  [[nodiscard]] std::array<double, 2> deflection_mm() const;
  /// Free-vibration amplitude per axis with the current input's acceleration u_0 (terms > 0):
  /// sqrt(sum_i (e_i - pi_i u_0)^2 + (q_i - pi'_i u_0)^2), the state minus the static
  /// deflection under constant acceleration (only that term of the particular solution: the
  /// higher ones blow up on the very short, steep ramps planners emit).
  [[nodiscard]] std::array<double, 2> vibration_mm(int terms, const InputTerms& u) const;
  /// The same free-vibration state per mode (2 numbers per mode, model_0's modes first).
  void modal_state(int terms, const InputTerms& u, std::span<double> out) const;

  [[nodiscard]] std::size_t modes() const { return runs_.size(); }
  [[nodiscard]] bool empty() const { return runs_.empty(); }
  /// Axis (0 or 1) of each mode, in modal_state() order.
  [[nodiscard]] std::vector<int> mode_axes() const;

 private:
  struct Run {
    int axis = 0;
    Mode mode;
    ModePropagator step;  // for the cached step
    double e = 0.0;       // modal deflection [mm]
    double q = 0.0;       // deflection rate / w [mm]
  };
  void apply(const ModePropagator* props, int terms, const InputTerms& u);
  std::vector<Run> runs_;
  std::vector<ModePropagator> sub_;
};

/// Coefficients of a command piece: degree <= kMaxInputTerms + 1 (u = x'' then has at most
/// kMaxInputTerms derivative terms).
inline constexpr int kCommandPieceCoeffs = kMaxInputTerms + 2;

/// The command of the two simulated axes over [t0_s, t0_s + duration_s]:
/// x_a(t0 + tau) = sum_k c[a][k] tau^k.
struct CommandPiece {
  double t0_s = 0.0;
  double duration_s = 0.0;
  std::array<std::array<double, kCommandPieceCoeffs>, 2> c{};
};

/// One output sample of a PieceSimulator: the command and the nozzle of the two simulated axes.
struct PlantSample {
  double t_s = 0.0;
  std::array<double, 2> cmd_mm{};
  std::array<double, 2> sim_mm{};  ///< cmd_mm + deflection
};

/// Drives a ModalPlant from command pieces (time order, each starting where the last ended;
/// the plant at rest on the command before the first) and reports the exact response at
/// t_k = grid_t0_s + (grid_index0 + k) / sample_rate_hz. A sample on a piece boundary belongs to the piece
/// that starts there. Between pieces the command's position is taken as continuous: a
/// position jump (a G92 absorbed upstream) moves the command, not the plant's state.
class PieceSimulator {
 public:
  /// Called for every sample; the simulator's input_terms()/plant() describe the sample.
  using Sink = std::function<void(const PlantSample&)>;
  /// Throws amctl::Error for a sample rate at or below the models' Nyquist limit.
  PieceSimulator(const AxisModel& model_0, const AxisModel& model_1, double sample_rate_hz,
                 double grid_t0_s, long long grid_index0 = 0);
  /// Reports the samples before the piece's end and advances the state to its end.
  void push(const CommandPiece& piece, const Sink& sink);
  /// After the last piece the command rests where it ended: reports every sample with
  /// index <= last_k.
  void rest_until(std::size_t last_k, const Sink& sink);

  [[nodiscard]] const ModalPlant& plant() const { return plant_; }
  /// The input (derivatives of x'') of the sample being reported, and its term count.
  [[nodiscard]] const InputTerms& input() const { return u_; }
  [[nodiscard]] int input_terms() const { return terms_; }
  /// The index of the next sample to report.
  [[nodiscard]] std::size_t next_k() const { return k_; }
  [[nodiscard]] double step_s() const { return h_; }
  [[nodiscard]] std::size_t state_updates() const { return updates_; }
  [[nodiscard]] std::size_t pieces() const { return pieces_; }

 private:
  /// Fills u_, terms_ and the command at tau on `c`.
  void load(const CommandPiece& p, double tau, PlantSample& s);
  [[nodiscard]] double time(std::size_t k) const {
    return grid_t0_ + static_cast<double>(grid_index0_ + static_cast<long long>(k)) * h_;
  }
  ModalPlant plant_;
  double h_ = 0.0, grid_t0_ = 0.0;
  long long grid_index0_ = 0;
  std::size_t k_ = 0;
  bool started_ = false;
  double t_ = 0.0;                   ///< the time the state is at
  std::array<double, 2> end_pos_{};  ///< command at the end of the last piece
  std::array<double, 2> end_vel_{};
  InputTerms u_{};
  int terms_ = 0;
  std::size_t updates_ = 0, pieces_ = 0;
};

}  // namespace amctl::dynamics
