#include "amctl/formats/bgcode.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <deque>
#include <optional>
#include <vector>

#include <fmt/format.h>
#include <zlib.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/heatshrink.hpp"
#include "amctl/formats/meatpack.hpp"
#include "amctl/formats/sources.hpp"

namespace amctl::formats {
namespace {

constexpr std::size_t kFileHeaderBytes = 10;
constexpr std::size_t kChunkBytes = 64 * 1024;
constexpr std::size_t kMaxOrigins = 4096;  // blocks remembered for origin(): ~ the line buffer

enum BlockType : std::uint16_t {
  file_metadata = 0,
  gcode = 1,
  slicer_metadata = 2,
  printer_metadata = 3,
  print_metadata = 4,
  thumbnail = 5,
};

const char* type_name(std::uint16_t t) {
  switch (t) {
    case file_metadata: return "file metadata";
    case gcode: return "G-code";
    case slicer_metadata: return "slicer metadata";
    case printer_metadata: return "printer metadata";
    case print_metadata: return "print metadata";
    case thumbnail: return "thumbnail";
    default: return "unknown";
  }
}

const char* compression_name(std::uint16_t c) {
  switch (c) {
    case 0: return "not compressed";
    case 1: return "DEFLATE";
    case 2: return "heatshrink 11/4";
    case 3: return "heatshrink 12/4";
    default: return "unknown compression";
  }
}

std::uint16_t le16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

struct Origin {
  std::uint64_t start = 0;  // offset in the decoded text
  std::uint64_t gcode_block = 0;  // 0: the print metadata lines
  std::uint64_t block = 0;
  std::uint64_t file_offset = 0;
};

}  // namespace

struct BgcodeReader::Impl {
  Impl(std::unique_ptr<gcode::ByteSource> f, std::string n, BgcodeLimits l)
      : file(std::move(f)), name(std::move(n)), limits(l) {}
  ~Impl() {
    if (zlib_open) inflateEnd(&zs);
  }

  std::unique_ptr<gcode::ByteSource> file;
  std::string name;
  BgcodeLimits limits;
  BgcodeStats stats;
  std::uint64_t file_offset = 0;  // bytes taken from the file so far
  bool header_done = false;
  bool ended = false;

  // The block being decoded.
  bool in_block = false;
  std::uint16_t type = 0, compression = 0, encoding = 0;
  std::uint32_t uncompressed = 0;
  std::uint64_t block_offset = 0;
  std::vector<std::uint8_t> payload;  // parameters + stored data
  std::size_t data_begin = 0;         // where the data starts in payload
  std::size_t copy_pos = 0;           // compression 0: next data byte
  std::uint64_t produced = 0;         // bytes decompressed so far
  z_stream zs{};
  bool zlib_open = false;
  bool zlib_end = false;
  std::optional<HeatshrinkDecoder> hs11, hs12;
  HeatshrinkDecoder* hs = nullptr;
  MeatPackDecoder meatpack;
  std::string unpacked;  // MeatPack's text of the current chunk
  // The line being written: nothing but blanks (and a ';') so far, or text.
  enum class LineState { blank, comment_mark, text };
  LineState line_state = LineState::blank;
  std::string held_blanks;  // the blank line's characters so far, written if text follows
  std::vector<std::uint8_t> chunk = std::vector<std::uint8_t>(kChunkBytes);

  // Decoded text waiting to be read, and where it came from.
  std::string out;
  std::size_t out_pos = 0;
  std::uint64_t decoded = 0;  // bytes of text given out or in `out`
  bool last_was_newline = true;
  std::deque<Origin> origins;
  std::string metadata_lines;  // print metadata, given out after the last G-code block

  [[nodiscard]] std::string block_where() const {
    return fmt::format("block {} at byte {} ({}, {})", stats.blocks, block_offset, type_name(type),
                       compression_name(compression));
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(SourceLocation{name, 0, 0}, what);
  }
  [[noreturn]] void fail_block(const std::string& what) const {
    fail(block_where() + ": " + what);
  }

