// The .npy table writer (amctl/core/table_output.hpp).
#include "amctl/core/table_output.hpp"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cstring>
#include <limits>

#include <sys/stat.h>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl {

static_assert(std::endian::native == std::endian::little,
              "the .npy writer packs records in the host's byte order and declares it little-endian");

namespace {

constexpr std::size_t kNpyPreamble = 10;  // magic (6), version (2), header length (2)
constexpr std::size_t kNpyAlign = 64;

std::size_t width_of(const NpyColumn& c) {
  switch (c.type) {
    case NpyType::f8:
    case NpyType::i8:
    case NpyType::u8: return 8;
    case NpyType::i4: return 4;
    case NpyType::i1:
    case NpyType::b1: return 1;
    case NpyType::text: return c.text_bytes;
  }
  return 0;
}

std::string descr_of(const NpyColumn& c) {
  switch (c.type) {
    case NpyType::f8: return "<f8";
    case NpyType::i8: return "<i8";
    case NpyType::u8: return "<u8";
    case NpyType::i4: return "<i4";
    case NpyType::i1: return "|i1";
    case NpyType::b1: return "|b1";
    case NpyType::text: return fmt::format("|S{}", c.text_bytes);
  }
  return "";
}

void check_columns(const std::vector<NpyColumn>& columns) {
  AMCTL_CHECK(!columns.empty(), "a .npy table needs at least one column");
  for (const NpyColumn& c : columns) {
    AMCTL_CHECK(!c.name.empty(), "a .npy column needs a name");
    for (const char ch : c.name) {
      AMCTL_CHECK(std::isprint(static_cast<unsigned char>(ch)) && ch != '\'' && ch != '\\',
                  "a .npy column name must be printable ASCII without quotes");
    }
    AMCTL_CHECK(c.type != NpyType::text || c.text_bytes >= 1, "a .npy text column needs a width");
  }
}

/// The path, when it names a file that can be rewritten (not "-", a FIFO or a device): checked
/// before OutputFile opens it, as opening a FIFO would wait for its reader.
std::string refuse_streamed(std::string path, const OutputOptions& options) {
  struct stat st {};
  const bool streamed = path == "-" || (::stat(path.c_str(), &st) == 0 && (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode)));
  if (streamed) {
    throw Error(SourceLocation{path, 0, 0},
                fmt::format("{}is a pipe, a device or standard output; a .npy file holds its "
                            "row count in its header, written when the table is complete, so "
                            "expected a regular file (or a .csv name to stream the rows)",
                            options.flag.empty() ? std::string() : options.flag + " "));
  }
  return path;
}

}  // namespace

TableFormat table_format_for(std::string_view path) {
  if (path.size() < 4) return TableFormat::csv;
  std::string ext(path.substr(path.size() - 4));
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext == ".npy" ? TableFormat::npy : TableFormat::csv;
}

const char* to_string(TableFormat format) {
  switch (format) {
    case TableFormat::csv: return "csv";
    case TableFormat::npy: return "npy";
  }
  return "?";
}

std::string npy_header(const std::vector<NpyColumn>& columns, std::uint64_t rows,
                       std::size_t header_bytes) {
  check_columns(columns);
  std::string dict = "{'descr': [";
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (i > 0) dict += ", ";
    dict += fmt::format("('{}', '{}')", columns[i].name, descr_of(columns[i]));
  }
  dict += fmt::format("], 'fortran_order': False, 'shape': ({},), }}", rows);
  // Padded with spaces, ended by '\n', so that preamble + dict is a multiple of 64 (or the
  // size asked for).
  std::size_t total = header_bytes;
  if (total == 0) {
    total = (kNpyPreamble + dict.size() + 1 + kNpyAlign - 1) / kNpyAlign * kNpyAlign;
  }
  AMCTL_CHECK(total >= kNpyPreamble + dict.size() + 1, "the .npy header does not fit its room");
  const std::size_t dict_len = total - kNpyPreamble;
  AMCTL_CHECK(dict_len <= std::numeric_limits<std::uint16_t>::max(),
              "a .npy version 1.0 header is at most 65535 bytes");
  dict.append(dict_len - dict.size() - 1, ' ');
  dict += '\n';
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(dict_len & 0xff);
  out += static_cast<char>((dict_len >> 8) & 0xff);
  out += dict;
  return out;
}

