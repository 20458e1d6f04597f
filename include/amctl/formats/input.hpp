#pragma once
// Opening a G-code input by what it holds, not by its name: the one adapter between the
// G-code readers (gcode::LineReader and everything built on it: plan::PlanSource, M73,
// the empirical estimate, the G-code scaler) and the file formats of this module.
//
//   bytes (file, standard input, pipe; read once) -> recognise the first bytes ->
//     "GCDE"            binary G-code       -> BgcodeReader  -> G-code text
//     zip "PK\3\4"      sliced 3MF          -> one plate     -> G-code text
//     gzip 1f 8b        gzip-compressed G-code (.gcode.gz)   -> G-code text
//     STL, STEP, a 3MF without G-code: a 3D model -> amctl::Error "slice it first"
//     anything else     G-code text as it is
//
// A plate of a several-plate 3MF is named as a path inside the archive:
// "print.gcode.3mf/Metadata/plate_2.gcode". gcode_parts() lists them.
#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/formats/bgcode.hpp"
#include "amctl/formats/sliced_3mf.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::formats {

enum class GcodeFormat { text, binary_gcode, sliced_3mf, gzip };

/// What the first bytes of an input are.
enum class ContentKind { gcode_text, binary_gcode, zip, gzip, stl_ascii, stl_binary, step };

struct InputLimits {
  BgcodeLimits bgcode;
  ArchiveLimits archive;
};

/// An opened G-code input: its text as a byte stream.
struct GcodeInput {
  std::unique_ptr<gcode::ByteSource> bytes;
  std::string name;    ///< for messages: the path, "<stdin>" for "-"
  GcodeFormat format = GcodeFormat::text;
  std::string member;  ///< the 3MF member read ("Metadata/plate_1.gcode"), else empty
};

/// Recognises the content from its first bytes (512 are enough) and, for a binary STL, the
/// file's size (0 if unknown, as for a pipe).
ContentKind detect_content(std::string_view prefix, std::uint64_t file_size = 0);

/// Opens `path` ("-" reads standard input once) as described above. Throws amctl::Error if it
/// cannot be opened, is a 3D model, a 3MF without G-code or with several plates and none named.
GcodeInput open_gcode_input(const std::string& path, const InputLimits& limits = {});

/// The decoders one by one, for a reader that opens its byte source itself and puts an
/// optional decoder between it and the lines (recognise the first bytes, then wrap): each
/// reads `raw` (which must outlive what it returns) from its first byte. `name` is used in
/// messages. A sliced 3MF is copied to an unnamed temporary file first (a zip's directory is
/// at its end) and gives its only plate; several plates are an error naming them.
bool is_gzip(std::string_view prefix);
std::unique_ptr<gcode::ByteSource> decode_bgcode(gcode::ByteSource& raw, std::string name,
                                                 const BgcodeLimits& limits = {});
std::unique_ptr<gcode::ByteSource> decode_gzip(gcode::ByteSource& raw, std::string name);
std::unique_ptr<gcode::ByteSource> decode_sliced_3mf(gcode::ByteSource& raw, std::string name,
                                                     const ArchiveLimits& limits = {});

/// The G-code text of an input already open by the project's reader (core/input.hpp), by its
/// content as open_gcode_input() reads a path: a view of `file` for text, else a decoder over
/// it (`file` must outlive what is returned). A rewindable file read a second time is decoded
/// again from its first byte (call file.rewind() first). `format`, when given, is set.
std::unique_ptr<gcode::ByteSource> decode_gcode(InputFile& file, const InputLimits& limits = {},
                                                GcodeFormat* format = nullptr);
/// decode_gcode() wrapped in a line reader (the M73 writer's and the scaler's second pass).
std::unique_ptr<gcode::LineReader> open_gcode_reader(
    InputFile& file, const InputLimits& limits = {},
    std::size_t buffer_bytes = gcode::LineReader::kDefaultBufferBytes);

/// open_gcode_input() wrapped in a line reader.
std::unique_ptr<gcode::LineReader> open_gcode_reader(
    const std::string& path, const InputLimits& limits = {},
    std::size_t buffer_bytes = gcode::LineReader::kDefaultBufferBytes);

/// The inputs `path` stands for: `path` itself, or for a 3MF with several plates one path per
/// plate ("print.gcode.3mf/Metadata/plate_2.gcode"), in plate order. Reads only the archive's
/// directory. Throws amctl::Error as open_gcode_input() does for a model.
std::vector<std::string> gcode_parts(const std::string& path, const InputLimits& limits = {});

/// The G-code inputs named by `inputs`, in order: a file as it is, a directory's G-code files
/// (not recursive; names ending in .gcode, .gco, .g, .bgcode, .gcode.3mf, .gcode.gz, any case;
/// sorted), and each 3MF with several plates as its plates (gcode_parts). A path that does not
/// exist is kept (reading it gives the error). Throws amctl::Error for a directory without
/// G-code.
std::vector<std::string> expand_gcode_inputs(const std::vector<std::string>& inputs,
                                             const InputLimits& limits = {});

/// True if `name` ends like a G-code file of any format expand_gcode_inputs() takes.
bool has_gcode_suffix(std::string_view name);

const char* to_string(GcodeFormat f);

}  // namespace amctl::formats
