#pragma once
// The one input reader of amctl (docs/architecture.md, "Inputs and outputs"), in three layers:
//
//   byte source (InputFile: a path, "-" for standard input, a FIFO, a device)
//     -> optional decoder (a ByteSource over another ByteSource: a container format such as
//        binary G-code or a .gcode.3mf archive turned into the bytes of text)
//     -> LineReader (lines ended by LF, CRLF or a lone CR)
//
// Every input is opened once and read once, as a stream, in bounded memory. A job that needs
// a second pass (M73 progress lines need the total time first) asks for a rewindable input:
// a regular file is then read again through the same open descriptor (an error if the file
// changed in between); standard input, a FIFO or a device is copied, while it is read the
// first time, into a temporary file the reader made itself (unlinked, so nothing is left),
// and the second pass reads that copy. Anything that cannot be read as asked (a directory, a
// missing or unreadable file, a file beyond the size a reader accepts) is an amctl::Error
// naming it.
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/output.hpp"

namespace amctl {

/// A stream of bytes (layer 1, or a decoder of layer 2).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  /// Up to `n` bytes into `dst`; 0 only at the end. Throws amctl::Error naming the input on a
  /// read error or malformed data (a decoder).
  virtual std::size_t read(char* dst, std::size_t n) = 0;
  /// The name used in messages (the path as given, "<stdin>"); empty when the source does not
  /// know it (a decoder's reader is then given the name).
  [[nodiscard]] virtual const std::string& name() const;
  /// Where the byte at `offset` of this stream (0-based) came from, for messages: empty when
  /// the stream is the file's own bytes, else for example "G-code block 3, the file's block 8
  /// at byte 4711" or "Metadata/plate_1.gcode" (a decoder).
  [[nodiscard]] virtual std::string origin(std::uint64_t offset) const {
    (void)offset;
    return {};
  }
};

struct InputOptions {
  /// What the input is, for messages ("G-code file", "machine file", "accelerometer CSV").
  std::string what = "file";
  /// Keep what is read so that rewind() can start again (see the header comment).
  bool rewindable = false;
  /// Refuse an input larger than this many bytes (0: no bound), before reading it when its
  /// size is known, as soon as the bound is passed otherwise.
  std::uint64_t max_bytes = 0;
};

/// Layer 1: the bytes of a path as given ("-" is standard input).
class InputFile final : public ByteSource {
 public:
  /// Opens `path`. Throws amctl::Error naming it when it does not exist, is a directory, cannot
  /// be read, or is larger than options.max_bytes.
  explicit InputFile(const std::string& path, InputOptions options = {});
  ~InputFile() override;
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  std::size_t read(char* dst, std::size_t n) override;
  [[nodiscard]] const std::string& name() const override { return name_; }
  /// The path as given ("-" for standard input).
  [[nodiscard]] const std::string& path() const { return path_; }

  /// The first up to `n` bytes without consuming them (format detection by a decoder); only
  /// before anything was read.
  std::string_view peek(std::size_t n);
  /// Starts again at the first byte (needs options.rewindable). What the first pass did not
  /// read yet is read from the source as before.
  void rewind();

  /// Device and inode of the file read (an output must never be it); none for a pipe.
  [[nodiscard]] std::optional<FileIdentity> identity() const { return identity_; }
  /// The size in bytes when the input is a regular file.
  [[nodiscard]] std::optional<std::uint64_t> size() const { return size_; }
  /// Bytes read so far in the current pass.
  [[nodiscard]] std::uint64_t position() const { return position_; }

 private:
  std::size_t read_source(char* dst, std::size_t n);
  std::size_t fetch(char* dst, std::size_t n);  // the spool on a second pass, else the source
  [[noreturn]] void fail(const std::string& what, int err) const;

  std::string path_;
  std::string name_;
  InputOptions options_;
  int fd_ = -1;
  bool owns_fd_ = false;
  bool regular_ = false;
  std::optional<FileIdentity> identity_;
  std::optional<std::uint64_t> size_;
  std::int64_t mtime_ns_ = 0;
  std::uint64_t position_ = 0;      // bytes handed out in this pass
  std::uint64_t start_offset_ = 0;  // a regular file: where reading began (stdin redirected)
  std::string peeked_;            // read by peek(), handed out first
  // The copy of a stream for rewind(): an unlinked temporary file.
  int spool_fd_ = -1;
  std::uint64_t spool_bytes_ = 0;
  std::uint64_t spool_pos_ = 0;
  bool rewound_ = false;
};

/// Layer 2: a decoder a reader may put between the file and the lines. `detect` sees the
/// first bytes (InputFile::peek) and the path; `open` wraps the raw source (which outlives
/// the decoder). A G-code reader tries its decoders in order and reads the bytes as text
/// when none claims them.
struct Decoder {
  std::string name;
  std::function<bool(std::string_view first_bytes, std::string_view path)> detect;
  std::function<std::unique_ptr<ByteSource>(ByteSource& raw)> open;
};

