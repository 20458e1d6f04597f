#include "amctl/resonance/record.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iostream>
#include <iterator>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/core/input.hpp"
#include "amctl/resonance/calibrate.hpp"

namespace amctl::resonance {
namespace {

constexpr std::array<std::string_view, 4> kRawColumns{"time", "accel_x", "accel_y", "accel_z"};
constexpr std::array<std::string_view, 4> kCorpusColumns{"time_s", "accel_x_mm_s2",
                                                         "accel_y_mm_s2", "accel_z_mm_s2"};
constexpr std::array<std::string_view, 5> kPsdColumns{"freq", "psd_x", "psd_y", "psd_z",
                                                      "psd_xyz"};

constexpr std::string_view kExpectedHeaders =
    "'#time,accel_x,accel_y,accel_z' (Klipper raw), "
    "'#time_s,accel_x_mm_s2,accel_y_mm_s2,accel_z_mm_s2' (corpus) or "
    "'freq,psd_x,psd_y,psd_z,psd_xyz' (Klipper PSD)";

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      out.push_back(trim(line.substr(start)));
      return out;
    }
    out.push_back(trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
}

/// A header line split as CSV: a field may be quoted ("a,b.csv"), "" inside quotes is one ".
std::vector<std::string> split_quoted(std::string_view line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  for (std::string& f : out) f = std::string(trim(f));
  return out;
}

/// "zv(41.6)": a shaper column of an older calibration_data CSV.
bool shaper_column(std::string_view c) {
  const std::size_t open = c.find('(');
  if (open == 0 || open == std::string_view::npos || c.back() != ')') return false;
  double v = 0;
  const std::string_view num = c.substr(open + 1, c.size() - open - 2);
  const auto [p, ec] = std::from_chars(num.data(), num.data() + num.size(), v);
  return ec == std::errc() && p == num.data() + num.size();
}

std::string shorten(std::string_view s) {
  if (s.size() <= 40) return std::string(s);
  return std::string(s.substr(0, 37)) + "...";
}

template <std::size_t N>
bool columns_are(const std::vector<std::string_view>& cols, const std::array<std::string_view, N>& want) {
  if (cols.size() != N) return false;
  for (std::size_t i = 0; i < N; ++i)
    if (cols[i] != want[i]) return false;
  return true;
}

double parse_number(std::string_view field, std::string_view column, std::size_t col_index,
                    const std::string& source, std::uint64_t line) {
  double v = 0.0;
  const char* first = field.data();
  const char* last = field.data() + field.size();
  if (!field.empty() && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (field.empty() || ec != std::errc() || ptr != last) {
    throw Error(SourceLocation{source, line, 0},
                fmt::format("column {} ({}) is '{}', expected a number", col_index + 1, column,
                            shorten(field)));
  }
  if (!std::isfinite(v)) {
    throw Error(SourceLocation{source, line, 0},
                fmt::format("column {} ({}) is '{}', expected a finite number", col_index + 1,
                            column, shorten(field)));
  }
  // An acceleration no accelerometer reads (1e308 squares to inf in the spectrum).
  if (column.rfind("accel", 0) == 0 && std::abs(v) > kAccelRange.max) {
    throw Error(SourceLocation{source, line, 0},
                fmt::format("column {} ({}) is '{}', expected an acceleration within +-{:g} mm/s^2",
                            col_index + 1, column, shorten(field), kAccelRange.max));
  }
  return v;
}

AxisClipping clipping_of(const std::vector<double>& v) {
  AxisClipping c;
  if (v.empty()) return c;
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  c.min_mm_s2 = *lo;
  c.max_mm_s2 = *hi;
  if (c.min_mm_s2 == c.max_mm_s2) {  // a constant signal: one run at both extremes
    if (v.size() >= kClipRunSamples) {
      c.runs = 1;
      c.samples = v.size();
    }
    return c;
  }
  std::size_t i = 0;
  while (i < v.size()) {
    if (v[i] != c.min_mm_s2 && v[i] != c.max_mm_s2) {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j < v.size() && v[j] == v[i]) ++j;
    if (j - i >= kClipRunSamples) {
      ++c.runs;
      c.samples += j - i;
    }
    i = j;
  }
  return c;
}

}  // namespace

std::string_view to_string(RecordFormat format) {
  switch (format) {
    case RecordFormat::klipper_raw: return "klipper_raw";
    case RecordFormat::corpus: return "corpus";
    case RecordFormat::klipper_psd: return "klipper_psd";
  }
  return "?";
}

namespace {

/// Reads a file line by line: nothing but the parsed columns is kept (bounded by the record).
class RecordParser {
 public:
  explicit RecordParser(std::string source) : source_(std::move(source)) {}

