// split_words: the byte spans of each parameter word, checked against hand-counted offsets
// and against parse_params on the same lines.
#include "amctl/gcode/words.hpp"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace amctl::gcode {
namespace {

std::vector<WordSpan> split(std::string_view line, Params& p) {
  Command c;
  ParseIssue issue;
  EXPECT_TRUE(parse_line(line, c, issue)) << line << ": " << issue.message;
  std::vector<WordSpan> w;
  EXPECT_TRUE(split_words(line, c, w, p, issue)) << line << ": " << issue.message;
  return w;
}

std::string text_of(std::string_view line, const WordSpan& w) {
  return std::string(line.substr(w.number_offset, w.number_size));
}

TEST(Words, GivesTheBytesOfEveryNumber) {
  const std::string_view line = "G1 X10 Y-2.5 e.4 F1800 ; X99";
  Params p;
  const auto w = split(line, p);
  ASSERT_EQ(w.size(), 4u);
  EXPECT_EQ(w[0].letter, 'X');
  EXPECT_EQ(w[0].letter_offset, 3u);
  EXPECT_EQ(text_of(line, w[0]), "10");
  EXPECT_EQ(text_of(line, w[1]), "-2.5");
  EXPECT_EQ(w[2].letter, 'E');  // upper-cased
  EXPECT_EQ(w[2].letter_offset, 13u);
  EXPECT_EQ(text_of(line, w[2]), ".4");
  EXPECT_DOUBLE_EQ(w[2].value, 0.4);
  EXPECT_EQ(text_of(line, w[3]), "1800");
}

TEST(Words, HandlesGluedWordsBlanksCommentsAndBareLetters) {
  {
    const std::string_view line = "N3 G1X10Y5*";
    // no checksum digits: parse_line refuses, nothing to split
    Command c;
    ParseIssue issue;
    EXPECT_FALSE(parse_line(line, c, issue));
  }
  const std::string_view glued = "G1X10Y5";
  Params p;
  auto w = split(glued, p);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0].number_offset, 3u);
  EXPECT_EQ(w[1].letter_offset, 5u);
  EXPECT_EQ(text_of(glued, w[1]), "5");

  const std::string_view spaced = "G1 X 10 (note) Y\t2";
  w = split(spaced, p);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(text_of(spaced, w[0]), "10");
  EXPECT_EQ(w[0].number_offset, 5u);
  EXPECT_EQ(text_of(spaced, w[1]), "2");

  const std::string_view bare = "G28 X Y";
  w = split(bare, p);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_TRUE(w[0].bare());
  EXPECT_TRUE(w[1].bare());
  EXPECT_EQ(w[1].letter_offset, 6u);
  EXPECT_TRUE(p.has('X'));
  EXPECT_EQ(p.bare, (1u << ('X' - 'A')) | (1u << ('Y' - 'A')));
}

TEST(Words, AgreeWithParseParamsAndRejectWhatItRejects) {
  for (const std::string_view line :
       {"G1 X1 Y2 Z3 E4 F5", "G2 X10 Y0 I-5 J0 E.25", "G1 x-0.000 y+3.", "G0 X1e3 Y2",
        "M204 S3000 T2000", "G1 X1 X2"}) {
    Params p;
    const auto w = split(line, p);
    std::uint32_t seen = 0;
    for (const auto& s : w) {
      seen |= 1u << (s.letter - 'A');
      if (s.value != p.get(s.letter)) {
        // Only a repeated letter may differ: parse_params keeps the last.
        int count = 0;
        for (const auto& t : w) count += t.letter == s.letter;
        EXPECT_GT(count, 1) << line << " " << s.letter;
      }
    }
    EXPECT_EQ(seen, p.present) << line;
  }
  for (const std::string_view line : {"G1 X1.2.3", "G1 Xnan", "G1 X10 #"}) {
    Command c;
    ParseIssue issue;
    ASSERT_TRUE(parse_line(line, c, issue)) << line;
    std::vector<WordSpan> w;
    Params p;
    EXPECT_FALSE(split_words(line, c, w, p, issue)) << line;
    EXPECT_GT(issue.column, 0u) << line;
  }
}

}  // namespace
}  // namespace amctl::gcode
