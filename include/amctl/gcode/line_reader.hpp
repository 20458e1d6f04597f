#pragma once
// G-code lines: amctl's one input reader (core/input.hpp) with the G-code decoders between the
// file and the lines (byte source -> decoder -> LineReader). A file of any size is read once,
// in bounded memory; "-" reads standard input; a FIFO works; lines end at LF, CRLF or a lone
// CR (docs/gcode.md, "Line ends").
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/input.hpp"

namespace amctl::gcode {

/// The decoders a G-code input is offered to before it is read as text (layer 2 of the
/// reader). Binary G-code (.bgcode, the "GCDE" magic) and a .gcode.3mf archive (a zip) are
/// recognised here; until their decoders exist, each is an error naming the file and the
/// format instead of being read as garbage text.
[[nodiscard]] const std::vector<Decoder>& gcode_decoders();

/// The options of a G-code input (what = "G-code file").
[[nodiscard]] InputOptions gcode_input_options(bool rewindable = false);

class LineReader : public amctl::LineReader {
 public:
  /// Opens `path` ("-" reads standard input). Throws amctl::Error if it cannot be read.
  explicit LineReader(const std::string& path, std::size_t buffer_bytes = kDefaultBufferBytes);
  /// Reads an input already open (a rewindable one for a second pass), which must outlive the
  /// reader; the decoders are applied as for a path.
  explicit LineReader(InputFile& file, std::size_t buffer_bytes = kDefaultBufferBytes);
  /// Reads an in-memory text (tests, fuzzing). `name` is used in messages.
  LineReader(std::string_view text, std::string name) : amctl::LineReader(text, std::move(name)) {}
};

}  // namespace amctl::gcode