  /// One line (without its '\n'); `offset` is the byte offset of its first character.
  void feed(std::string_view raw, std::uint64_t offset) {
    ++line_no;
    if (line_no == 1 && raw.substr(0, 3) == "\xEF\xBB\xBF") {  // a UTF-8 byte-order mark
      raw.remove_prefix(3);
      offset += 3;
    }
    for (std::size_t i = 0; i < raw.size(); ++i) {
      const auto c = static_cast<unsigned char>(raw[i]);
      if (c < 0x20 && c != '\t' && c != '\r' && c != '\f') {
        throw Error(fmt::format(
            "{}: binary file (byte 0x{:02x} at offset {}), expected an accelerometer CSV with "
            "header {}",
            source_, c, offset + i, kExpectedHeaders));
      }
    }
    const std::string_view line = trim(raw);
    if (line.empty()) return;
    any_text = true;
    feed_line(line);
  }

  [[nodiscard]] std::size_t rows() const {
    return out.format == RecordFormat::klipper_psd ? out.psd.freq_hz.size() : out.record.time_s.size();
  }
  void reserve(std::size_t n) {
    if (out.format == RecordFormat::klipper_psd || n > (std::size_t{1} << 34)) return;
    out.record.time_s.reserve(n);
    out.record.accel_x_mm_s2.reserve(n);
    out.record.accel_y_mm_s2.reserve(n);
    out.record.accel_z_mm_s2.reserve(n);
  }

  AccelFile finish() {
    if (!any_text) {
      throw Error(fmt::format("{}: empty file, expected an accelerometer CSV with header {}",
                              source_, kExpectedHeaders));
    }
    if (!have_header) {
      throw Error(fmt::format("{}: no header, expected {}", source_, kExpectedHeaders));
    }
    const std::uint64_t where = last_data_line != 0 ? last_data_line : line_no;
    if (out.format == RecordFormat::klipper_psd) {
      if (out.psd.freq_hz.size() < 2) {
        throw Error(SourceLocation{source_, where, 0},
                    fmt::format("{} PSD row{}, expected at least 2", out.psd.freq_hz.size(),
                                out.psd.freq_hz.size() == 1 ? "" : "s"));
      }
      return std::move(out);  // a member: moved, not copied (the whole record)
    }
    out.record.source = source_;
    const std::size_t n = out.record.size();
    if (n < 2) {
      throw Error(SourceLocation{source_, where, 0},
                  fmt::format("{} sample{}, expected more than one Welch segment of {} s",
                              n, n == 1 ? "" : "s", kKlipperWindowS));
    }
    const double duration = out.record.time_s.back() - out.record.time_s.front();
    const double fs = static_cast<double>(n) / duration;
    const std::size_t m = klipper_segment_samples(fs);
    if (n <= m || m < 4) {
      throw Error(SourceLocation{source_, where, 0},
                  fmt::format("{} samples over {:.6g} s ({:.6g} Hz), expected more than {} (one "
                              "Welch segment of {} s, as Klipper needs)",
                              n, duration, fs, std::max<std::size_t>(m, 4), kKlipperWindowS));
    }
    return std::move(out);  // a member: moved, not copied (the whole record)
  }

