#pragma once
// Streaming line reader: a fixed-size buffer, so a file of any size is read in bounded
// memory. Lines longer than the buffer are an error (no real G-code line comes close).
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/gcode/byte_source.hpp"

namespace amctl::gcode {

class LineReader {
 public:
  static constexpr std::size_t kDefaultBufferBytes = 1u << 20;

  /// Opens `path` ("-" reads standard input). Throws amctl::Error if it cannot be opened.
  explicit LineReader(const std::string& path, std::size_t buffer_bytes = kDefaultBufferBytes);
  /// Reads from an in-memory text (tests, fuzzing). `name` is used in messages.
  LineReader(std::string_view text, std::string name);
  /// Reads from a byte stream (a decoder of binary G-code or of a 3MF plate: formats/input.hpp
  /// opens a path by its content). `name` is used in messages.
  LineReader(std::unique_ptr<ByteSource> source, std::string name,
             std::size_t buffer_bytes = kDefaultBufferBytes);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /// Next line without its terminator ('\n'; a preceding '\r' is dropped). Returns false at
  /// end of input. Throws amctl::Error on a read error or an over-long line. The view stays
  /// valid until the next call.
  /// The common case (a complete line already in the buffer) is inline: it runs once per line.
  bool next(std::string_view& line) {
    const bool in_memory = in_memory_;
    const char* data = in_memory ? memory_.data() : buf_.data() + begin_;
    const std::size_t avail = in_memory ? memory_.size() : end_ - begin_;
    const void* hit = avail != 0 ? std::memchr(data, '\n', avail) : nullptr;
    if (hit == nullptr) return next_slow(line);
    const auto len = static_cast<std::size_t>(static_cast<const char*>(hit) - data);
    if (in_memory) {
      memory_.remove_prefix(len + 1);
    } else {
      begin_ += len + 1;
    }
    line_start_ = bytes_;
    bytes_ += len + 1;
    ++line_no_;
    line = std::string_view(data, len != 0 && data[len - 1] == '\r' ? len - 1 : len);
    return true;
  }

  /// 1-based number of the line last returned.
  [[nodiscard]] std::uint64_t line_number() const { return line_no_; }
  [[nodiscard]] const std::string& name() const { return name_; }
  /// Bytes consumed so far (for progress).
  [[nodiscard]] std::uint64_t bytes_read() const { return bytes_; }
  /// True if the input did not end with a newline (a possibly truncated file).
  [[nodiscard]] bool ended_without_newline() const { return no_final_newline_; }
  /// Where the line last returned came from inside the file, when the text is decoded from
  /// a container ("G-code block 3, the file's block 8 at byte 4711"); empty for plain text.
  [[nodiscard]] std::string origin_of_line() const {
    return source_ ? source_->origin(line_start_) : std::string();
  }

 private:
  bool next_slow(std::string_view& line);  // refills the buffer; the last unterminated line
  bool refill();

  std::string name_;
  std::FILE* file_ = nullptr;
  bool owns_file_ = false;
  std::unique_ptr<ByteSource> source_;  // read instead of file_ when set
  bool in_memory_ = false;
  std::vector<char> buf_;
  std::size_t begin_ = 0;  // start of unconsumed data
  std::size_t end_ = 0;    // end of valid data
  bool eof_ = false;
  bool no_final_newline_ = false;
  std::string_view memory_;  // in-memory mode when file_ == nullptr
  std::uint64_t line_no_ = 0;
  std::uint64_t bytes_ = 0;
  std::uint64_t line_start_ = 0;  // offset of the line last returned
};

}  // namespace amctl::gcode