  std::size_t take(void* dst, std::size_t n) {
    const std::size_t got = read_fully(*file, static_cast<char*>(dst), n);
    file_offset += got;
    return got;
  }
  void take_exactly(void* dst, std::size_t n, const char* what) {
    const std::size_t got = take(dst, n);
    if (got != n) {
      fail_block(fmt::format("found the end of the file after {} of the {} bytes of its {}, "
                             "expected the whole block (a truncated file?)",
                             got, n, what));
    }
  }

  void read_file_header();
  bool next_block();  // false at the end of the file
  void finish_file();
  void start_gcode();
  void pump();
  std::size_t decompress(std::uint8_t* dst, std::size_t n);
  void end_block();
  void keep_print_metadata();
  void push_text(std::string_view text);
};

void BgcodeReader::Impl::read_file_header() {
  std::array<std::uint8_t, kFileHeaderBytes> h{};
  const std::size_t got = take(h.data(), h.size());
  if (got < 4 || std::memcmp(h.data(), "GCDE", 4) != 0) {
    fail("found no binary G-code header, expected the bytes \"GCDE\" at the start of the file");
  }
  if (got < h.size()) {
    fail(fmt::format("found the end of the file after {} bytes, expected the 10-byte binary "
                     "G-code header (a truncated file?)",
                     got));
  }
  stats.version = le32(h.data() + 4);
  if (stats.version != 1) {
    fail(fmt::format("found binary G-code version {}, expected version 1 (the one published)",
                     stats.version));
  }
  const std::uint16_t checksum = le16(h.data() + 8);
  if (checksum > 1) {
    fail(fmt::format("found checksum type {}, expected 0 (none) or 1 (CRC32)", checksum));
  }
  stats.crc32 = checksum == 1;
  header_done = true;
}

bool BgcodeReader::Impl::next_block() {
  std::array<std::uint8_t, 12> h{};
  block_offset = file_offset;
  const std::size_t first = take(h.data(), 8);
  if (first == 0) return false;
  ++stats.blocks;
  type = le16(h.data());
  compression = le16(h.data() + 2);
  if (first < 8) {
    fail_block(fmt::format("found the end of the file after {} of the 8 bytes of its header, "
                           "expected the whole block (a truncated file?)",
                           first));
  }
  if (type > thumbnail) {
    fail(fmt::format("block {} at byte {}: found block type {}, expected 0 to 5 (file metadata, "
                     "G-code, slicer metadata, printer metadata, print metadata, thumbnail)",
                     stats.blocks, block_offset, type));
  }
  if (compression > 3) {
    fail(fmt::format("block {} at byte {} ({}): found compression {}, expected 0 (none), "
                     "1 (DEFLATE), 2 (heatshrink 11/4) or 3 (heatshrink 12/4)",
                     stats.blocks, block_offset, type_name(type), compression));
  }
  uncompressed = le32(h.data() + 4);
  std::size_t header_bytes = 8;
  std::uint32_t stored = uncompressed;
  if (compression != 0) {
    take_exactly(h.data() + 8, 4, "header");
    header_bytes = 12;
    stored = le32(h.data() + 8);
  }
  const std::size_t params = type == thumbnail ? 6 : 2;
  const std::uint64_t payload_bytes = params + static_cast<std::uint64_t>(stored);
  std::uint32_t crc = static_cast<std::uint32_t>(crc32(0L, Z_NULL, 0));
  crc = static_cast<std::uint32_t>(crc32(crc, h.data(), static_cast<uInt>(header_bytes)));

  const bool keep = type == gcode || type == print_metadata;
  if (keep && payload_bytes > limits.max_block_bytes) {
    fail_block(fmt::format("found {} bytes of block data, expected at most {} (PrusaSlicer "
                           "writes blocks of 64 KiB)",
                           payload_bytes, limits.max_block_bytes));
  }
  if (keep) {
    payload.resize(static_cast<std::size_t>(payload_bytes));
    take_exactly(payload.data(), payload.size(), "data");
    crc = static_cast<std::uint32_t>(crc32(crc, payload.data(), static_cast<uInt>(payload.size())));
  } else {
    // Thumbnails and the other metadata: checked and dropped, a chunk at a time.
    std::uint64_t left = payload_bytes;
    while (left > 0) {
      const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, chunk.size()));
      take_exactly(chunk.data(), n, "data");
      crc = static_cast<std::uint32_t>(crc32(crc, chunk.data(), static_cast<uInt>(n)));
      left -= n;
    }
    if (type == thumbnail) {
      ++stats.thumbnails;
    } else {
      ++stats.metadata_blocks;
    }
  }
  if (stats.crc32) {
    std::array<std::uint8_t, 4> c{};
    take_exactly(c.data(), c.size(), "CRC32");
    const std::uint32_t expected = le32(c.data());
    if (expected != crc) {
      fail_block(fmt::format("found CRC32 {:08x} over the block, expected {:08x} as stored "
                             "(the block is corrupt)",
                             crc, expected));
    }
  }
  if (type == gcode) {
    start_gcode();
  } else if (type == print_metadata) {
    ++stats.metadata_blocks;
    keep_print_metadata();
  }
  return true;
}

