// Heatshrink decoding against bit streams written out by hand from the format's description
// (formats/heatshrink.hpp): tag 1 + 8-bit literal, tag 0 + W-bit (distance - 1) + L-bit
// (count - 1), most significant bit first, the last byte padded with zeros.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/heatshrink.hpp"

namespace amctl::formats {
namespace {

/// "1 01000001 0 ..." -> bytes (spaces ignored), zero-padded to a whole byte.
std::vector<std::uint8_t> bits(const std::string& s) {
  std::vector<std::uint8_t> out;
  int n = 0;
  std::uint8_t acc = 0;
  for (char c : s) {
    if (c == ' ') continue;
    acc = static_cast<std::uint8_t>((acc << 1) | (c == '1' ? 1 : 0));
    if (++n == 8) {
      out.push_back(acc);
      acc = 0;
      n = 0;
    }
  }
  if (n > 0) out.push_back(static_cast<std::uint8_t>(acc << (8 - n)));
  return out;
}

std::string decode_all(HeatshrinkDecoder& d, const std::vector<std::uint8_t>& in, std::size_t step = 4096) {
  d.reset(in);
  std::string out;
  std::vector<std::uint8_t> buf(step);
  for (std::size_t k; (k = d.decode(buf.data(), buf.size())) > 0;) out.append(buf.begin(), buf.begin() + static_cast<long>(k));
  return out;
}

TEST(Heatshrink, LiteralsAreTagOneAndEightBits) {
  HeatshrinkDecoder d(12, 4);
  // 'G' = 01000111, '1' = 00110001: 18 bits, padded to 3 bytes.
  EXPECT_EQ(decode_all(d, bits("1 01000111 1 00110001")), "G1");
  EXPECT_EQ(d.untouched_input_bytes(), 0u);
}

TEST(Heatshrink, BackReferenceMayOverlapWhatItWrites) {
  HeatshrinkDecoder d(12, 4);
  // 'A', then distance 1 (index 0) count 5 (count field 4): "AAAAAA".
  EXPECT_EQ(decode_all(d, bits("1 01000001 0 000000000000 0100")), "AAAAAA");
}

TEST(Heatshrink, BackReferenceCopiesFromFurtherBack) {
  HeatshrinkDecoder d(11, 4);
  // "XY" then distance 2 (index 1, 11 bits) count 4 (field 3): "XYXYXY".
  EXPECT_EQ(decode_all(d, bits("1 01011000 1 01011001 0 00000000001 0011")), "XYXYXY");
}

TEST(Heatshrink, WindowBitsChangeHowTheSameBitsRead) {
  // The same back-reference bits under W = 12 and W = 11: the index field is one bit longer.
  const auto in = bits("1 01000001 1 01000010 0 000000000001 0001");
  HeatshrinkDecoder w12(12, 4), w11(11, 4);
  EXPECT_EQ(decode_all(w12, in), "ABAB");
  // W = 11 reads index 0 (the first 11 of the 12 zero-and-one bits) -> distance 1, then the
  // count field "1000" (the index's last bit and three of "0001") -> count 9; what is left,
  // "1" + five padding zeros, is a literal's tag without its 8 bits: the stream ends.
  EXPECT_EQ(decode_all(w11, in), "AB" + std::string(9, 'B'));
}

TEST(Heatshrink, ReferenceBeforeTheStartIsAnError) {
  HeatshrinkDecoder d(12, 4);
  const auto in = bits("1 01000001 0 000000000101 0000");  // distance 6 after 1 byte
  d.reset(in);  // the decoder reads the caller's bytes: they must outlive it
  std::vector<std::uint8_t> buf(16);
  EXPECT_THROW(d.decode(buf.data(), buf.size()), Error);
}

TEST(Heatshrink, StopsAtTheBytesAskedForAndResumesInsideABackReference) {
  HeatshrinkDecoder d(12, 4);
  const auto in = bits("1 01000001 0 000000000000 1111");  // 'A' + 16 more 'A'
  EXPECT_EQ(decode_all(d, in, 1), std::string(17, 'A'));
  EXPECT_EQ(decode_all(d, in, 5), std::string(17, 'A'));
  EXPECT_EQ(d.produced(), 17u);
}

TEST(Heatshrink, ReportsWholeBytesLeftOver) {
  HeatshrinkDecoder d(12, 4);
  auto in = bits("1 01000001");
  in.push_back(0xAB);
  in.push_back(0xCD);
  d.reset(in);
  std::vector<std::uint8_t> buf(1);
  ASSERT_EQ(d.decode(buf.data(), 1), 1u);
  EXPECT_EQ(buf[0], 'A');
  // 9 bits read: the second byte is partly read, 0xAB and 0xCD untouched.
  EXPECT_EQ(d.untouched_input_bytes(), 2u);
}

}  // namespace
}  // namespace amctl::formats