 private:
  void feed_line(std::string_view line) {
    if (!have_header) {
      const bool hash = line.front() == '#';
      const std::vector<std::string_view> cols = split(hash ? line.substr(1) : line);
      std::vector<std::string_view> trimmed = cols;
      if (!trimmed.empty()) trimmed[0] = trim(trimmed[0]);
      if (hash && columns_are(trimmed, kRawColumns)) {
        out.format = RecordFormat::klipper_raw;
        names.assign(kRawColumns.begin(), kRawColumns.end());
      } else if (hash && columns_are(trimmed, kCorpusColumns)) {
        out.format = RecordFormat::corpus;
        names.assign(kCorpusColumns.begin(), kCorpusColumns.end());
      } else if (!hash && !trimmed.empty() && trimmed[0] == "freq" && trimmed.size() >= 2) {
        read_psd_header(line);
      } else if (hash && line.find(',') == std::string_view::npos) {
        return;  // a comment before the header; a '#' line with commas is a header
      } else {
        throw Error(SourceLocation{source_, line_no, 0},
                    fmt::format("header '{}', expected {}", shorten(line), kExpectedHeaders));
      }
      if (out.format != RecordFormat::klipper_psd || sets == 0) ncols = names.size();
      have_header = true;
      return;
    }
    if (line.front() == '#') return;  // comments between rows, as numpy.loadtxt skips them

    const std::vector<std::string_view> fields = split(line);
    const bool psd = out.format == RecordFormat::klipper_psd;
    // After the PSD columns a normalised file has an empty column and one value per shaper
    // (an older file: one value per shaper, without the empty column).
    if (fields.size() < ncols || (!psd && fields.size() > ncols) ||
        (psd && !out.psd.normalized && fields.size() > ncols)) {
      std::string want;
      for (std::size_t i = 0; i < names.size(); ++i) want += (i ? "," : "") + std::string(names[i]);
      for (const std::string& n : set_names) want += "," + n;
      throw Error(SourceLocation{source_, line_no, 0},
                  fmt::format("{} column{}, expected {} ({})", fields.size(),
                              fields.size() == 1 ? "" : "s", ncols, want));
    }
    if (sets > 0) {  // a several-record PSD file: freq and one psd_xyz per record
      std::vector<double> v(ncols);
      for (std::size_t i = 0; i < ncols; ++i) {
        v[i] = parse_number(fields[i], i == 0 ? std::string_view("freq") : std::string_view(set_names[i - 1]), i,
                            source_, line_no);
      }
      check_increasing(v[0], true);
      for (std::size_t k = 0; k < sets; ++k) {
        PsdTable& t = k == 0 ? out.psd : out.more_psd[k - 1];
        t.freq_hz.push_back(v[0]);
        t.psd_xyz.push_back(v[k + 1]);
      }
      return;
    }
    std::array<double, 5> v{};
    for (std::size_t i = 0; i < ncols; ++i) v[i] = parse_number(fields[i], names[i], i, source_, line_no);
    check_increasing(v[0], psd);
    if (psd) {
      out.psd.freq_hz.push_back(v[0]);
      out.psd.psd_x.push_back(v[1]);
      out.psd.psd_y.push_back(v[2]);
      out.psd.psd_z.push_back(v[3]);
      out.psd.psd_xyz.push_back(v[4]);
    } else {
      out.record.time_s.push_back(v[0]);
      out.record.accel_x_mm_s2.push_back(v[1]);
      out.record.accel_y_mm_s2.push_back(v[2]);
      out.record.accel_z_mm_s2.push_back(v[3]);
    }
    }

  void check_increasing(double first, bool psd) {
    if (last_data_line != 0 && !(first > prev_t)) {
      throw Error(SourceLocation{source_, line_no, 0},
                  fmt::format("{} {} is not after {} on line {}, expected {} to increase",
                              psd ? "freq" : names[0], first, prev_t, prev_line,
                              psd ? "frequency" : "time"));
    }
    prev_t = first;
    prev_line = line_no;
    last_data_line = line_no;
  }

  /// "freq,psd_x,psd_y,psd_z,psd_xyz[,shapers:,...]", the older "...,psd_xyz,zv(41.6),...", or
  /// "freq,NAME1,NAME2,...[,shapers:,...]" (one record per column).
  void read_psd_header(std::string_view line) {
    const std::vector<std::string> cols = split_quoted(line);
    out.format = RecordFormat::klipper_psd;
    const bool per_axis = cols.size() >= 5 && cols[1] == "psd_x" && cols[2] == "psd_y" &&
                          cols[3] == "psd_z" && cols[4] == "psd_xyz";
    if (per_axis) {
      const bool shapers = cols.size() > 5 && cols[5] == "shapers:";
      bool older = cols.size() > 5;
      for (std::size_t i = 5; i < cols.size(); ++i) older = older && shaper_column(cols[i]);
      if (cols.size() > 5 && !shapers && !older) {
        throw Error(SourceLocation{source_, line_no, 0},
                    fmt::format("column 6 is '{}', expected 'shapers:', a shaper column such as "
                                "'mzv(25.6)' or nothing after psd_xyz",
                                shorten(cols[5])));
      }
      out.psd.normalized = shapers || older;
      names.assign(kPsdColumns.begin(), kPsdColumns.end());
      return;
    }
    // One column per record up to "shapers:".
    for (std::size_t i = 1; i < cols.size() && cols[i] != "shapers:"; ++i) {
      if (cols[i].empty() || cols[i].starts_with("psd_")) {
        throw Error(SourceLocation{source_, line_no, 0},
                    fmt::format("header '{}', expected {} or freq and one column per record",
                                shorten(line), kExpectedHeaders));
      }
      set_names.push_back(cols[i]);
    }
    if (set_names.empty()) {
      throw Error(SourceLocation{source_, line_no, 0},
                  fmt::format("header '{}', expected {} or freq and one column per record",
                              shorten(line), kExpectedHeaders));
    }
    const bool normalized = std::find(cols.begin(), cols.end(), "shapers:") != cols.end();
    sets = set_names.size();
    ncols = sets + 1;
    out.psd.normalized = normalized;
    out.psd.name = set_names[0];
    for (std::size_t k = 1; k < sets; ++k) {
      PsdTable t;
      t.normalized = normalized;
      t.name = set_names[k];
      out.more_psd.push_back(std::move(t));
    }
    names.assign(1, "freq");
  }

