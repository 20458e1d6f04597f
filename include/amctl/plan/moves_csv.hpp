#pragma once
// The planned moves as CSV (or numpy's .npy), one row per move, as a sink of the plan stream (`amctl plan`).
// Numbers are written in the shortest form that reads back to the same double, so a script
// that loads the CSV (numpy, pandas, MATLAB) sees exactly the planner's values.
//
// Columns: line, layer, feature (the slicer's name, quoted if it holds a comma or quote;
// empty before the first annotation), start_time_s, duration_s, x0_mm, y0_mm, z0_mm, e0_mm,
// x1_mm, y1_mm, z1_mm, e1_mm, distance_mm, start_v_mm_s, cruise_v_mm_s, end_v_mm_s,
// accel_mm_s2, jerk_mm_s3, accel_t_s, cruise_t_s, decel_t_s, profile, extrude_only.
// (x1 = x0 + axes_r[0] distance_mm, ...; e of an extrude-only move is along axes_r[3].)
#include <cstdio>
#include <memory>
#include <optional>
#include <ostream>
#include <string>

#include "amctl/core/output.hpp"
#include "amctl/core/table_output.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::plan {

/// The header line of the moves CSV (with its newline).
[[nodiscard]] const std::string& moves_csv_header();
/// One row (with its newline). `feature_name` is the move's feature (PlanBatch::feature_names).
[[nodiscard]] std::string moves_csv_row(const PlannedMove& m, std::string_view feature_name);

/// Writes the moves CSV to a stream (e.g. std::cout).
class MovesCsvSink final : public Sink {
 public:
  explicit MovesCsvSink(std::ostream& out);
  void consume(const PlanBatch& batch) override;
  [[nodiscard]] std::uint64_t rows() const { return rows_; }

 private:
  std::ostream& out_;
  std::uint64_t rows_ = 0;
};

/// Widest feature name a .npy moves table holds [bytes] (slicers' names are under 40).
inline constexpr std::size_t kMovesNpyFeatureBytes = 64;

/// Writes the moves table through amctl::OutputFile: a regular file appears at commit() (call
/// it after the pipeline ran) whole or not at all, so an error never leaves half a table
/// behind; "-", a device or a FIFO is streamed (CSV only). A path ending in ".npy" is written
/// as numpy's .npy format (core/table_output.hpp): one record per move with the CSV's columns
/// as fields, with the names and types of the Python package's MOVE_DTYPE except `feature` and
/// `profile`, which are bytes here (line uint64, layer int32, extrude_only bool); a feature name
/// longer than kMovesNpyFeatureBytes is an error naming its line (never cut).
class MovesFile final : public Sink {
 public:
  explicit MovesFile(std::string path, OutputOptions options = {});
  MovesFile(const MovesFile&) = delete;
  MovesFile& operator=(const MovesFile&) = delete;
  void consume(const PlanBatch& batch) override;
  void commit();
  [[nodiscard]] TableFormat format() const { return format_; }
  [[nodiscard]] std::uint64_t rows() const { return rows_; }

 private:
  TableFormat format_;
  std::optional<OutputFile> csv_;
  std::optional<NpyTable> npy_;
  std::string path_;
  std::uint64_t rows_ = 0;
};

}  // namespace amctl::plan
