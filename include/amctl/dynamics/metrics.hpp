#pragma once
// Print-quality metrics of a simulated nozzle path (fed sample by sample from simulate()).
//
//  contour error   distance from the simulated nozzle (X, Y) to the commanded path, the
//                  polyline of the moves' XY segments near the current move (within an
//                  along-path radius of 2 |sim - cmd| + 0.05 mm, at most 64 moves either side),
//                  so a lag along a straight line does not count, a cut corner does.
//  corner          a junction whose XY direction turns by more than corner_angle_deg.
//  overshoot       after a corner at P with incoming direction d_in: the largest
//                  (sim - P).d_in - max(0, (cmd - P).d_in), how far the nozzle runs past the
//                  corner beyond what the command itself does.
//  ringing         after a corner, the deviation (sim - cmd).n_out across the outgoing wall;
//                  wavelength = commanded path distance between successive maxima (what a
//                  ringing tower shows), amplitude = half the first peak-to-trough swing.
//  residual        the free-vibration amplitude (vector norm over X and Y) just after each
//  vibration       move's end, exact when fed through on_move_end(), else at the first sample
//                  at or after the end.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <span>
#include <vector>

#include "amctl/dynamics/simulate.hpp"
#include "amctl/plan/planned_move.hpp"

namespace amctl::dynamics {

struct MetricsOptions {
  double corner_angle_deg = 20.0;
  /// How long after a corner overshoot and ringing are watched (cut short by the next corner).
  double corner_window_s = 0.25;
  std::size_t worst_count = 10;
  /// Only samples with t in [t_begin_s, t_end_s] count.
  double t_begin_s = -std::numeric_limits<double>::infinity();
  double t_end_s = std::numeric_limits<double>::infinity();
  /// Only samples whose move lies in layers [layer_begin, layer_end] count.
  std::int32_t layer_begin = std::numeric_limits<std::int32_t>::min();
  std::int32_t layer_end = std::numeric_limits<std::int32_t>::max();
  /// Keep QualityReport::per_move (one record per move). Off for bounded-memory streaming:
  /// moves are then folded into the per-layer/per-feature groups and the worst list as soon
  /// as their samples are over.
  bool keep_per_move = true;
};

struct MoveMetrics {
  double max_contour_error_mm = 0.0;
  double sum_sq_contour_error_mm2 = 0.0;
  std::uint32_t samples = 0;
  double worst_t_s = 0.0;
  double worst_x_mm = 0.0;
  double worst_y_mm = 0.0;
  double residual_vibration_mm = 0.0;
};

struct GroupMetrics {
  double max_contour_error_mm = 0.0;
  double rms_contour_error_mm = 0.0;
  std::uint64_t samples = 0;
};

struct WorstPlace {
  std::uint64_t line = 0;
  std::size_t move_index = 0;
  std::int32_t layer = -1;
  std::uint16_t feature = 0;
  double t_s = 0.0;
  double x_mm = 0.0;
  double y_mm = 0.0;
  double contour_error_mm = 0.0;
};

struct CornerResult {
  std::size_t move_index = 0;      ///< the move ending at the corner
  std::uint64_t line = 0;
  double angle_deg = 0.0;          ///< direction change
  double junction_speed_mm_s = 0.0;
  double overshoot_mm = 0.0;
  double ringing_wavelength_mm = std::numeric_limits<double>::quiet_NaN();
  double ringing_period_s = std::numeric_limits<double>::quiet_NaN();
  double ringing_amplitude_mm = 0.0;
};

struct QualityReport {
  double motion_time_s = 0.0;
  std::uint64_t samples = 0;
  double max_contour_error_mm = 0.0;
  double rms_contour_error_mm = 0.0;
  double max_contour_error_printing_mm = 0.0;  ///< extruding moves only
  double rms_contour_error_printing_mm = 0.0;
  double max_corner_overshoot_mm = 0.0;
  double max_residual_vibration_mm = 0.0;
  double final_residual_vibration_mm = 0.0;    ///< at the end of the last move
  double ringing_wavelength_mm = std::numeric_limits<double>::quiet_NaN();  ///< median
  double ringing_amplitude_mm = 0.0;                                        ///< max
  std::vector<MoveMetrics> per_move;  ///< empty unless MetricsOptions::keep_per_move
  std::map<std::int32_t, GroupMetrics> per_layer;
  std::map<std::uint16_t, GroupMetrics> per_feature;
  std::vector<WorstPlace> worst;
  /// Every corner, or with keep_per_move = false only the worst_count by overshoot (the
  /// median ringing wavelength then comes from a 0.001 mm histogram).
  std::vector<CornerResult> corners;
  std::uint64_t corner_count = 0;
};

/// Distance [mm] from (x, y) to the XY polyline of the moves around move `center`, searching
/// along the path up to radius_mm (and at most 64 moves) either side: the contour error,
/// with radius_mm = 2 |nozzle - command| + 0.05 (the one definition every simulation uses).
[[nodiscard]] double distance_to_path(std::span<const plan::PlannedMove> moves,
                                      std::size_t center, double x_mm, double y_mm,
                                      double radius_mm);

/// One XY segment of a path, from (ax, ay) to (bx, by).
struct PathSegment {
  double ax = 0.0, ay = 0.0, bx = 0.0, by = 0.0;
};

/// distance_to_path on any sequence of segments: segment_at(i) -> PathSegment for i < count
/// (a caller holding its own window of the path, e.g. a deque).
template <class SegmentAt>
[[nodiscard]] double distance_to_segments(const SegmentAt& segment_at, std::size_t count,
                                          std::size_t center, double x, double y, double radius) {
  if (count == 0) return 0.0;
  center = std::min(center, count - 1);
  const auto d2 = [x, y](const PathSegment& s) {
    const double dx = s.bx - s.ax, dy = s.by - s.ay;
    const double l2 = dx * dx + dy * dy;
    double u = 0.0;
    if (l2 > 0.0) u = std::clamp(((x - s.ax) * dx + (y - s.ay) * dy) / l2, 0.0, 1.0);
    const double ex = x - (s.ax + u * dx), ey = y - (s.ay + u * dy);
    return ex * ex + ey * ey;
  };
  const auto len = [](const PathSegment& s) {
    return std::sqrt((s.bx - s.ax) * (s.bx - s.ax) + (s.by - s.ay) * (s.by - s.ay));
  };
  double best = d2(segment_at(center));
  constexpr std::size_t kMaxMoves = 64;
  double along = 0.0;
  for (std::size_t k = 1; k <= kMaxMoves && k <= center; ++k) {
    const PathSegment sk = segment_at(center - k);
    best = std::min(best, d2(sk));
    along += len(sk);
    if (along > radius) break;
  }
  along = 0.0;
  for (std::size_t k = 1; k <= kMaxMoves && center + k < count; ++k) {
    const PathSegment sk = segment_at(center + k);
    best = std::min(best, d2(sk));
    along += len(sk);
    if (along > radius) break;
  }
  return std::sqrt(best);
}

class QualityMeter {
 public:
  /// Streaming use: call set_window() before the samples of each window.
  explicit QualityMeter(MetricsOptions options);
  /// Whole plan at once (window = all moves).
  QualityMeter(std::span<const plan::PlannedMove> moves, MetricsOptions options);
  /// The moves with global indices base .. base + size - 1. Must cover the moves of the
  /// coming samples plus the neighbours the contour search and corner detection look at
  /// (64 moves either side); moves before `base` must be finished.
  void set_window(std::span<const plan::PlannedMove> window, std::size_t base);
  /// Adds one sample; returns its contour error [mm] (NaN when outside the range).
  double add(const SimSample& s);
  /// Exact free-vibration amplitude just after move `i` ends (simulate()'s MoveEndSink).
  void on_move_end(std::size_t i, double t_s, const std::array<double, 2>& vibration_mm);
  /// Closes open corner windows and aggregates. Call once after the last sample.
  [[nodiscard]] QualityReport finish();