  std::string source_;
  AccelFile out;
  std::size_t sets = 0;                // records of a several-record PSD file
  std::vector<std::string> set_names;  // their names
  std::uint64_t line_no = 0;
  bool any_text = false;
  bool have_header = false;
  std::size_t ncols = 0;
  std::vector<std::string_view> names;
  std::uint64_t last_data_line = 0;
  double prev_t = 0.0;
  std::uint64_t prev_line = 0;
};

}  // namespace

namespace {

AccelFile parse_lines(LineReader& reader, RecordParser& parser, std::optional<std::uint64_t> size) {
  std::string_view line;
  std::uint64_t offset = 0;
  bool reserved = false;
  while (reader.next(line)) {
    parser.feed(line, offset);
    offset = reader.bytes_read();
    // Once the rows' length is known, room for all of them at once: no vector doubling, so
    // the record takes its 32 bytes per sample and not up to twice that while it grows.
    if (!reserved && size && parser.rows() == 4096) {
      reserved = true;
      const double per_row = static_cast<double>(offset) / static_cast<double>(parser.rows());
      parser.reserve(static_cast<std::size_t>(1.02 * static_cast<double>(*size) / per_row) + 16);
    }
  }
  return parser.finish();
}

}  // namespace

AccelFile parse_accel_text(std::string_view text, const std::string& source) {
  RecordParser parser(source);
  LineReader reader(text, source);
  return parse_lines(reader, parser, std::nullopt);
}

AccelFile read_accel_file(const std::string& path) {
  InputFile in(path, InputOptions{"accelerometer CSV", false, 0});
  RecordParser parser(path);
  LineReader reader(in);
  return parse_lines(reader, parser, in.size());
}

std::optional<RecordSizeEstimate> estimate_record_size(const std::string& path) {
  if (path == "-") return std::nullopt;
  // Only a regular file is measured: a pipe opened and closed here would lose its writer.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
  InputFile in(path, InputOptions{"accelerometer CSV", false, 0});
  if (!in.size() || *in.size() == 0) return std::nullopt;
  // The first 64 KiB tell the bytes per row (the header and comments included: a slight
  // overestimate of the rows).
  std::string head(65536, '\0');
  std::size_t got = 0;
  for (std::size_t n = 0; got < head.size() && (n = in.read(head.data() + got, head.size() - got)) != 0;) got += n;
  head.resize(got);
  std::size_t lines = 0;
  for (char c : head) lines += c == '\n' ? 1 : 0;
  if (lines == 0) return std::nullopt;
  RecordSizeEstimate e;
  e.bytes = *in.size();
  e.samples = static_cast<std::uint64_t>(static_cast<double>(*in.size()) / static_cast<double>(got) *
                                         static_cast<double>(lines));
  e.memory_bytes = e.samples * kRecordBytesPerSample;
  return e;
}

RecordQuality assess_record(const AccelRecord& record) {
  const std::size_t n = record.size();
  if (n < 2) throw Error(fmt::format("{}: {} samples, expected at least 2", record.source, n));
  RecordQuality q;
  q.samples = n;
  q.duration_s = record.time_s.back() - record.time_s.front();
  q.mean_sample_rate_hz = static_cast<double>(n) / q.duration_s;
  // One array of n - 1 intervals for the median (reordered by nth_element); the pass over the
  // intervals in order below takes them from the times again (a 10-million-row record: 80 MB
  // instead of 160 MB).
  auto dt = [&record](std::size_t i) { return record.time_s[i + 1] - record.time_s[i]; };
  std::vector<double> sorted(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) sorted[i] = dt(i);
  const std::size_t mid = sorted.size() / 2;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid), sorted.end());
  double median = sorted[mid];
  if (sorted.size() % 2 == 0) {
    const double lower = *std::max_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid));
    median = 0.5 * (median + lower);
  }
  q.median_interval_s = median;
  q.sample_rate_hz = 1.0 / median;
  double sum_sq = 0.0;
  std::size_t regular = 0;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double d = dt(i);
    if (d > kGapFactor * median) {
      ++q.gaps;
      q.largest_gap_s = std::max(q.largest_gap_s, d);
      q.missing_s += d - median;
      continue;
    }
    const double rel = (d - median) / median;
    sum_sq += rel * rel;
    q.max_interval_deviation = std::max(q.max_interval_deviation, std::abs(rel));
    ++regular;
  }
  q.jitter = regular > 0 ? std::sqrt(sum_sq / static_cast<double>(regular)) : 0.0;
  q.clip_x = clipping_of(record.accel_x_mm_s2);
  q.clip_y = clipping_of(record.accel_y_mm_s2);
  q.clip_z = clipping_of(record.accel_z_mm_s2);
  return q;
}

}  // namespace amctl::resonance
