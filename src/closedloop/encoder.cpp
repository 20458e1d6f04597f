#include "amctl/closedloop/encoder.hpp"

#include <bit>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::closedloop {

std::uint32_t encode_frame(const As5311Frame& f) {
  std::uint32_t b = static_cast<std::uint32_t>(f.position & 0x0FFFu) << 6;
  b |= (f.ocf ? 1u : 0u) << 5;
  b |= (f.cof ? 1u : 0u) << 4;
  b |= (f.lin ? 1u : 0u) << 3;
  b |= (f.mag_inc ? 1u : 0u) << 2;
  b |= (f.mag_dec ? 1u : 0u) << 1;
  b |= static_cast<std::uint32_t>(std::popcount(b) & 1);  // even parity over all 18 bits
  return b;
}

DecodedFrame decode_frame(std::uint32_t bits) {
  DecodedFrame d;
  bits &= 0x3FFFFu;
  d.frame.position = static_cast<std::uint16_t>((bits >> 6) & 0x0FFFu);
  d.frame.ocf = (bits >> 5) & 1u;
  d.frame.cof = (bits >> 4) & 1u;
  d.frame.lin = (bits >> 3) & 1u;
  d.frame.mag_inc = (bits >> 2) & 1u;
  d.frame.mag_dec = (bits >> 1) & 1u;
  d.parity_ok = (std::popcount(bits) % 2) == 0;
  d.valid = d.parity_ok && d.frame.ocf && !d.frame.cof && !d.frame.lin &&
            !(d.frame.mag_inc && d.frame.mag_dec);
  return d;
}

void EncoderParameters::validate() const {
  require_positive("encoder.resolution_mm", resolution_mm);
  if (resolution_mm < kAs5311ResolutionMm * (1.0 - 1e-9)) {
    throw Error(fmt::format("encoder resolution {} um is finer than the AS5311's {:.4f} um (12 "
                            "bits per 2 mm pole pair): its frame cannot carry it",
                            resolution_mm * 1e3, kAs5311ResolutionMm * 1e3));
  }
  if (resolution_mm > 0.25 * kAs5311PolePairMm) {
    throw Error(fmt::format("encoder resolution {} um: at most a quarter of the 2 mm pole pair "
                            "(500 um), or pole crossings cannot be unwrapped",
                            resolution_mm * 1e3));
  }
  require_non_negative("encoder.noise_rms_um", noise_rms_um);
  require_non_negative("encoder.latency_s", latency_s);
  if (!(corrupt_probability >= 0.0 && corrupt_probability <= 1.0)) {
    throw Error("encoder.corrupt_probability = " + std::to_string(corrupt_probability) +
                ": expected a probability in [0, 1]");
  }
}

As5311Encoder::As5311Encoder(const EncoderParameters& p, double start_mm) : p_(p), rng_(p.seed) {
  p_.validate();
  counts_ = static_cast<int>(std::lround(kAs5311PolePairMm / p_.resolution_mm));
  res_mm_ = kAs5311PolePairMm / counts_;
  inv_res_ = 1.0 / res_mm_;
  std::normal_distribution<double> normal(0.0, 1.0);
  normals_.resize(4096);
  for (double& v : normals_) v = normal(rng_);
  pick_ = p.seed * 0x9E3779B97F4A7C15ull + 1;
  // Place the strip so that start_mm falls in the middle of a count.
  const double counts = std::floor(start_mm * inv_res_);
  offset_mm_ = 0.0;
  turns_counts_ = static_cast<std::int64_t>(counts);
  last_count_ = static_cast<int>(((turns_counts_ % counts_) + counts_) % counts_);
}

double As5311Encoder::read(double x_mm) {
  ++reads_;
  // xorshift64 picks the next noise sample.
  pick_ ^= pick_ << 13;
  pick_ ^= pick_ >> 7;
  pick_ ^= pick_ << 17;
  const double sensed = x_mm + p_.noise_rms_um * 1e-3 * normals_[pick_ >> 52];
  const auto counts = static_cast<std::int64_t>(std::floor(sensed * inv_res_));
  As5311Frame f;
  // Within the pole pair (a mask for the AS5311's 4096 counts, no division).
  f.position = static_cast<std::uint16_t>((counts_ & (counts_ - 1)) == 0
                                              ? (counts & (counts_ - 1))
                                              : ((counts % counts_) + counts_) % counts_);
  DecodedFrame d;
  if (p_.corrupt_probability > 0.0) {
    // The frame on the wire, possibly with a flipped bit, and what the reader makes of it.
    std::uint32_t bits = encode_frame(f);
    if (uni_(rng_) < p_.corrupt_probability) bits ^= 1u << static_cast<unsigned>(uni_(rng_) * 18.0);
    d = decode_frame(bits);
  } else {
    // A clean frame decodes to itself (encoder_test checks the round trip).
    d.frame = f;
    d.parity_ok = d.valid = true;
  }
  last_valid_ = d.valid;
  if (!d.valid) {
    ++rejected_;
  } else {
    int delta = static_cast<int>(d.frame.position) - last_count_;
    if (delta >= counts_ / 2) delta -= counts_;
    if (delta < -counts_ / 2) delta += counts_;
    turns_counts_ += delta;
    last_count_ = d.frame.position;
  }
  // The centre of the count: the quantisation error is then within +-resolution/2.
  return (static_cast<double>(turns_counts_) + 0.5) * res_mm_ + offset_mm_;
}

}  // namespace amctl::closedloop
