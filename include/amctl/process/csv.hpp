#pragma once
// A minimal CSV table: a header row naming the columns, then data rows. Fields are
// separated by commas; surrounding whitespace is trimmed; "#" starts a comment line; fields
// may be wrapped in double quotes. Every error names file:line:col.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/output.hpp"
#include "amctl/core/error.hpp"

namespace amctl::process {

class CsvTable {
 public:
  /// Parses `text`; `file` is used only in error messages.
  static CsvTable parse(std::string_view text, std::string file);
  /// Reads and parses a file (amctl::Error when it cannot be opened).
  static CsvTable read(const std::string& path);

  [[nodiscard]] const std::vector<std::string>& header() const { return header_; }
  [[nodiscard]] std::size_t rows() const { return rows_.size(); }
  /// Index of the column named exactly `name` (case-insensitive), if present.
  [[nodiscard]] std::optional<std::size_t> find(std::string_view name) const;
  /// Index of a required column; throws naming the file and the columns found.
  [[nodiscard]] std::size_t require(std::string_view name) const;
  [[nodiscard]] const std::string& text(std::size_t row, std::size_t col) const;
  /// The field parsed as a finite number; throws with file:line:col otherwise.
  [[nodiscard]] double number(std::size_t row, std::size_t col) const;
  [[nodiscard]] SourceLocation where(std::size_t row, std::size_t col) const;
  [[nodiscard]] const std::string& file() const { return file_; }
  /// 1-based line of the header row.
  [[nodiscard]] std::uint64_t header_line() const { return header_line_; }

 private:
  std::string file_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<std::uint64_t> line_;                 // 1-based source line of each row
  std::vector<std::vector<std::uint32_t>> column_;  // 1-based source column of each field
  std::uint64_t header_line_ = 0;
};

/// Writes `content` to `path` through amctl::OutputFile (core/output.hpp): a regular file
/// atomically (on any failure `path` is left untouched and amctl::Error is thrown), "-", a
/// device or a FIFO streamed.
void write_file_atomic(const std::string& path, std::string_view content,
                       const OutputOptions& options = {});

/// Reads a whole file as bytes through amctl's one input reader (core/input.hpp): "-" is
/// standard input; amctl::Error naming the path when it cannot be read, is a directory, or is
/// larger than `max_bytes` (checked before reading when the size is known). `what` names the
/// kind of file in messages.
[[nodiscard]] std::string read_file_bytes(const std::string& path, std::string_view what = "file",
                                          std::uint64_t max_bytes = 256ull << 20);

}  // namespace amctl::process