void BgcodeReader::Impl::start_gcode() {
  encoding = le16(payload.data());
  if (encoding > 2) {
    fail_block(fmt::format("found G-code encoding {}, expected 0 (text), 1 (MeatPack) or 2 "
                           "(MeatPack with comments)",
                           encoding));
  }
  ++stats.gcode_blocks;
  stats.gcode_bytes_stored += payload.size() - 2;
  data_begin = 2;
  copy_pos = data_begin;
  produced = 0;
  const std::span<const std::uint8_t> data(payload.data() + data_begin, payload.size() - data_begin);
  if (compression == 1) {
    if (!zlib_open) {
      zs = z_stream{};
      if (inflateInit(&zs) != Z_OK) throw std::bad_alloc();
      zlib_open = true;
    } else {
      inflateReset(&zs);
    }
    zs.next_in = const_cast<Bytef*>(data.data());
    zs.avail_in = static_cast<uInt>(data.size());
    zlib_end = false;
  } else if (compression >= 2) {
    auto& d = compression == 2 ? hs11 : hs12;
    if (!d) d.emplace(compression == 2 ? 11 : 12, 4);
    hs = &*d;
    hs->reset(data);
  }
  meatpack.reset();
  if (origins.size() == kMaxOrigins) origins.pop_front();
  origins.push_back(Origin{decoded, stats.gcode_blocks, stats.blocks, block_offset});
  in_block = true;
}

std::size_t BgcodeReader::Impl::decompress(std::uint8_t* dst, std::size_t n) {
  switch (compression) {
    case 0: {
      const std::size_t k = std::min(n, payload.size() - copy_pos);
      std::memcpy(dst, payload.data() + copy_pos, k);
      copy_pos += k;
      return k;
    }
    case 1: {
      if (zlib_end) return 0;
      zs.next_out = dst;
      zs.avail_out = static_cast<uInt>(n);
      const int rc = inflate(&zs, Z_NO_FLUSH);
      const std::size_t k = n - zs.avail_out;
      if (rc == Z_STREAM_END) {
        zlib_end = true;
      } else if (rc == Z_BUF_ERROR && k == 0) {
        return 0;  // no progress possible: the data ends early
      } else if (rc != Z_OK) {
        fail_block(fmt::format("found corrupt DEFLATE data ({}), expected a zlib stream",
                               zs.msg != nullptr ? zs.msg : "zlib error"));
      }
      return k;
    }
    default:
      try {
        return hs->decode(dst, n);
      } catch (const Error& e) {
        fail_block(e.detail());
      }
  }
}

