#include "amctl/formats/heatshrink.hpp"

#include <algorithm>

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
  acc_ = 0;
  acc_bits_ = 0;
  head_ = 0;
  produced_ = 0;
  copy_left_ = 0;
  copy_offset_ = 0;
}

std::size_t HeatshrinkDecoder::untouched_input_bytes() const { return in_.size() - byte_; }

std::uint32_t HeatshrinkDecoder::take(int count) {
  while (acc_bits_ < count) {  // never more than count + 7 bits held: bytes stay untouched
    acc_ = (acc_ << 8) | in_[byte_++];
    acc_bits_ += 8;
  }
  acc_bits_ -= count;
  return static_cast<std::uint32_t>(acc_ >> acc_bits_) & ((1u << count) - 1u);
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
      const std::size_t run = std::min(copy_left_, n - k);
      for (std::size_t i = 0; i < run; ++i) put(out, k, window_[(head_ - copy_offset_) & mask]);
      copy_left_ -= run;
      continue;
    }
    // A whole item must be there: the tag and its payload (the encoder pads with zeros).
    const std::size_t remaining = static_cast<std::size_t>(acc_bits_) + (in_.size() - byte_) * 8;
    if (remaining == 0) break;
    if (acc_bits_ == 0) {
      acc_ = (acc_ << 8) | in_[byte_++];
      acc_bits_ = 8;
    }
    const bool literal = ((acc_ >> (acc_bits_ - 1)) & 1u) != 0;
    const std::size_t need = 1 + (literal ? 8 : static_cast<std::size_t>(window_bits_ + lookahead_bits_));
    if (remaining < need) break;
    (void)take(1);
    if (literal) {
      put(out, k, static_cast<std::uint8_t>(take(8)));
      continue;
    }
    const std::size_t offset = static_cast<std::size_t>(take(window_bits_)) + 1;
    const std::size_t count = static_cast<std::size_t>(take(lookahead_bits_)) + 1;
    if (offset > produced_) {
      throw Error(fmt::format(
          "heatshrink data: found a back-reference {} bytes back after {} bytes of output, "
          "expected one within the output (corrupt data)",
          offset, produced_));
    }
    copy_offset_ = offset;
    copy_left_ = count;
  }
  return k;
}

}  // namespace amctl::formats