/// The decoded stream of `file` (a non-owning view of `file` itself when no decoder claims it).
[[nodiscard]] std::unique_ptr<ByteSource> decode(InputFile& file, const std::vector<Decoder>& decoders);
/// Opens `path` (InputFile) and decodes it; the result owns both.
[[nodiscard]] std::unique_ptr<ByteSource> open_decoded(const std::string& path, InputOptions options,
                                                       const std::vector<Decoder>& decoders);

/// Layer 3: lines over a ByteSource, with a fixed-size buffer so that a file of any size is
/// read in bounded memory. A line ends at LF, at CRLF (one line end) or at a lone CR (old Mac
/// files, as PrusaSlicer's G-code reader and Marlin read them); lines longer than the buffer
/// are an error (no real text line comes close).
class LineReader {
 public:
  static constexpr std::size_t kDefaultBufferBytes = 1u << 20;

  /// Reads `source`, which it owns.
  explicit LineReader(std::unique_ptr<ByteSource> source, std::size_t buffer_bytes = kDefaultBufferBytes);
  /// Reads `source`, which it owns, under `name` in messages (a decoder that has no name).
  LineReader(std::unique_ptr<ByteSource> source, std::string name, std::size_t buffer_bytes = kDefaultBufferBytes);
  /// Reads `source`, which must outlive the reader.
  explicit LineReader(ByteSource& source, std::size_t buffer_bytes = kDefaultBufferBytes);
  /// Reads an in-memory text (tests, fuzzing, generated G-code). `name` is used in messages.
  LineReader(std::string_view text, std::string name);
  virtual ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /// Next line without its terminator. Returns false at the end of the input. Throws
  /// amctl::Error on a read error or an over-long line. The view stays valid until the next
  /// call. The common case (an LF-ended line already in the buffer) is inline: it runs once
  /// per line.
  bool next(std::string_view& line) {
    const char* data = in_memory_ ? memory_.data() : buf_.data() + begin_;
    const std::size_t avail = in_memory_ ? memory_.size() : end_ - begin_;
    const void* hit = avail != 0 ? std::memchr(data, '\n', avail) : nullptr;
    if (hit == nullptr) return next_slow(line);
    auto len = static_cast<std::size_t>(static_cast<const char*>(hit) - data);
    std::size_t term = 1;
    if (const void* cr = len != 0 ? std::memchr(data, '\r', len) : nullptr) {
      const auto at = static_cast<std::size_t>(static_cast<const char*>(cr) - data);
      if (at + 1 == len) {
        term = 2;  // CRLF
        len = at;
      } else {
        len = at;  // a lone CR ends this line
        term = 1;
      }
    }
    if (in_memory_) {
      memory_.remove_prefix(len + term);
    } else {
      begin_ += len + term;
    }
    line_start_ = bytes_;
    bytes_ += len + term;
    terminator_ = term == 2 ? "\r\n" : data[len] == '\r' ? "\r" : "\n";
    ++line_no_;
    line = std::string_view(data, len);
    return true;
  }

  /// 1-based number of the line last returned.
  [[nodiscard]] std::uint64_t line_number() const { return line_no_; }
  [[nodiscard]] const std::string& name() const { return name_; }
  /// Bytes consumed so far, terminators included (for progress).
  [[nodiscard]] std::uint64_t bytes_read() const { return bytes_; }
  /// The terminator of the line last returned: "\n", "\r\n", "\r", or "" for a last line
  /// without one.
  [[nodiscard]] std::string_view terminator() const { return terminator_; }
  /// True if the input did not end with a line end (a possibly truncated file).
  [[nodiscard]] bool ended_without_newline() const { return no_final_newline_; }
  /// Where the line last returned came from inside the file, when the text is decoded from
  /// a container ("G-code block 3, the file's block 8 at byte 4711"); empty for plain text.
  [[nodiscard]] std::string origin_of_line() const {
    return source_ != nullptr ? source_->origin(line_start_) : std::string();
  }

 private:
  bool next_slow(std::string_view& line);
  bool refill();

  std::string name_;
  std::unique_ptr<ByteSource> owned_;
  ByteSource* source_ = nullptr;
  bool in_memory_ = false;
  std::vector<char> buf_;
  std::size_t begin_ = 0;  // start of unconsumed data
  std::size_t end_ = 0;    // end of valid data
  bool eof_ = false;
  bool no_final_newline_ = false;
  std::string_view memory_;  // in-memory mode
  std::string_view terminator_;
  std::uint64_t line_no_ = 0;
  std::uint64_t bytes_ = 0;
  std::uint64_t line_start_ = 0;  // offset of the line last returned
};

/// A whole input in memory, for the formats read as a whole (TOML, printer.cfg, JSON, STL,
/// the small process CSVs). Refuses an input beyond options.max_bytes before allocating for it.
[[nodiscard]] std::string read_whole_input(const std::string& path, InputOptions options = {});

}  // namespace amctl
