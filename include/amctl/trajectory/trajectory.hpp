#pragma once
// Exact piecewise-polynomial evaluation of a stream of planned moves.
//
// Every move is split into at most 7 polynomial pieces of the path distance s(tau)
// (plan::move_pieces); axis i then follows p_i(t) = start_mm[i] + axes_r[i] * s(t - t_piece).
// Between moves (a dwell, or before the first / after the last move) the tool holds still.
// Positions, velocities, accelerations and jerks are exact (no resampling); the only error
// is floating-point round-off.
#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/velocity_profile.hpp"

namespace amctl::trajectory {

inline constexpr std::size_t kAxes = 4;  ///< X, Y, Z, E

/// Kinematic state of every axis at one time. [mm], [mm/s], [mm/s^2], [mm/s^3]
struct AxisState {
  double t_s = 0.0;
  std::array<double, kAxes> pos_mm{};
  std::array<double, kAxes> vel_mm_s{};
  std::array<double, kAxes> acc_mm_s2{};
  std::array<double, kAxes> jerk_mm_s3{};
};

/// The polynomial pieces of one planned move, rebuilt from its profile, speeds, accel and
/// jerk. Throws amctl::Error (naming the G-code line) when the move's stored phase durations
/// disagree with its speeds and limits by more than 1e-9 s relative.
std::size_t move_pieces(const plan::PlannedMove& move, std::array<plan::PathPiece, 7>& out);

/// Sequential evaluator over a time-ordered span of moves. Times passed to locate() /
/// evaluate() must be non-decreasing; each call is amortised O(1). The cursor only keeps
/// the current move's pieces, so streaming memory is O(1) in the number of moves.
class Cursor {
 public:
  explicit Cursor(std::span<const plan::PlannedMove> moves);

  /// Where time t falls: a piece of a move, or a hold (dwell / before / after).
  struct Location {
    std::size_t move_index = 0;            ///< move whose geometry applies (hold: previous)
    const plan::PathPiece* piece = nullptr;
    double piece_t0_s = 0.0;               ///< start of the piece on the global time line
    double piece_end_s = 0.0;              ///< end of the piece (+inf after the last move)
    bool holding = false;                  ///< tool at rest (gap, before or after moves)
  };

  /// The piece covering [t, t+eps): at a boundary the later piece is returned.
  const Location& locate(double t_s);
  /// State of every axis at t.
  AxisState evaluate(double t_s);
  /// Path distance s and its derivatives 0..max_order at t (local polynomial of the piece).
  /// d[k] = d^k s / dt^k. Axis i follows start_mm[i] + axes_r[i] * s.
  void path_derivatives(double t_s, std::array<double, plan::kMaxPieceDegree + 1>& d);
  /// Same for a location returned by locate(t_s) (no second search).
  static void path_derivatives(const Location& loc, double t_s,
                               std::array<double, plan::kMaxPieceDegree + 1>& d);

  [[nodiscard]] const plan::PlannedMove& move(std::size_t i) const { return moves_[i]; }
  [[nodiscard]] std::span<const plan::PlannedMove> moves() const { return moves_; }

 private:
  void load_move(std::size_t i);
  std::span<const plan::PlannedMove> moves_;
  std::array<plan::PathPiece, 7> pieces_{};
  std::size_t piece_count_ = 0;
  std::size_t loaded_move_ = static_cast<std::size_t>(-1);
  std::size_t next_move_ = 0;   ///< first move not yet started at the last located time
  std::size_t piece_i_ = 0;
  double piece_start_ = 0.0;    ///< start time of pieces_[piece_i_]
  bool loc_valid_ = false;
  plan::PathPiece hold_{};
  Location loc_{};
  double last_t_ = -1e300;
};

/// A time-ordered sequence of moves with random-access evaluation.
class Trajectory {
 public:
  explicit Trajectory(std::vector<plan::PlannedMove> moves);
  [[nodiscard]] const std::vector<plan::PlannedMove>& moves() const { return moves_; }
  [[nodiscard]] double start_time_s() const;
  [[nodiscard]] double end_time_s() const;
  /// State at any time (binary search; O(log n)).
  [[nodiscard]] AxisState evaluate(double t_s) const;
  [[nodiscard]] Cursor cursor() const { return Cursor(moves_); }

 private:
  std::vector<plan::PlannedMove> moves_;
};

/// Evaluates a polynomial piece: s and its first three derivatives at local time tau.
[[nodiscard]] plan::PathState evaluate_piece(const plan::PathPiece& p, double tau_s);

}  // namespace amctl::trajectory
