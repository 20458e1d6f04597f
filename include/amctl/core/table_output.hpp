#pragma once
// Tables written as numpy's .npy format, for the large outputs (planned moves, steps,
// compensated commands, simulated traces) that CSV makes slow to write and slow to read
// (docs/architecture.md, "Inputs and outputs"; docs/outputs.md). The format is chosen by the
// output's name: a path ending in ".npy" is written as a one-dimensional structured array (one
// record per row, one named field per column), anything else as the job's CSV.
//
// The .npy layout (numpy's "NEP 1: A simple file format for NumPy arrays", format version 1.0):
// the 6 bytes "\x93NUMPY", the version bytes 1 and 0, a little-endian uint16 header length,
// then an ASCII Python-literal dict {'descr': [...], 'fortran_order': False, 'shape': (N,), }
// padded with spaces and ended by '\n' so the data starts at a multiple of 64 bytes; then the
// N records, packed, little-endian. numpy.load reads it as is, pandas as
// pandas.DataFrame(numpy.load(path)); no amctl code is needed to read it.
//
// The file is written in one pass, in bounded memory: the header is written first with room
// for any row count and rewritten with the real count when the table is complete, so a .npy
// output needs a regular file (a pipe or a device cannot be rewritten) and, like every amctl
// output, appears whole at commit() or not at all.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/output.hpp"

namespace amctl {

/// How a table output is written.
enum class TableFormat { csv, npy };
/// npy for a path ending in ".npy" (any case), csv otherwise ("-" included).
[[nodiscard]] TableFormat table_format_for(std::string_view path);
[[nodiscard]] const char* to_string(TableFormat format);

/// The numpy types a column can have.
enum class NpyType {
  f8,    ///< float64, '<f8'
  i8,    ///< int64, '<i8'
  i4,    ///< int32, '<i4'
  i1,    ///< int8, '|i1'
  u8,    ///< uint64, '<u8'
  b1,    ///< bool, '|b1' (one byte, 0 or 1)
  text,  ///< fixed-width bytes, '|S<n>' (ASCII; shorter values are padded with NUL)
};

struct NpyColumn {
  std::string name;  ///< the field name numpy and pandas show (ASCII, no quotes)
  NpyType type = NpyType::f8;
  std::size_t text_bytes = 0;  ///< width of a text column [bytes], >= 1
};

/// The header of a .npy file with `rows` records of `columns` (padded to `header_bytes` when
/// that is not 0; then it must fit). Exposed for tests and for writers of other containers.
[[nodiscard]] std::string npy_header(const std::vector<NpyColumn>& columns, std::uint64_t rows,
                                     std::size_t header_bytes = 0);

/// A .npy table written row by row through amctl::OutputFile.
class NpyTable {
 public:
  /// Opens the output. Throws amctl::Error naming the path (and options.flag) when it cannot be
  /// written, or when it is a pipe, a device or standard output.
  NpyTable(std::string path, std::vector<NpyColumn> columns, OutputOptions options = {});
  /// Opens the output now (the same errors) and takes the columns later, from set_columns(),
  /// for a writer that knows them only once its work has begun.
  NpyTable(std::string path, OutputOptions options);
  /// Sets the columns and writes the header; once, before the first append.
  void set_columns(std::vector<NpyColumn> columns);
  NpyTable(const NpyTable&) = delete;
  NpyTable& operator=(const NpyTable&) = delete;

  [[nodiscard]] std::size_t record_bytes() const { return record_bytes_; }
  [[nodiscard]] std::size_t offset(std::size_t column) const { return offsets_.at(column); }
  [[nodiscard]] const std::vector<NpyColumn>& columns() const { return columns_; }

  /// Appends one packed record of record_bytes() bytes (see NpyRecord).
  void append(std::string_view record);
  /// Appends whole packed records (a multiple of record_bytes() bytes), for writers that pack
  /// many rows at once.
  void append_records(std::string_view records);
  /// Writes the row count into the header and commits the file.
  void commit();

  [[nodiscard]] std::uint64_t rows() const { return rows_; }
  [[nodiscard]] std::uint64_t bytes() const { return out_.bytes(); }
  [[nodiscard]] const std::string& path() const { return out_.path(); }

 private:
  OutputFile out_;
  std::vector<NpyColumn> columns_;
  std::vector<std::size_t> offsets_;
  std::size_t record_bytes_ = 0;
  std::size_t header_bytes_ = 0;
  std::uint64_t rows_ = 0;
};

/// One record in NpyTable's packed layout, filled column by column.
class NpyRecord {
 public:
  explicit NpyRecord(const NpyTable& table);
  /// A float64 column.
  NpyRecord& set(std::size_t column, double value);
  /// An integer column (i8, i4, i1, u8, b1); the value must fit the column's type.
  NpyRecord& set_int(std::size_t column, std::int64_t value);
  /// A text column; the value must fit its width.
  NpyRecord& set_text(std::size_t column, std::string_view value);
  [[nodiscard]] std::string_view bytes() const { return bytes_; }

 private:
  const NpyTable* table_;
  std::string bytes_;
};

}  // namespace amctl
