#pragma once
// The toolpath of every layer as a decimated XY polyline with speed, in bounded memory
// (docs/report.md, "Toolpath").
//
// Every move with XY motion adds its end point as a vertex; the segment arriving at a vertex
// carries its kind (travel, or the feature of an extruding move), the highest speed reached
// on it and, when a simulation feeds add_error_sample(), the largest contour error of the
// samples taken on it. Decimation by radial distance: a vertex closer than the layer's
// tolerance to the last kept vertex is merged into the next one of the same kind (its speed
// and error folded in); a change of kind always keeps the vertex before it, and the first and
// last point of each layer are always kept. Bounds: when a layer exceeds max_points_per_layer
// its tolerance doubles and the layer is decimated again (up to 8 times; after that the rest
// of the layer is dropped and the layer marked truncated); when all layers together exceed
// max_points, the tolerance of every layer doubles and all are decimated again.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "amctl/plan/stream.hpp"

namespace amctl::report {

struct ToolpathVertex {
  float x_mm = 0.0F;
  float y_mm = 0.0F;
  float speed_mm_s = 0.0F;       ///< highest speed on the segment arriving here
  float error_mm = -1.0F;        ///< largest contour error on it; < 0: no sample
  double t0_s = 0.0;             ///< print time the segment starts
  double t1_s = 0.0;             ///< print time it ends (at this vertex)
  std::int32_t kind = -2;        ///< -2: start of a polyline, -1: travel, >= 0: feature
};

struct ToolpathLayer {
  std::int32_t layer = 0;
  double z_mm = 0.0;
  double tolerance_mm = 0.0;
  bool truncated = false;        ///< points dropped because the layer hit its cap
  std::uint64_t moves = 0;       ///< XY moves seen in the layer
  std::vector<ToolpathVertex> vertices;
};

struct ToolpathOptions {
  double tolerance_mm = 0.1;
  std::size_t max_points_per_layer = 8000;
  std::size_t max_points = 150000;
};

class ToolpathSink final : public plan::Sink {
 public:
  explicit ToolpathSink(ToolpathOptions options = {});
  void consume(const plan::PlanBatch& batch) override;
  void finish(const plan::StreamSummary& summary) override;

  /// A simulated sample at print time t_s with contour error error_mm (NaN: ignored), folded
  /// into the segment it was taken on, or between segments into the one that ended last.
  /// Samples must come in time order and after the moves they belong to were consumed.
  void add_error_sample(double t_s, double error_mm);

  [[nodiscard]] const std::vector<ToolpathLayer>& layers() const { return layers_; }
  [[nodiscard]] std::size_t points() const { return total_points_; }
  [[nodiscard]] std::uint64_t moves() const { return moves_; }
  /// Whether any cap made a tolerance grow or a layer lose points.
  [[nodiscard]] bool capped() const { return capped_; }
  [[nodiscard]] const ToolpathOptions& options() const { return options_; }

 private:
  void add_move(const plan::PlannedMove& m);
  void push(ToolpathVertex v);
  void commit(ToolpathVertex v);
  void flush_pending();
  void redecimate(ToolpathLayer& layer);
  void fix_cursor();

  ToolpathOptions options_;
  std::vector<ToolpathLayer> layers_;
  bool has_pending_ = false;
  ToolpathVertex pending_{};
  std::size_t total_points_ = 0;
  std::uint64_t moves_ = 0;
  bool capped_ = false;
  double global_tolerance_mm_ = 0.0;
  // Error samples: the vertex they were last assigned to and the largest error of samples
  // past the last committed vertex (given to the next vertex committed).
  std::size_t cursor_layer_ = 0;
  std::size_t cursor_vertex_ = 0;
  float carry_error_mm_ = -1.0F;
  double last_sample_t_s_ = 0.0;
  bool finished_ = false;
};

/// Radial-distance decimation of one polyline (used for the caps; exposed for tests): keeps
/// the first and last vertex and every vertex before a change of kind.
[[nodiscard]] std::vector<ToolpathVertex> decimate(const std::vector<ToolpathVertex>& in,
                                                   double tolerance_mm);

}  // namespace amctl::report
