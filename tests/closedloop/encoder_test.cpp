// AS5311 frames (18 bits: D11..D0, OCF, COF, LIN, MagINC, MagDEC, even parity), pole-crossing
// unwrapping and the hold of the last good value on a corrupted frame.
#include <bit>
#include <cmath>

#include <gtest/gtest.h>

#include "amctl/closedloop/encoder.hpp"

namespace amctl::closedloop {
namespace {

TEST(As5311, ResolutionIsTwoMillimetresOver4096) {
  EXPECT_NEAR(kAs5311ResolutionMm * 1000.0, 0.48828125, 1e-12);
}

TEST(As5311, FrameLayoutAndEvenParityByHand) {
  // Position 0xA5C = 1010 0101 1100, OCF = 1, others 0: bits 101001011100 1 0 0 0 0 P.
  // Ones: 1+0+1+0+0+1+0+1+1+1+0+0 = 6, + OCF = 7 -> parity bit 1.
  As5311Frame f;
  f.position = 0xA5C;
  const std::uint32_t b = encode_frame(f);
  EXPECT_EQ(b, (0xA5Cu << 6) | (1u << 5) | 1u);
  const DecodedFrame d = decode_frame(b);
  EXPECT_TRUE(d.parity_ok);
  EXPECT_TRUE(d.valid);
  EXPECT_EQ(d.frame.position, 0xA5C);
}

TEST(As5311, EverySingleBitFlipIsDetected) {
  As5311Frame f;
  f.position = 1234;
  const std::uint32_t b = encode_frame(f);
  for (int bit = 0; bit < 18; ++bit) {
    const DecodedFrame d = decode_frame(b ^ (1u << bit));
    EXPECT_FALSE(d.parity_ok) << bit;
    EXPECT_FALSE(d.valid) << bit;
  }
}

TEST(As5311, StatusBitsInvalidateTheData) {
  As5311Frame f;
  f.ocf = false;
  EXPECT_FALSE(decode_frame(encode_frame(f)).valid);
  f = {};
  f.cof = true;
  EXPECT_FALSE(decode_frame(encode_frame(f)).valid);
  f = {};
  f.lin = true;
  EXPECT_FALSE(decode_frame(encode_frame(f)).valid);
  f = {};
  f.mag_inc = f.mag_dec = true;
  EXPECT_FALSE(decode_frame(encode_frame(f)).valid);
  f = {};
  f.mag_inc = true;  // field increasing alone is only a hint
  EXPECT_TRUE(decode_frame(encode_frame(f)).valid);
}

TEST(As5311, UnwrapsAcrossPolesBothWays) {
  EncoderParameters p;
  p.noise_rms_um = 0.0;
  As5311Encoder enc(p, 0.3);
  for (double x = 0.3; x < 10.3; x += 0.37) {
    EXPECT_NEAR(enc.read(x), x, 0.5 * kAs5311ResolutionMm + 1e-12) << x;
  }
  for (double x = 10.3; x > -6.0; x -= 0.41) {
    EXPECT_NEAR(enc.read(x), x, 0.5 * kAs5311ResolutionMm + 1e-12) << x;
  }
}

TEST(As5311, CorruptedFramesHoldTheLastGoodValue) {
  EncoderParameters p;
  p.noise_rms_um = 0.0;
  p.corrupt_probability = 1.0;
  As5311Encoder enc(p, 5.0);
  const double held = enc.read(5.0);
  EXPECT_NEAR(held, 5.0, kAs5311ResolutionMm);
  EXPECT_EQ(enc.read(7.0), held);
  EXPECT_FALSE(enc.last_valid());
  EXPECT_EQ(enc.rejected_frames(), 2u);
}

}  // namespace
}  // namespace amctl::closedloop
