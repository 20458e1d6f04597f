// Reading the G-code containers (formats/): text given out per second by the binary G-code
// reader (DEFLATE + text, the whole block walk and CRC32), by heatshrink and by MeatPack
// alone. The estimate itself runs at its usual rate on the decoded text (docs/formats.md has
// the figures and the end-to-end time of a .bgcode against its text).
#include <benchmark/benchmark.h>

#include <cstdint>
#include <string>
#include <vector>

#include <zlib.h>

#include "amctl/formats/bgcode.hpp"
#include "amctl/formats/heatshrink.hpp"
#include "amctl/formats/meatpack.hpp"
#include "synthetic.hpp"

namespace {

void put16(std::string& b, std::uint16_t v) {
  b += static_cast<char>(v & 0xFF);
  b += static_cast<char>(v >> 8);
}
void put32(std::string& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b += static_cast<char>((v >> (8 * i)) & 0xFF);
}

/// A binary G-code file of `text` in 64 KiB DEFLATE blocks, text encoding, CRC32.
std::string deflate_bgcode(const std::string& text) {
  std::string b = "GCDE";
  put32(b, 1);
  put16(b, 1);
  for (std::size_t at = 0; at < text.size(); at += 65536) {
    const std::string chunk = text.substr(at, 65536);
    uLongf len = compressBound(static_cast<uLong>(chunk.size()));
    std::string z(len, '\0');
    compress(reinterpret_cast<Bytef*>(z.data()), &len, reinterpret_cast<const Bytef*>(chunk.data()),
             static_cast<uLong>(chunk.size()));
    z.resize(len);
    const std::size_t start = b.size();
    put16(b, 1);  // G-code
    put16(b, 1);  // DEFLATE
    put32(b, static_cast<std::uint32_t>(chunk.size()));
    put32(b, static_cast<std::uint32_t>(z.size()));
    put16(b, 0);  // text
    b += z;
    put32(b, static_cast<std::uint32_t>(
                 crc32(0L, reinterpret_cast<const Bytef*>(b.data() + start), static_cast<uInt>(b.size() - start))));
  }
  return b;
}

void BM_BgcodeDeflateText(benchmark::State& state) {
  const std::string text = amctl::bench::synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  const std::string file = deflate_bgcode(text);
  for (auto _ : state) {
    const std::string out = amctl::formats::decode_bgcode(file, "bench.bgcode");
    benchmark::DoNotOptimize(out.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(text.size()) * state.iterations());
}
BENCHMARK(BM_BgcodeDeflateText)->Arg(1 << 17)->Unit(benchmark::kMillisecond);

void BM_HeatshrinkLiterals(benchmark::State& state) {
  // A literal-only stream (9 bits per byte): the bit reader's cost per output byte.
  const std::string text = amctl::bench::synthetic_gcode(static_cast<std::size_t>(state.range(0)));
  std::vector<std::uint8_t> in((text.size() * 9 + 7) / 8, 0);
  std::size_t bit = 0;
  for (const char c : text) {
    const unsigned v = 0x100u | static_cast<unsigned char>(c);
    for (int i = 8; i >= 0; --i, ++bit) {
      if ((v >> i) & 1u) in[bit / 8] |= static_cast<std::uint8_t>(0x80u >> (bit % 8));
    }
  }
  amctl::formats::HeatshrinkDecoder d(12, 4);
  std::vector<std::uint8_t> out(65536);
  for (auto _ : state) {
    d.reset(in);
    std::size_t total = 0;
    for (std::size_t k; (k = d.decode(out.data(), out.size())) > 0;) total += k;
    benchmark::DoNotOptimize(total);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(text.size()) * state.iterations());
}
BENCHMARK(BM_HeatshrinkLiterals)->Arg(1 << 17)->Unit(benchmark::kMillisecond);

void BM_MeatPackPacked(benchmark::State& state) {
  // Digits, '.', 'G', 'X', ' ' and newlines two per byte, the common case of G1 lines.
  const std::size_t n = static_cast<std::size_t>(state.range(0));
  std::vector<std::uint8_t> in = {0xFF, 0xFF, 251};
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t lo = static_cast<std::uint8_t>(i % 10), hi = static_cast<std::uint8_t>((i / 10) % 11);
    in.push_back(static_cast<std::uint8_t>(lo | (hi << 4)));
    if (i % 16 == 15) in.push_back(0xCC);  // a newline
  }
  amctl::formats::MeatPackDecoder d;
  std::string out;
  for (auto _ : state) {
    d.reset();
    out.clear();
    d.decode(in, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(out.size()) * state.iterations());
}
BENCHMARK(BM_MeatPackPacked)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

}  // namespace
