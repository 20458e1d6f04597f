// MeatPack decoding against bytes packed by hand from the format's description
// (formats/meatpack.hpp): codes 0-9 '.', ' ', '\n', 'G', 'X' = 0..14 two per byte, low nibble
// first; 15 = the character follows whole; 0xFF 0xFF + command.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/formats/meatpack.hpp"

namespace amctl::formats {
namespace {

constexpr std::uint8_t kOn[] = {0xFF, 0xFF, 251};
constexpr std::uint8_t kOff[] = {0xFF, 0xFF, 250};
constexpr std::uint8_t kNoSpaces[] = {0xFF, 0xFF, 247};

std::uint8_t pair(int low, int high) { return static_cast<std::uint8_t>(low | (high << 4)); }
constexpr int kDot = 10, kSpace = 11, kNl = 12, kG = 13, kX = 14, kWhole = 15;

std::string decode(const std::vector<std::uint8_t>& in, std::size_t step = 1000) {
  MeatPackDecoder d;
  d.reset();
  std::string out;
  for (std::size_t i = 0; i < in.size(); i += step) {
    const std::size_t n = std::min(step, in.size() - i);
    d.decode(std::span<const std::uint8_t>(in.data() + i, n), out);
  }
  EXPECT_FALSE(d.pending());
  return out;
}

std::vector<std::uint8_t> cat(std::initializer_list<std::vector<std::uint8_t>> parts) {
  std::vector<std::uint8_t> v;
  for (const auto& p : parts) v.insert(v.end(), p.begin(), p.end());
  return v;
}
std::vector<std::uint8_t> v(const std::uint8_t (&a)[3]) { return {a, a + 3}; }

TEST(MeatPack, PacksTwoCharactersPerByteLowNibbleFirst) {
  // "G1\n": (G,1) then ('\n', padding): the high nibble after a newline is ignored.
  EXPECT_EQ(decode(cat({v(kOn), {pair(kG, 1), pair(kNl, kNl)}})), "G1\n");
  // "G28\n": (G,2) (8,'\n').
  EXPECT_EQ(decode(cat({v(kOn), {pair(kG, 2), pair(8, kNl)}})), "G28\n");
}

TEST(MeatPack, WholeBytesFollowTheirPair) {
  // ('M','1'): the low nibble is whole: 'M' comes as the next byte, then the '1'.
  EXPECT_EQ(decode(cat({v(kOn), {pair(kWhole, 1), 'M', pair(0, 4), pair(kNl, kNl)}})), "M104\n");
  // ('1','M'): the high nibble is whole.
  EXPECT_EQ(decode(cat({v(kOn), {pair(1, kWhole), 'M', pair(kNl, kNl)}})), "1M\n");
  // Both whole: 0xFF and two bytes ("Y-").
  EXPECT_EQ(decode(cat({v(kOn), {0xFF, 'Y', '-', pair(5, kNl)}})), "Y-5\n");
}

TEST(MeatPack, SpacesGoBackIntoGLinesBeforeParameterLetters) {
  // "G1X10Y-5E.2\n" as the writer sends it (no spaces, "no spaces" on: code 11 is 'E').
  const auto in = cat({v(kOn), v(kNoSpaces),
                       {pair(kG, 1), pair(kX, 1), pair(0, kWhole), 'Y', 0xFF, '-', '5',
                        pair(kSpace, kDot), pair(2, kNl)}});
  EXPECT_EQ(decode(in), "G1 X10 Y-5 E.2\n");
  EXPECT_EQ(decode(in, 1), "G1 X10 Y-5 E.2\n");  // byte by byte: the same
}

TEST(MeatPack, OtherLinesKeepTheirTextAsSent) {
  // "M204 S800\n" with "no spaces" off: the space is code 11 and stays where it is; a line
  // that starts with G but not G + digit gets no spaces put in.
  EXPECT_EQ(decode(cat({v(kOn), {pair(kWhole, 2), 'M', pair(0, 4), pair(kSpace, kWhole), 'S',
                                 pair(8, 0), pair(0, kNl)}})),
            "M204 S800\n");
  EXPECT_EQ(decode(cat({v(kOn), {pair(kG, kWhole), 'E', pair(kWhole, kWhole), 'T', '_',
                                 pair(kNl, kNl)}})),
            "GET_\n");
}

TEST(MeatPack, PackingOffPassesCommentLinesThrough) {
  std::vector<std::uint8_t> in = v(kOff);
  for (char c : std::string(";LAYER_CHANGE\n;Z:0.2\n")) in.push_back(static_cast<std::uint8_t>(c));
  in.insert(in.end(), kOn, kOn + 3);
  in.push_back(pair(kG, 1));
  in.push_back(pair(kNl, kNl));
  EXPECT_EQ(decode(in), ";LAYER_CHANGE\n;Z:0.2\nG1\n");
}

TEST(MeatPack, EmptyLinesAreDropped) {
  EXPECT_EQ(decode(cat({v(kOn), {pair(kG, 1), pair(kNl, kNl), pair(kNl, kNl), pair(kG, 4),
                                 pair(kNl, kNl)}})),
            "G1\nG4\n");
}

TEST(MeatPack, EndingInsideAPairIsPending) {
  MeatPackDecoder d;
  d.reset();
  std::string out;
  const std::vector<std::uint8_t> in = cat({v(kOn), {pair(kWhole, 1)}});  // 'M' never comes
  d.decode(in, out);
  EXPECT_TRUE(d.pending());
}

}  // namespace
}  // namespace amctl::formats