 private:
  struct Corner {
    double angle_deg = 0.0;
    double p[2]{}, din[2]{}, dout[2]{};
  };
  struct RingSample {
    double sigma_mm, t_s, dev_mm;
  };
  struct OpenMove {
    MoveMetrics m;
    std::uint64_t line = 0;
    std::int32_t layer = -1;
    std::uint16_t feature = 0;
  };
  [[nodiscard]] const plan::PlannedMove& move(std::size_t global) const;
  OpenMove& open(std::size_t global);
  void finalize_before(std::size_t global);
  void open_corner_after(std::size_t global, double vib_unused);
  void close_corner();
  [[nodiscard]] bool in_range(const SimSample& s) const;

  MetricsOptions opt_;
  QualityReport rep_;
  std::span<const plan::PlannedMove> win_;
  std::size_t base_ = 0;
  bool have_start_ = false;
  double first_start_s_ = 0.0, last_end_s_ = 0.0;
  std::deque<OpenMove> open_;          // per-move records not yet folded, from open_base_
  std::size_t open_base_ = 0;
  std::vector<WorstPlace> worst_heap_; // min-heap on contour error, size <= worst_count
  std::size_t next_end_ = 0;           // first move whose end has not been passed
  bool exact_ends_ = false;            // on_move_end() has been called
  double sum_sq_ = 0.0, sum_sq_print_ = 0.0;
  std::uint64_t n_print_ = 0;
  double last_vib_ = 0.0;
  // active corner window
  bool corner_open_ = false;
  double corner_t0_ = 0.0;
  Corner corner_;
  CornerResult corner_res_;
  std::vector<RingSample> ring_;
  std::vector<std::uint32_t> wavelength_hist_;  // 0.001 mm bins, when !keep_per_move
};

/// Simulation and metrics of a move stream in bounded memory: moves are pushed one by one
/// (e.g. from the planner's callback); a window of 3 x window_moves moves is kept, and every
/// time it fills the simulation advances to the start of the move window_moves from its end.
class StreamingSimulation {
 public:
  /// Called for every sample with its contour error (NaN outside the measured range).
  using RowSink = std::function<void(const SimSample&, double contour_error_mm)>;
  StreamingSimulation(const AxisModel& model_0, const AxisModel& model_1,
                      const SimulationOptions& sim_options, MetricsOptions metrics_options,
                      RowSink rows = nullptr, std::size_t window_moves = 256);
  void push(const plan::PlannedMove& move);
  /// Simulates the rest (through the settle time) and returns the report.
  [[nodiscard]] QualityReport finish();
  [[nodiscard]] const SimulationStats& stats() const { return sim_.stats(); }
  [[nodiscard]] std::size_t max_window_moves() const { return max_buffer_; }

 private:
  void run(double t_stop, bool final);
  Simulator sim_;
  QualityMeter meter_;
  RowSink rows_;
  std::size_t window_;
  std::vector<plan::PlannedMove> buf_;
  std::size_t base_ = 0;
  std::size_t max_buffer_ = 0;
};

}  // namespace amctl::dynamics
