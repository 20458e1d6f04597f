#include "amctl/gcode/line_reader.hpp"

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::gcode {
namespace {

std::unique_ptr<ByteSource> unsupported(ByteSource& raw, std::string_view format, std::string_view hint) {
  throw Error(SourceLocation{raw.name(), 0, 0},
              fmt::format("is {}, which amctl does not read yet; expected plain G-code text ({})", format, hint));
}

bool ends_with(std::string_view s, std::string_view suffix) {
  if (s.size() < suffix.size()) return false;
  for (std::size_t i = 0; i < suffix.size(); ++i) {
    const char a = s[s.size() - suffix.size() + i];
    if ((a >= 'A' && a <= 'Z' ? a - 'A' + 'a' : a) != suffix[i]) return false;
  }
  return true;
}

}  // namespace

const std::vector<Decoder>& gcode_decoders() {
  static const std::vector<Decoder> decoders{
      Decoder{"binary G-code",
              [](std::string_view first, std::string_view) { return first.substr(0, 4) == "GCDE"; },
              [](ByteSource& raw) {
                return unsupported(raw, "binary G-code (.bgcode)",
                                   "export with binary G-code switched off, or convert it with PrusaSlicer's "
                                   "bgcode tool");
              }},
      Decoder{"3MF archive",
              [](std::string_view first, std::string_view path) {
                return first.substr(0, 4) == std::string_view("PK\x03\x04", 4) &&
                       (ends_with(path, ".3mf") || ends_with(path, ".gcode.3mf"));
              },
              [](ByteSource& raw) {
                return unsupported(raw, "a .gcode.3mf archive", "export the plate's G-code as a .gcode file");
              }},
  };
  return decoders;
}

InputOptions gcode_input_options(bool rewindable) {
  InputOptions o;
  o.what = "G-code file";
  o.rewindable = rewindable;
  return o;
}

LineReader::LineReader(const std::string& path, std::size_t buffer_bytes)
    : amctl::LineReader(open_decoded(path, gcode_input_options(), gcode_decoders()), buffer_bytes) {}

LineReader::LineReader(InputFile& file, std::size_t buffer_bytes)
    : amctl::LineReader(decode(file, gcode_decoders()), buffer_bytes) {}

}  // namespace amctl::gcode
