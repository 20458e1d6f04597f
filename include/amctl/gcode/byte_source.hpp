#pragma once
// A stream of bytes that G-code text is read from: a file, standard input, or a decoder over
// another stream (binary G-code, a plate of a sliced 3MF; include/amctl/formats/). The line
// reader pulls from it in large chunks, so one virtual call serves about a megabyte of text.
#include <cstddef>
#include <cstdint>
#include <string>

namespace amctl::gcode {

class ByteSource {
 public:
  virtual ~ByteSource() = default;
  /// Copies up to `n` bytes into `dst` and returns how many; 0 only at the end of the stream.
  /// Throws amctl::Error on a read error or malformed input (naming the file and the place).
  virtual std::size_t read(char* dst, std::size_t n) = 0;
  /// Where the byte at `offset` of this stream (0-based) came from, for messages: empty when
  /// the stream is the file's own bytes, else for example "G-code block 3, the file's block 8
  /// at byte 4711" or "Metadata/plate_1.gcode".
  [[nodiscard]] virtual std::string origin(std::uint64_t offset) const {
    (void)offset;
    return {};
  }
};

}  // namespace amctl::gcode