void BgcodeReader::Impl::pump() {
  const std::uint64_t left = uncompressed - produced;
  std::size_t k = 0;
  if (left > 0) {
    k = decompress(chunk.data(), static_cast<std::size_t>(std::min<std::uint64_t>(left, chunk.size())));
    if (k == 0) {
      fail_block(fmt::format("found {} bytes of data when decompressed, expected the {} the block "
                             "header gives",
                             produced, uncompressed));
    }
    produced += k;
  }
  const std::string_view text(reinterpret_cast<const char*>(chunk.data()), k);
  if (encoding == 0) {
    push_text(text);
  } else {
    unpacked.clear();
    meatpack.decode(std::span<const std::uint8_t>(chunk.data(), k), unpacked);
    push_text(unpacked);
  }
  if (produced == uncompressed) end_block();
}

void BgcodeReader::Impl::push_text(std::string_view text) {
  // Lines that are empty once blanks and a lone ';' are taken away are dropped, as the bgcode
  // tool and PrusaSlicer's viewer drop them: the text and its line numbers are theirs.
  const std::size_t before = out.size();
  for (const char c : text) {
    if (line_state == LineState::text) {
      out.push_back(c);
      if (c == '\n') line_state = LineState::blank;
      continue;
    }
    if (c == '\n') {  // an empty line: nothing of it is written
      held_blanks.clear();
      line_state = LineState::blank;
      continue;
    }
    if (c == ' ' || c == '\t' || (c == ';' && line_state == LineState::blank)) {
      held_blanks.push_back(c);
      if (c == ';') line_state = LineState::comment_mark;
      if (held_blanks.size() < 4096) continue;
    } else {
      held_blanks.push_back(c);
    }
    out += held_blanks;  // the line has text: write what was held back
    held_blanks.clear();
    line_state = LineState::text;
  }
  decoded += out.size() - before;
  stats.gcode_bytes_decoded += out.size() - before;
  if (out.size() > before) last_was_newline = out.back() == '\n';
}

void BgcodeReader::Impl::end_block() {
  // All the declared bytes are out: the stored data must end there too.
  if (compression == 1) {
    if (!zlib_end) {
      std::uint8_t extra = 0;
      const std::size_t k = decompress(&extra, 1);
      if (k > 0 || !zlib_end) {
        fail_block(fmt::format("found more than the {} bytes the block header gives when "
                               "decompressed, expected exactly that many",
                               uncompressed));
      }
    }
    if (zs.avail_in != 0) {
      fail_block(fmt::format("found {} bytes after the end of the DEFLATE data, expected none",
                             zs.avail_in));
    }
  } else if (compression >= 2) {
    std::uint8_t extra = 0;
    std::size_t more = 0;
    try {
      more = hs->decode(&extra, 1);
    } catch (const Error&) {
      more = 1;  // a further item, broken or not: more data than declared
    }
    if (more > 0) {
      fail_block(fmt::format("found more than the {} bytes the block header gives when "
                             "decompressed, expected exactly that many",
                             uncompressed));
    }
    if (hs->untouched_input_bytes() > 0) {
      fail_block(fmt::format("found {} bytes of heatshrink data after the {} bytes the block "
                             "header gives, expected none",
                             hs->untouched_input_bytes(), uncompressed));
    }
  }
  if (encoding != 0 && meatpack.pending()) {
    fail_block("found the MeatPack data ending inside a packed character or a command, "
               "expected it to end on a whole character");
  }
  in_block = false;
}

