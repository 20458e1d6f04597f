#pragma once
// The command table `amctl compensate --csv` writes: per sample, the time, the command, the
// desired path and the simulated nozzle (and the command's acceleration when the method has
// it), as CSV (9 decimals, no exponent; accelerations 6) or, for a path ending in ".npy", as
// numpy's .npy format with the same names as float64 fields and every double exact
// (core/table_output.hpp). Columns: time_s, x_cmd_mm, y_cmd_mm, x_des_mm, y_des_mm, x_sim_mm,
// y_sim_mm[, x_cmd_accel_mm_s2, y_cmd_accel_mm_s2].
#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "amctl/core/output.hpp"
#include "amctl/core/table_output.hpp"

namespace amctl::compensation {

/// One sample of the command table.
struct CommandSample {
  double t_s = 0.0;
  double x_cmd_mm = 0.0, y_cmd_mm = 0.0;
  double x_des_mm = 0.0, y_des_mm = 0.0;
  double x_sim_mm = 0.0, y_sim_mm = 0.0;
  double x_cmd_accel_mm_s2 = 0.0, y_cmd_accel_mm_s2 = 0.0;  ///< written with_accel only
};

class CommandTable {
 public:
  /// Opens the output now, so that a path that cannot be written (or is an input) fails before
  /// the work; the header is written by begin().
  CommandTable(std::string path, OutputOptions options);
  CommandTable(const CommandTable&) = delete;
  CommandTable& operator=(const CommandTable&) = delete;

  /// Writes the header; `with_accel` adds the two acceleration columns. Once, before rows.
  void begin(bool with_accel);
  [[nodiscard]] bool begun() const { return begun_; }
  void add(const CommandSample& s);
  /// Commits the file (whole or not at all).
  void commit();

  [[nodiscard]] TableFormat format() const { return format_; }
  [[nodiscard]] std::uint64_t rows() const { return rows_; }

 private:
  void flush();
  TableFormat format_;
  std::optional<OutputFile> csv_;
  std::optional<NpyTable> npy_;
  std::string buf_;
  bool begun_ = false;
  bool accel_ = false;
  std::uint64_t rows_ = 0;
};

}  // namespace amctl::compensation
