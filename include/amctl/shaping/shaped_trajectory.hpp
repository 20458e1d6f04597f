#pragma once
// Input shaping applied to planned motion as Klipper applies it (klippy/chelper/kin_shaper.c):
// each shaped axis follows the convolution of its planned position with the shaper's impulses,
// normalised and centred,
//   x_s(t) = sum_i a_i x(t - d_i),   a_i = A_i / sum(A),   d_i = T_i - t_s,
//   t_s = sum_i a_i T_i  (Shaper::time_shift_s),
// so that sum a_i d_i = 0: a constant-velocity motion is left exactly as planned, and the
// shaped print takes the same time as the planned one. x is the exact piecewise polynomial
// of trajectory::Cursor, so the shaped position (and its velocity, acceleration and jerk, the
// same weighted sums of the planned ones) is exact: no resampling.
#include <array>
#include <optional>
#include <span>
#include <vector>

#include "amctl/plan/planned_move.hpp"
#include "amctl/shaping/shaper.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::shaping {

/// The impulses as applied to motion: weights a_i (sum 1) at delays d_i [s] (sum a_i d_i = 0;
/// negative delays look ahead in the plan). Klipper's shift_pulses().
struct AppliedPulses {
  std::vector<double> weights;
  std::vector<double> delays_s;
};

[[nodiscard]] AppliedPulses applied_pulses(const Shaper& shaper);

/// A shaper per axis: X, Y, Z (the extruder is never shaped, as in Klipper). An empty axis
/// follows the plan.
struct AxisShapers {
  std::array<std::optional<Shaper>, 3> xyz;
};

/// Shaped evaluation over a window of planned moves. Times passed to evaluate() must be
/// non-decreasing (amortised O(pulses) per call; one trajectory::Cursor per distinct delay).
/// The shaped state at t depends on the plan over [t - max_delay_s(), t - min_delay_s()]:
/// a caller streaming the plan keeps that much of it around t in the window. Outside the
/// window the tool is held still as by trajectory::Cursor (at rest before the first move's
/// start and after the last move's end). Like trajectory::Cursor it refers to the moves (which
/// must outlive it) and is not to be copied once evaluate() has been called.
class ShapedCursor {
 public:
  ShapedCursor(std::span<const plan::PlannedMove> moves, const AxisShapers& shapers);

  /// Shaped state of every axis at t.
  [[nodiscard]] trajectory::AxisState evaluate(double t_s);

  /// The largest look-behind (>= 0) and the most negative look-ahead (<= 0) delay [s].
  [[nodiscard]] double max_delay_s() const { return max_delay_s_; }
  [[nodiscard]] double min_delay_s() const { return min_delay_s_; }

 private:
  struct Tap {
    double delay_s = 0.0;
    std::array<double, trajectory::kAxes> weight{};  ///< per axis (0: axis not at this delay)
    trajectory::Cursor cursor;
  };
  std::vector<Tap> taps_;
  double max_delay_s_ = 0.0;
  double min_delay_s_ = 0.0;
};

}  // namespace amctl::shaping
