// libFuzzer target for binary G-code (formats/bgcode.hpp) and its two decoders. Acceptable
// outcomes: text or amctl::Error. Three runs per input:
//   1. the bytes as a file (the header, the block walk, CRC32, every limit);
//   2. the same bytes with every block's CRC32 made right, so that mutations reach the
//      decompressors and MeatPack instead of stopping at the checksum;
//   3. heatshrink (11/4 and 12/4) and MeatPack straight on the bytes.
// Invariants: no more text than the limits allow (a block's stored bytes never decode to
// more than its header says, MeatPack gives at most 3 characters per byte), and reading in
// 1-byte and 4 KiB pieces gives the same text.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <zlib.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/bgcode.hpp"
#include "amctl/formats/heatshrink.hpp"
#include "amctl/formats/meatpack.hpp"
#include "amctl/formats/sources.hpp"
#include "fuzz_support.hpp"

namespace fm = amctl::formats;
using amctl::fuzz::require;

namespace {

constexpr std::uint64_t kMaxText = 1u << 24;  // stop reading a fuzz input's text here

std::uint32_t le32(const std::string& b, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(b[at + static_cast<std::size_t>(i)]);
  return v;
}

/// The bytes with each block's CRC32 recomputed, as far as the block walk goes.
std::string with_right_crcs(std::string b) {
  if (b.size() < 10 || b.compare(0, 4, "GCDE") != 0) return b;
  b[8] = 1;  // CRC32 on
  b[9] = 0;
  std::size_t at = 10;
  for (int blocks = 0; blocks < 64 && at + 8 <= b.size(); ++blocks) {
    const auto type = static_cast<std::uint16_t>(static_cast<std::uint8_t>(b[at]) | (static_cast<std::uint8_t>(b[at + 1]) << 8));
    const auto comp = static_cast<std::uint16_t>(static_cast<std::uint8_t>(b[at + 2]) | (static_cast<std::uint8_t>(b[at + 3]) << 8));
    const std::size_t header = comp == 0 ? 8 : 12;
    if (at + header > b.size()) break;
    const std::uint64_t stored = comp == 0 ? le32(b, at + 4) : le32(b, at + 8);
    const std::uint64_t end = at + header + (type == 5 ? 6 : 2) + stored;
    if (end + 4 > b.size()) break;
    const auto crc = static_cast<std::uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(b.data() + at), static_cast<uInt>(end - at)));
    for (int i = 0; i < 4; ++i) b[end + static_cast<std::size_t>(i)] = static_cast<char>((crc >> (8 * i)) & 0xFF);
    at = end + 4;
  }
  return b;
}

std::string read_all(std::string_view bytes, std::size_t piece, bool& failed) {
  fm::BgcodeLimits limits;
  limits.max_block_bytes = 1u << 20;
  fm::BgcodeReader r(std::make_unique<fm::MemorySource>(bytes), "fuzz.bgcode", limits);
  std::string text;
  std::vector<char> buf(piece);
  failed = false;
  try {
    for (std::size_t k; text.size() < kMaxText && (k = r.read(buf.data(), buf.size())) > 0;) {
      require(k <= piece);
      text.append(buf.data(), k);
      (void)r.origin(text.size() - 1);
    }
  } catch (const amctl::Error&) {
    failed = true;
  }
  return text;
}

void decode_both_ways(std::string_view bytes) {
  bool failed_whole = false, failed_bytewise = false;
  const std::string whole = read_all(bytes, 4096, failed_whole);
  if (bytes.size() > 4096) return;  // byte-by-byte reading of big inputs costs too much
  const std::string bytewise = read_all(bytes, 1, failed_bytewise);
  require(failed_whole == failed_bytewise);
  if (!failed_whole && whole.size() < kMaxText) require(whole == bytewise);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  decode_both_ways(bytes);
  const std::string fixed = with_right_crcs(std::string(bytes));
  if (fixed != bytes) decode_both_ways(fixed);

  const std::span<const std::uint8_t> in(data, size);
  for (int w : {11, 12}) {
    fm::HeatshrinkDecoder h(w, 4);
    h.reset(in);
    std::vector<std::uint8_t> out(4096);
    std::uint64_t total = 0;
    try {
      for (std::size_t k; total < kMaxText && (k = h.decode(out.data(), out.size())) > 0;) total += k;
    } catch (const amctl::Error&) {
    }
    // Each item is at least 9 bits and gives at most 16 bytes.
    require(total <= 16 * (size * 8 / 9 + 1));
  }
  fm::MeatPackDecoder mp;
  mp.reset();
  std::string text;
  mp.decode(in, text);
  require(text.size() <= 3 * size);
  return 0;
}