NpyTable::NpyTable(std::string path, std::vector<NpyColumn> columns, OutputOptions options)
    : NpyTable(std::move(path), std::move(options)) {
  set_columns(std::move(columns));
}

NpyTable::NpyTable(std::string path, OutputOptions options)
    : out_(refuse_streamed(std::move(path), options), options) {
  AMCTL_CHECK(!out_.streamed(), "a .npy output opened as a stream");
}

void NpyTable::set_columns(std::vector<NpyColumn> columns) {
  AMCTL_CHECK(columns_.empty(), "NpyTable::set_columns twice");
  check_columns(columns);
  columns_ = std::move(columns);
  for (const NpyColumn& c : columns_) {
    offsets_.push_back(record_bytes_);
    record_bytes_ += width_of(c);
  }
  // Room for any row count: the header of the largest count, written now with 0.
  header_bytes_ = npy_header(columns_, std::numeric_limits<std::uint64_t>::max()).size();
  out_.write(npy_header(columns_, 0, header_bytes_));
}

void NpyTable::append(std::string_view record) {
  AMCTL_CHECK(!columns_.empty() && record.size() == record_bytes_, "a .npy record of the wrong size");
  out_.write(record);
  ++rows_;
}

void NpyTable::append_records(std::string_view records) {
  AMCTL_CHECK(!columns_.empty() && records.size() % record_bytes_ == 0, "packed .npy records of the wrong size");
  out_.write(records);
  rows_ += records.size() / record_bytes_;
}

void NpyTable::commit() {
  AMCTL_CHECK(!columns_.empty(), "NpyTable::commit without columns");
  out_.overwrite_at(0, npy_header(columns_, rows_, header_bytes_));
  out_.commit();
}

NpyRecord::NpyRecord(const NpyTable& table)
    : table_(&table), bytes_(table.record_bytes(), '\0') {}

NpyRecord& NpyRecord::set(std::size_t column, double value) {
  AMCTL_CHECK(table_->columns().at(column).type == NpyType::f8, "a float64 value for a column that is not f8");
  std::memcpy(bytes_.data() + table_->offset(column), &value, sizeof value);
  return *this;
}

NpyRecord& NpyRecord::set_int(std::size_t column, std::int64_t value) {
  const NpyType type = table_->columns().at(column).type;
  char* at = bytes_.data() + table_->offset(column);
  switch (type) {
    case NpyType::i8: std::memcpy(at, &value, 8); break;
    case NpyType::u8: {
      AMCTL_CHECK(value >= 0, "a negative value for an unsigned .npy column");
      const auto u = static_cast<std::uint64_t>(value);
      std::memcpy(at, &u, 8);
      break;
    }
    case NpyType::i4: {
      AMCTL_CHECK(value >= std::numeric_limits<std::int32_t>::min() &&
                      value <= std::numeric_limits<std::int32_t>::max(),
                  "a value that does not fit an int32 .npy column");
      const auto v = static_cast<std::int32_t>(value);
      std::memcpy(at, &v, 4);
      break;
    }
    case NpyType::i1: {
      AMCTL_CHECK(value >= -128 && value <= 127, "a value that does not fit an int8 .npy column");
      const auto v = static_cast<std::int8_t>(value);
      std::memcpy(at, &v, 1);
      break;
    }
    case NpyType::b1: {
      AMCTL_CHECK(value == 0 || value == 1, "a bool .npy column holds 0 or 1");
      at[0] = static_cast<char>(value);
      break;
    }
    default: AMCTL_CHECK(false, "an integer value for a column that is not an integer");
  }
  return *this;
}

NpyRecord& NpyRecord::set_text(std::size_t column, std::string_view value) {
  const NpyColumn& c = table_->columns().at(column);
  AMCTL_CHECK(c.type == NpyType::text && value.size() <= c.text_bytes,
              "a text value for a column that is not text, or wider than it");
  char* at = bytes_.data() + table_->offset(column);
  std::memset(at, 0, c.text_bytes);
  std::memcpy(at, value.data(), value.size());
  return *this;
}

}  // namespace amctl
