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
#include <cstdint>
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
  std::vector<MoveMetrics> per_move;
  std::map<std::int32_t, GroupMetrics> per_layer;
  std::map<std::uint16_t, GroupMetrics> per_feature;
  std::vector<WorstPlace> worst;
  std::vector<CornerResult> corners;
};

/// Distance [mm] from (x, y) to the XY polyline of the moves around move `center`, searching
/// along the path up to radius_mm (and at most 64 moves) either side.
[[nodiscard]] double distance_to_path(std::span<const plan::PlannedMove> moves,
                                      std::size_t center, double x_mm, double y_mm,
                                      double radius_mm);

class QualityMeter {
 public:
  QualityMeter(std::span<const plan::PlannedMove> moves, MetricsOptions options);
  /// Adds one sample; returns its contour error [mm] (NaN when outside the time range).
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
  void close_corner();

  std::span<const plan::PlannedMove> moves_;
  MetricsOptions opt_;
  QualityReport rep_;
  std::vector<double> corner_angle_;   // per move: turn angle to the next XY move, or < 0
  std::vector<std::size_t> next_xy_;   // per move: the next move with XY motion
  std::size_t next_end_ = 0;           // first move whose end has not been passed
  bool exact_ends_ = false;            // on_move_end() has been called
  double sum_sq_ = 0.0, sum_sq_print_ = 0.0;
  std::uint64_t n_print_ = 0;
  double last_vib_ = 0.0;
  // active corner window
  bool corner_open_ = false;
  std::size_t corner_move_ = 0;
  double corner_t0_ = 0.0;
  Corner corner_;
  CornerResult corner_res_;
  std::vector<RingSample> ring_;
};

}  // namespace amctl::dynamics