void BgcodeReader::Impl::keep_print_metadata() {
  const std::uint16_t enc = le16(payload.data());
  if (enc != 0) {
    fail_block(fmt::format("found metadata encoding {}, expected 0 (INI)", enc));
  }
  if (uncompressed > limits.max_metadata_bytes) return;  // too large to keep: skipped
  std::string text(uncompressed, '\0');
  data_begin = 2;
  copy_pos = data_begin;
  produced = 0;
  encoding = 0;
  const std::span<const std::uint8_t> data(payload.data() + 2, payload.size() - 2);
  if (compression == 1) {
    uLongf len = uncompressed;
    const int rc = uncompress(reinterpret_cast<Bytef*>(text.data()), &len, data.data(),
                              static_cast<uLong>(data.size()));
    if (rc != Z_OK || len != uncompressed) {
      fail_block(fmt::format("found corrupt DEFLATE data or not the {} bytes the block header "
                             "gives, expected a zlib stream of that size",
                             uncompressed));
    }
  } else if (compression >= 2) {
    HeatshrinkDecoder d(compression == 2 ? 11 : 12, 4);
    d.reset(data);
    std::size_t k = 0;
    try {
      k = d.decode(reinterpret_cast<std::uint8_t*>(text.data()), text.size());
    } catch (const Error& e) {
      fail_block(e.detail());
    }
    if (k != text.size()) {
      fail_block(fmt::format("found {} bytes of data when decompressed, expected the {} the "
                             "block header gives",
                             k, uncompressed));
    }
  } else {
    text.assign(reinterpret_cast<const char*>(data.data()), data.size());
  }
  // INI lines key=value -> "; key = value", as PrusaSlicer writes them in text G-code.
  std::string lines;
  std::string_view rest = text;
  while (!rest.empty()) {
    const std::size_t nl = rest.find('\n');
    std::string_view line = rest.substr(0, nl);
    rest.remove_prefix(nl == std::string_view::npos ? rest.size() : nl + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const std::size_t eq = line.find('=');
    if (line.empty() || eq == std::string_view::npos) continue;
    auto trim = [](std::string_view s) {
      while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
      while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
      return s;
    };
    lines += fmt::format("; {} = {}\n", trim(line.substr(0, eq)), trim(line.substr(eq + 1)));
  }
  metadata_lines = std::move(lines);
}

void BgcodeReader::Impl::finish_file() {
  ended = true;
  if (stats.gcode_blocks == 0) {
    fail(fmt::format("found {} blocks and no G-code block, expected at least one (a file with "
                     "only metadata and thumbnails?)",
                     stats.blocks));
  }
  if (metadata_lines.empty()) return;
  if (!last_was_newline) {
    out.push_back('\n');
    ++decoded;
  }
  if (origins.size() == kMaxOrigins) origins.pop_front();
  origins.push_back(Origin{decoded, 0, 0, 0});
  out += metadata_lines;
  decoded += metadata_lines.size();
  metadata_lines.clear();
}

BgcodeReader::BgcodeReader(std::unique_ptr<gcode::ByteSource> file, std::string name,
                           BgcodeLimits limits)
    : impl_(std::make_unique<Impl>(std::move(file), std::move(name), limits)) {}

BgcodeReader::~BgcodeReader() = default;

std::size_t BgcodeReader::read(char* dst, std::size_t n) {
  Impl& s = *impl_;
  if (n == 0) return 0;
  for (;;) {
    if (s.out_pos < s.out.size()) {
      const std::size_t k = std::min(n, s.out.size() - s.out_pos);
      std::memcpy(dst, s.out.data() + s.out_pos, k);
      s.out_pos += k;
      return k;
    }
    s.out.clear();
    s.out_pos = 0;
    if (s.in_block) {
      s.pump();
      continue;
    }
    if (s.ended) return 0;
    if (!s.header_done) s.read_file_header();
    if (!s.next_block()) s.finish_file();
  }
}

std::string BgcodeReader::origin(std::uint64_t offset) const {
  const auto& o = impl_->origins;
  auto it = std::upper_bound(o.begin(), o.end(), offset,
                             [](std::uint64_t v, const Origin& e) { return v < e.start; });
  if (it == o.begin()) return {};
  --it;
  if (it->gcode_block == 0) return "the print metadata, given as comment lines";
  return fmt::format("G-code block {}, the file's block {} at byte {}", it->gcode_block,
                     it->block, it->file_offset);
}

const BgcodeStats& BgcodeReader::stats() const { return impl_->stats; }

bool is_bgcode(std::string_view prefix) { return prefix.starts_with("GCDE"); }

std::string decode_bgcode(std::string_view bytes, const std::string& name, BgcodeLimits limits) {
  BgcodeReader r(std::make_unique<MemorySource>(bytes), name, limits);
  std::string text;
  std::array<char, 16384> buf{};
  for (std::size_t k; (k = r.read(buf.data(), buf.size())) > 0;) text.append(buf.data(), k);
  return text;
}

}  // namespace amctl::formats
