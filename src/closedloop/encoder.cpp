#include "amctl/closedloop/encoder.hpp"

#include <bit>
#include <cmath>

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
  require_non_negative("encoder.noise_rms_um", noise_rms_um);
  require_non_negative("encoder.latency_s", latency_s);
  if (!(corrupt_probability >= 0.0 && corrupt_probability <= 1.0)) {
    throw Error("encoder.corrupt_probability = " + std::to_string(corrupt_probability) +
                ": expected a probability in [0, 1]");
  }
}

As5311Encoder::As5311Encoder(const EncoderParameters& p, double start_mm) : p_(p), rng_(p.seed) {
  p_.validate();
  // Place the strip so that start_mm falls in the middle of a count.
  const double counts = std::floor(start_mm / kAs5311ResolutionMm);
  offset_mm_ = 0.0;
  turns_counts_ = static_cast<std::int64_t>(counts);
  last_count_ = static_cast<int>(((turns_counts_ % kAs5311Counts) + kAs5311Counts) % kAs5311Counts);
}

double As5311Encoder::read(double x_mm) {
  ++reads_;
  const double sensed = x_mm + p_.noise_rms_um * 1e-3 * noise_(rng_);
  const auto counts = static_cast<std::int64_t>(std::floor(sensed / kAs5311ResolutionMm));
  As5311Frame f;
  f.position = static_cast<std::uint16_t>(((counts % kAs5311Counts) + kAs5311Counts) % kAs5311Counts);
  std::uint32_t bits = encode_frame(f);
  if (p_.corrupt_probability > 0.0 && uni_(rng_) < p_.corrupt_probability) {
    bits ^= 1u << static_cast<unsigned>(uni_(rng_) * 18.0);
  }
  const DecodedFrame d = decode_frame(bits);
  last_valid_ = d.valid;
  if (!d.valid) {
    ++rejected_;
  } else {
    int delta = static_cast<int>(d.frame.position) - last_count_;
    if (delta >= kAs5311Counts / 2) delta -= kAs5311Counts;
    if (delta < -kAs5311Counts / 2) delta += kAs5311Counts;
    turns_counts_ += delta;
    last_count_ = d.frame.position;
  }
  // The centre of the count: the quantisation error is then within +-resolution/2.
  return (static_cast<double>(turns_counts_) + 0.5) * kAs5311ResolutionMm + offset_mm_;
}

}  // namespace amctl::closedloop
