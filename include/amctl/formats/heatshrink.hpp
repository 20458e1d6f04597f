#pragma once
// Heatshrink decompression (an LZSS variant for small memory), as binary G-code uses it:
// compression 2 = window 2^11 bytes, lookahead 2^4; compression 3 = window 2^12, lookahead 2^4.
//
// The compressed data is a bit stream, most significant bit of each byte first. Each item
// starts with a tag bit:
//   1  a literal: the next 8 bits are one output byte;
//   0  a back-reference: W bits give index, then L bits give count, and the decoder copies
//      count + 1 bytes starting index + 1 bytes back in its output (the copy may overlap what
//      it writes, as in every LZ77 decoder).
// The stream ends when the input runs out of bits for a whole item; the encoder pads its last
// byte with zero bits. W and L are not stored in the stream: the container says them.
//
// Streaming: decode() writes as much as fits and resumes where it stopped (also in the
// middle of a back-reference); memory is the 2^W-byte window. The input is one whole span
// (a binary G-code block is checked against its CRC before it is decoded).
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace amctl::formats {

class HeatshrinkDecoder {
 public:
  /// window_bits W in [4, 15], lookahead_bits L in [3, W).
  HeatshrinkDecoder(int window_bits, int lookahead_bits);

  /// Starts a new stream (the window is emptied: each binary G-code block stands alone).
  /// The decoder reads `input` in place: it must stay alive while decode() runs.
  void reset(std::span<const std::uint8_t> input);

  /// Writes up to `n` decoded bytes to `out`; returns how many. Returns less than `n` only
  /// when the input holds no further whole item. Throws amctl::Error (no location) for a
  /// back-reference that points before the start of the stream.
  std::size_t decode(std::uint8_t* out, std::size_t n);

  /// Bytes written since reset().
  [[nodiscard]] std::uint64_t produced() const { return produced_; }
  /// Whole input bytes not yet touched (0 once the stream ends inside its last byte).
  [[nodiscard]] std::size_t untouched_input_bytes() const;

 private:
  /// The next `count` bits (count <= 16); the caller has checked that they are there.
  std::uint32_t take(int count);
  void put(std::uint8_t* out, std::size_t& k, std::uint8_t byte);

  int window_bits_;
  int lookahead_bits_;
  std::span<const std::uint8_t> in_;
  std::size_t byte_ = 0;    // next byte to take into acc_
  std::uint64_t acc_ = 0;   // bits taken but not yet used: the low acc_bits_ of it
  int acc_bits_ = 0;
  std::vector<std::uint8_t> window_;  // the last 2^W bytes written, a ring
  std::size_t head_ = 0;              // where the next byte goes in window_
  std::uint64_t produced_ = 0;
  std::size_t copy_left_ = 0;     // bytes of the current back-reference still to copy
  std::size_t copy_offset_ = 0;   // its distance back
};

}  // namespace amctl::formats
