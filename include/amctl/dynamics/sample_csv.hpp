#pragma once
// The per-sample CSV of a simulation (`amctl simulate --csv`):
//   t_s,cmd_x_mm,cmd_y_mm,cmd_z_mm,sim_x_mm,sim_y_mm,contour_error_mm,vibration_mm,line
// one row every `decimation`-th sample inside the measured range, written through
// amctl::OutputFile: a regular file appears at commit() whole or not at all (an error never
// leaves half a CSV behind); "-", a device or a FIFO is streamed. A path ending in ".npy" is
// written as numpy's .npy format instead (core/table_output.hpp): the same columns as fields,
// float64 at full precision, `line` uint64.
#include <cstddef>
#include <optional>
#include <string>

#include "amctl/core/output.hpp"
#include "amctl/core/table_output.hpp"
#include "amctl/dynamics/simulate.hpp"

namespace amctl::dynamics {

/// sample_rate_hz / csv_rate_hz (default: every sample), which must be a whole number.
/// Throws amctl::Error naming --csv-rate-hz otherwise.
[[nodiscard]] std::size_t csv_decimation(double sample_rate_hz, std::optional<double> csv_rate_hz);

class SampleCsvFile {
 public:
  SampleCsvFile(const std::string& path, std::size_t decimation, OutputOptions options = {});
  SampleCsvFile(const SampleCsvFile&) = delete;
  SampleCsvFile& operator=(const SampleCsvFile&) = delete;

  /// The first sample handed to row() is `first_step` output steps from the grid the rows
  /// are aligned to (<= 0 for a run that starts early, as a shaped command does), so rows
  /// fall on the same times whatever the run.
  void set_first_step(long long first_step);
  /// One sample and its contour error (NaN: outside the measured range, not written).
  void row(const SimSample& s, double contour_error_mm);
  /// Closes the file and renames it into place. Throws amctl::Error if it cannot.
  void commit();

 private:
  std::optional<OutputFile> csv_;
  std::optional<NpyTable> npy_;
  std::size_t decimation_;
  std::size_t k_ = 0;
};

}  // namespace amctl::dynamics
