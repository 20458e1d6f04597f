#pragma once
// Binary G-code (.bgcode, PrusaSlicer 2.7 and later): the file read block by block and its
// G-code given out as text, in bounded memory.
//
// The format (Prusa's public specification of binary G-code, version 1): a 10-byte file
// header ("GCDE", version 1, checksum type 0 none or 1 CRC32), then blocks. A block is a
// header (type, compression, uncompressed size, and the compressed size unless compression is
// 0), its parameters (2 bytes: the encoding; 6 for a thumbnail: format, width, height), its
// data and, with CRC32, the checksum of header, parameters and data (zlib's CRC-32, stored
// little-endian). Every integer is little-endian. Block types: 0 file metadata, 1 G-code,
// 2 slicer metadata, 3 printer metadata, 4 print metadata, 5 thumbnail. Compression: 0 none,
// 1 DEFLATE (a zlib stream), 2 heatshrink window 11 lookahead 4, 3 heatshrink 12/4. G-code
// encoding: 0 text, 1 MeatPack, 2 MeatPack keeping comment lines (formats/meatpack.hpp).
//
// What comes out: the G-code blocks' text in file order, then the print metadata (the
// slicer's estimated time, filament used, ...) as comment lines "; key = value", where
// PrusaSlicer's text G-code has them, so the estimate compares with the slicer's own figure.
// Thumbnails and the other metadata are checked (CRC) and skipped.
//
// Each block is read whole and its CRC checked before any of it is decoded, so a corrupt
// block is reported as such and not as the garbage G-code it would decode to. Memory: one
// block (PrusaSlicer writes 64 KiB) up to BgcodeLimits::max_block_bytes, a 64 KiB decode
// buffer and the 4 KiB heatshrink window.
//
// Errors are amctl::Error naming the file, the block (its number, counting from 1, and its
// byte offset in the file), what was found and what was expected. A line of the decoded text
// is placed by origin(): "G-code block 3, the file's block 8 at byte 4711".
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "amctl/gcode/byte_source.hpp"

namespace amctl::formats {

struct BgcodeLimits {
  /// Largest block payload (parameters + stored data) read at once [bytes].
  std::uint32_t max_block_bytes = 64u << 20;
  /// Largest print metadata kept for the trailing comment lines [bytes, uncompressed].
  std::uint32_t max_metadata_bytes = 1u << 20;
};

/// Counts of what the file held, complete once read() has returned 0.
struct BgcodeStats {
  std::uint32_t version = 0;
  bool crc32 = false;
  std::uint64_t blocks = 0;
  std::uint64_t gcode_blocks = 0;
  std::uint64_t thumbnails = 0;
  std::uint64_t metadata_blocks = 0;
  std::uint64_t gcode_bytes_stored = 0;   ///< G-code blocks' stored (compressed) data
  std::uint64_t gcode_bytes_decoded = 0;  ///< G-code text given out (without the metadata)
};

class BgcodeReader final : public gcode::ByteSource {
 public:
  /// `file` gives the file's bytes from its first one; `name` is used in messages.
  BgcodeReader(std::unique_ptr<gcode::ByteSource> file, std::string name, BgcodeLimits limits = {});
  ~BgcodeReader() override;
  BgcodeReader(const BgcodeReader&) = delete;
  BgcodeReader& operator=(const BgcodeReader&) = delete;

  std::size_t read(char* dst, std::size_t n) override;
  [[nodiscard]] std::string origin(std::uint64_t offset) const override;
  [[nodiscard]] const BgcodeStats& stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// True if `prefix` (the first bytes of a file) starts with the binary G-code magic "GCDE".
bool is_bgcode(std::string_view prefix);

/// The whole text of a binary G-code held in memory (tests, fuzzing, small files).
std::string decode_bgcode(std::string_view bytes, const std::string& name, BgcodeLimits limits = {});

}  // namespace amctl::formats
