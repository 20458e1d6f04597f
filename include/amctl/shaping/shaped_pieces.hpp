#pragma once
// The shaped plan as per-axis polynomial pieces (docs/steppers.md, "Input shaping").
//
// Each axis of the plan is a piecewise polynomial x(t) in time, with breaks at every move's
// piece boundaries (plan::move_pieces), holding still between moves. Shaped as Klipper's
// kin_shaper does it (shaped_trajectory.hpp):
//     x_s(t) = sum_i a_i x(t - d_i),
// x_s is again a piecewise polynomial, whose breaks are the plan's breaks shifted by every
// delay d_i. ShapedPieceStream builds those pieces exactly (a Taylor shift of each plan piece
// to the start of the shaped piece, weighted and summed), in time order, from a stream of
// planned moves: memory is the moves within the shaper's span of the current time.
//
// Pressure advance (Klipper's kin_extruder.c) replaces the extruder axis by its advanced and
// smoothed position: e_pa(t) = e(t) + pa e'(t) on moves that extrude while moving in X or Y
// (e_pa = e elsewhere), averaged with the triangular weight of half-width h = smooth_time / 2:
//     E(t) = (1 / h^2) integral_{-h}^{h} (h - |u|) e_pa(t + u) du,
// integrated exactly on each piece (breaks at every plan break shifted by -h, 0 and +h; E's
// degree is the plan's plus 2). With pa = 0 the extruder follows e, as in Klipper.
//
// A jump of an axis between two moves (G92, a homing reset) does not move the motor: it is
// absorbed into a per-axis offset so x(t) stays continuous, as the unshaped step generator
// absorbs it per motor.
#include <array>
#include <cstddef>
#include <limits>
#include <vector>

#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/velocity_profile.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"

namespace amctl::shaping {

/// Coefficients of an axis piece: the plan's degree, plus 2 for pressure advance's smoothing.
inline constexpr int kAxisPieceCoeffs = plan::kMaxPieceDegree + 3;

/// Klipper's pressure advance: pa [s] (0 = off) and the smoothing time [s] (> 0).
struct PressureAdvance {
  double advance_s = 0.0;
  double smooth_time_s = 0.040;
  [[nodiscard]] bool active() const { return advance_s > 0.0 && smooth_time_s > 0.0; }
};

/// One piece of every axis over [t0_s, t0_s + duration_s]: x_a(t0 + tau) = sum_k c[a][k] tau^k.
struct AxisPiece {
  double t0_s = 0.0;
  double duration_s = 0.0;
  int degree = 0;  ///< the highest degree of any axis
  std::array<std::array<double, kAxisPieceCoeffs>, 4> c{};  ///< X, Y, Z, E
  std::int64_t line = 0;  ///< G-code line of the latest move that contributes
};

/// Planned moves in, shaped axis pieces out (in time order, contiguous from the first).
class ShapedPieceStream {
 public:
  explicit ShapedPieceStream(const AxisShapers& shapers, const PressureAdvance& pa = {});

  /// Appends the move (moves come in time order) and every shaped piece it completes to `out`.
  void push(const plan::PlannedMove& move, std::vector<AxisPiece>& out);
  /// The pieces left once no move follows (the tool rests after the last move), to `out`.
  void finish(std::vector<AxisPiece>& out);

  /// The pressure advance of the moves pushed from now on (Klipper's SET_PRESSURE_ADVANCE with
  /// the same smoothing time: each move keeps the advance in force when it was queued).
  void set_advance(double advance_s) { pa_.advance_s = advance_s; }
  /// Every axis at the end of the last move pushed, and the offset added to the plan's
  /// positions (G92 and homing jumps absorbed), in the stream's coordinates.
  [[nodiscard]] const std::array<double, 4>& end_mm() const { return end_mm_; }
  [[nodiscard]] const std::array<double, 4>& offset_mm() const { return offset_mm_; }
  [[nodiscard]] bool started() const { return started_; }
  [[nodiscard]] double advance_s() const { return pa_.advance_s; }

  /// Largest look-behind delay (>= 0) and the most negative look-ahead delay (<= 0) [s].
  [[nodiscard]] double max_delay_s() const { return max_delay_s_; }
  [[nodiscard]] double min_delay_s() const { return min_delay_s_; }

 private:
  struct Source {  ///< one plan piece (or a rest) of every axis, in absolute time
    double t0_s = 0.0;
    double t1_s = 0.0;
    int degree = 0;
    std::array<std::array<double, kAxisPieceCoeffs>, 4> c{};
    std::array<double, kAxisPieceCoeffs> e_pa{};  ///< e + pa e' (pressure advance on)
    int e_degree = 0;  ///< the degree of e_pa (0: the extruder stands still)
    std::int64_t line = 0;
  };
  struct Tap {
    double delay_s = 0.0;
    std::array<double, 4> weight{};
    std::size_t index = 0;  ///< absolute index of the source piece the tap reads
  };
  void append_source(const Source& s);
  void append_rest(double t0, double t1);
  void generate(std::vector<AxisPiece>& out, bool final);
  /// Pressure advance's extruder over the piece starting at u0 (coefficients in tau).
  void smoothed_extruder(double u0, double* out, int& degree);
  [[nodiscard]] const Source& source(std::size_t index) const {
    return sources_[head_ + (index - base_)];
  }

  std::vector<Tap> taps_;
  PressureAdvance pa_;
  double half_smooth_s_ = 0.0;   ///< h; 0 without pressure advance
  std::size_t tap_behind_ = 0, tap_now_ = 0, tap_ahead_ = 0;  ///< taps reading t - h, t, t + h
  /// The last smoothed extruder piece: while the sources under the kernel are the same, the
  /// next piece is the same polynomial re-expanded at its start.
  struct SmoothCache {
    bool valid = false;
    std::size_t iL = 0, iM = 0, iR = 0;
    double u0 = 0.0;
    int degree = 0;
    std::array<double, kAxisPieceCoeffs> c{};
  } smooth_cache_;
  double max_delay_s_ = 0.0;
  double min_delay_s_ = 0.0;
  /// The sources still read, from sources_[head_] on (a queue over a vector: the front is
  /// dropped by moving head_, and the dropped ones erased once they are half of it).
  std::vector<Source> sources_;
  std::size_t head_ = 0;
  std::size_t base_ = 0;     ///< absolute index of sources_[head_]
  bool started_ = false;
  double out_t_s_ = 0.0;     ///< start of the next shaped piece
  std::array<double, 4> offset_mm_{};
  std::array<double, 4> end_mm_{};  ///< every axis at the end of the last source
  std::array<plan::PathPiece, 7> pieces_{};
};

/// Taylor shift: the coefficients of p(tau + h) from those of p(tau) (degree `degree`).
void taylor_shift(const double* c, int degree, double h, double* out);

}  // namespace amctl::shaping
