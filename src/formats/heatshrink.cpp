#include "amctl/formats/heatshrink.hpp"

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::formats {

HeatshrinkDecoder::HeatshrinkDecoder(int window_bits, int lookahead_bits)
    : window_bits_(window_bits), lookahead_bits_(lookahead_bits) {
  AMCTL_CHECK(window_bits >= 4 && window_bits <= 15, "heatshrink window bits out of range");
  AMCTL_CHECK(lookahead_bits >= 3 && lookahead_bits < window_bits,
              "heatshrink lookahead bits out of range");
  window_.assign(std::size_t{1} << window_bits, 0);
}

void HeatshrinkDecoder::reset(std::span<const std::uint8_t> input) {
  in_ = input;
  byte_ = 0;
  bit_ = 0;
  head_ = 0;
  produced_ = 0;
  copy_left_ = 0;
  copy_offset_ = 0;
}

std::size_t HeatshrinkDecoder::untouched_input_bytes() const {
  if (byte_ >= in_.size()) return 0;
  return in_.size() - byte_ - (bit_ > 0 ? 1 : 0);
}

int HeatshrinkDecoder::bits(int count) {
  const std::size_t left = (in_.size() - byte_) * 8 - static_cast<std::size_t>(bit_);
  if (byte_ >= in_.size() || left < static_cast<std::size_t>(count)) return -1;
  int v = 0;
  for (int i = 0; i < count; ++i) {
    const int b = (in_[byte_] >> (7 - bit_)) & 1;
    v = (v << 1) | b;
    if (++bit_ == 8) {
      bit_ = 0;
      ++byte_;
    }
  }
  return v;
}

void HeatshrinkDecoder::put(std::uint8_t* out, std::size_t& k, std::uint8_t byte) {
  out[k++] = byte;
  window_[head_] = byte;
  head_ = (head_ + 1) & (window_.size() - 1);
  ++produced_;
}

std::size_t HeatshrinkDecoder::decode(std::uint8_t* out, std::size_t n) {
  std::size_t k = 0;
  const std::size_t mask = window_.size() - 1;
  while (k < n) {
    if (copy_left_ > 0) {
      const std::uint8_t b = window_[(head_ - copy_offset_) & mask];
      put(out, k, b);
      --copy_left_;
      continue;
    }
    // A whole item must be there: the tag and its payload (the encoder pads with zeros).
    const std::size_t save_byte = byte_;
    const int save_bit = bit_;
    const int tag = bits(1);
    if (tag < 0) break;
    if (tag == 1) {
      const int lit = bits(8);
      if (lit < 0) {
        byte_ = save_byte;
        bit_ = save_bit;
        break;
      }
      put(out, k, static_cast<std::uint8_t>(lit));
      continue;
    }
    const int index = bits(window_bits_);
    const int count = index < 0 ? -1 : bits(lookahead_bits_);
    if (count < 0) {
      byte_ = save_byte;
      bit_ = save_bit;
      break;
    }
    const std::size_t offset = static_cast<std::size_t>(index) + 1;
    if (offset > produced_) {
      throw Error(fmt::format(
          "heatshrink data: found a back-reference {} bytes back after {} bytes of output, "
          "expected one within the output (corrupt data)",
          offset, produced_));
    }
    copy_offset_ = offset;
    copy_left_ = static_cast<std::size_t>(count) + 1;
  }
  return k;
}

}  // namespace amctl::formats
