#include "amctl/process/csv.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/input.hpp"
#include "amctl/core/text_input.hpp"


namespace amctl::process {
namespace {

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  }
  return true;
}

std::string_view trim(std::string_view s, std::size_t& offset) {
  offset = 0;
  while (offset < s.size() && std::isspace(static_cast<unsigned char>(s[offset]))) ++offset;
  std::size_t end = s.size();
  while (end > offset && std::isspace(static_cast<unsigned char>(s[end - 1]))) --end;
  return s.substr(offset, end - offset);
}

}  // namespace

CsvTable CsvTable::parse(std::string_view text, std::string file) {
  CsvTable t;
  t.file_ = std::move(file);
  std::uint64_t line_no = 0;
  std::size_t pos = 0;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") pos = 3;  // UTF-8 byte order mark
  bool have_header = false;
  while (pos <= text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    std::string_view line = text.substr(pos, eol - pos);
    const std::size_t line_start = pos;
    (void)line_start;
    pos = eol + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    std::size_t off = 0;
    const std::string_view body = trim(line, off);
    if (body.empty() || body.front() == '#') {
      if (eol == text.size()) break;
      continue;
    }
    std::vector<std::string> fields;
    std::vector<std::uint32_t> cols;
    std::size_t i = 0;
    while (true) {
      std::size_t start = i;
      std::string field;
      // Skip leading spaces to detect a quoted field.
      std::size_t j = i;
      while (j < line.size() && (line[j] == ' ' || line[j] == '\t')) ++j;
      if (j < line.size() && line[j] == '"') {
        std::size_t k = j + 1;
        bool closed = false;
        while (k < line.size()) {
          if (line[k] == '"') {
            if (k + 1 < line.size() && line[k + 1] == '"') {
              field.push_back('"');
              k += 2;
              continue;
            }
            closed = true;
            ++k;
            break;
          }
          field.push_back(line[k++]);
        }
        if (!closed) {
          throw Error(SourceLocation{t.file_, line_no, static_cast<std::uint32_t>(j + 1)},
                      "unterminated quoted field, expected a closing '\"'");
        }
        while (k < line.size() && line[k] != ',') ++k;
        cols.push_back(static_cast<std::uint32_t>(j + 1));
        fields.push_back(field);
        i = k;
      } else {
        std::size_t k = line.find(',', i);
        if (k == std::string_view::npos) k = line.size();
        std::size_t lead = 0;
        const std::string_view f = trim(line.substr(i, k - i), lead);
        cols.push_back(static_cast<std::uint32_t>(start + lead + 1));
        fields.emplace_back(f);
        i = k;
      }
      if (i >= line.size()) break;
      ++i;  // skip comma
    }
    if (!have_header) {
      t.header_ = std::move(fields);
      t.header_line_ = line_no;
      have_header = true;
    } else {
      if (fields.size() != t.header_.size()) {
        throw Error(SourceLocation{t.file_, line_no, 1},
                    fmt::format("found {} field(s), expected {} (the columns of the header)",
                                fields.size(), t.header_.size()));
      }
      t.rows_.push_back(std::move(fields));
      t.line_.push_back(line_no);
      t.column_.push_back(std::move(cols));
    }
    if (eol == text.size()) break;
  }
  if (!have_header) throw Error(SourceLocation{t.file_, 0, 0}, "found an empty file, expected a CSV table with a header row");
  return t;
}

CsvTable CsvTable::read(const std::string& path) {
  InputOptions o;
  o.what = "CSV table";
  return parse(read_whole_text(path, std::move(o)), path);
}

std::optional<std::size_t> CsvTable::find(std::string_view name) const {
  for (std::size_t i = 0; i < header_.size(); ++i) {
    if (iequals(header_[i], name)) return i;
  }
  return std::nullopt;
}

std::size_t CsvTable::require(std::string_view name) const {
  if (auto i = find(name)) return *i;
  std::string cols;
  for (const auto& h : header_) cols += (cols.empty() ? "" : ", ") + h;
  throw Error(SourceLocation{file_, header_line_, 0},
              fmt::format("expected a column '{}' in the header, found: {}", name, cols));
}

const std::string& CsvTable::text(std::size_t row, std::size_t col) const {
  AMCTL_CHECK(row < rows_.size() && col < header_.size(), "CSV index out of range");
  return rows_[row][col];
}

SourceLocation CsvTable::where(std::size_t row, std::size_t col) const {
  return SourceLocation{file_, line_[row], column_[row][col]};
}

double CsvTable::number(std::size_t row, std::size_t col) const {
  const std::string& s = text(row, col);
  double v = 0.0;
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (!s.empty() && *b == '+') ++b;
  auto [p, ec] = std::from_chars(b, e, v);
  if (s.empty() || ec != std::errc() || p != e || !std::isfinite(v)) {
    throw Error(where(row, col), fmt::format("column '{}': expected a finite number, got '{}'",
                                             header_[col], s));
  }
  return v;
}

std::string read_file_bytes(const std::string& path, std::string_view what, std::uint64_t max_bytes) {
  InputOptions o;
  o.what = std::string(what);
  o.max_bytes = max_bytes;
  return read_whole_input(path, std::move(o));
}

void write_file_atomic(const std::string& path, std::string_view content, const OutputOptions& options) {
  write_output(path, content, options);
}

}  // namespace amctl::process
