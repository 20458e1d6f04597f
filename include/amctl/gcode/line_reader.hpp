#pragma once
// G-code lines: amctl's one input reader (core/input.hpp): byte source -> decoder -> lines.
// A file of any size is read once, in bounded memory; "-" reads standard input; a FIFO works;
// lines end at LF, CRLF or a lone CR (docs/gcode.md, "Line ends"). A path is opened by its
// content (text, binary G-code, a sliced 3MF, gzip) with formats::open_gcode_reader(); this
// class reads a byte stream or an in-memory text.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "amctl/core/input.hpp"

namespace amctl::gcode {

/// The options of a G-code input (what = "G-code file").
[[nodiscard]] InputOptions gcode_input_options(bool rewindable = false);

class LineReader : public amctl::LineReader {
 public:
  /// Reads a byte stream (a file, or a decoder of binary G-code or of a 3MF plate:
  /// formats/input.hpp), which it owns. `name` is used in messages.
  LineReader(std::unique_ptr<ByteSource> source, std::string name, std::size_t buffer_bytes = kDefaultBufferBytes)
      : amctl::LineReader(std::move(source), std::move(name), buffer_bytes) {}
  /// Reads an in-memory text (tests, fuzzing). `name` is used in messages.
  LineReader(std::string_view text, std::string name) : amctl::LineReader(text, std::move(name)) {}
};

}  // namespace amctl::gcode
