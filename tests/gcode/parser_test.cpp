#include "amctl/gcode/parser.hpp"

#include <charconv>
#include <random>
#include <string>

#include <gtest/gtest.h>

namespace amctl::gcode {
namespace {

Command parse(std::string_view line) {
  Command c;
  ParseIssue issue;
  EXPECT_TRUE(parse_line(line, c, issue)) << line << ": " << issue.message;
  return c;
}

Params params(std::string_view line) {
  Command c = parse(line);
  Params p;
  ParseIssue issue;
  EXPECT_TRUE(parse_params(c, p, issue)) << line << ": " << issue.message;
  return p;
}

TEST(Parser, ReadsCommandWordAndParametersWithoutSpaces) {
  Command c = parse("G1X10Y-5.5E.25F1200");
  EXPECT_TRUE(c.is('G', 1));
  Params p = params("G1X10Y-5.5E.25F1200");
  EXPECT_DOUBLE_EQ(p.get('X'), 10.0);
  EXPECT_DOUBLE_EQ(p.get('Y'), -5.5);
  EXPECT_DOUBLE_EQ(p.get('E'), 0.25);
  EXPECT_DOUBLE_EQ(p.get('F'), 1200.0);
  EXPECT_FALSE(p.has('Z'));
}

TEST(Parser, AcceptsLowerCaseCommentsAndCarriageReturn) {
  Params p = params("g1 x+3 (move) y4. ; comment\r");
  EXPECT_DOUBLE_EQ(p.get('X'), 3.0);
  EXPECT_DOUBLE_EQ(p.get('Y'), 4.0);
  Command c = parse("g1 x+3 (move) y4. ; comment\r");
  EXPECT_EQ(c.comment, " comment\r");
}

TEST(Parser, ReadsLineNumbersAndVerifiesChecksums) {
  // Checksum: XOR of every byte before '*'. "N1 G28" -> computed by hand below.
  const std::string body = "N1 G28";
  int x = 0;
  for (char ch : body) x ^= static_cast<unsigned char>(ch);
  Command c = parse(body + "*" + std::to_string(x));
  EXPECT_EQ(c.line_number, 1);
  EXPECT_TRUE(c.is('G', 28));
  Command bad;
  ParseIssue issue;
  EXPECT_FALSE(parse_line(body + "*" + std::to_string(x ^ 1), bad, issue));
  EXPECT_NE(issue.message.find("checksum"), std::string::npos);
  EXPECT_EQ(issue.column, 7u);
}

// Found by fuzz_gcode (UBSan: signed overflow in the checksum and N number accumulators).
TEST(Parser, OverlongChecksumsAndLineNumbersAreErrorsNotOverflows) {
  Command c;
  ParseIssue issue;
  EXPECT_FALSE(parse_line("G1 X1*3333333333333333333333", c, issue));
  EXPECT_NE(issue.message.find("checksum mismatch"), std::string::npos);
  EXPECT_EQ(issue.column, 6u);
  EXPECT_FALSE(parse_line("N99999999999999999999999 G1 X1", c, issue));
  EXPECT_NE(issue.message.find("line number"), std::string::npos);
  EXPECT_EQ(issue.column, 2u);
  // The largest accepted line number still reads exactly.
  EXPECT_EQ(parse("N999999999999999999 G1 X1").line_number, 999999999999999999);
}

TEST(Parser, BlankAndCommentOnlyLinesHaveNoCommand) {
  EXPECT_EQ(parse("").kind, CommandKind::none);
  EXPECT_EQ(parse("   \t ").kind, CommandKind::none);
  EXPECT_EQ(parse(";LAYER:3").kind, CommandKind::none);
  EXPECT_EQ(parse(";LAYER:3").comment, "LAYER:3");
  EXPECT_EQ(parse("(only a comment)").kind, CommandKind::none);
}

TEST(Parser, ReadsSubcodesAndKlipperExtendedCommands) {
  Command c = parse("G29.1 Z0.2");
  EXPECT_EQ(c.code, 29);
  EXPECT_EQ(c.subcode, 1);
  Command k = parse("SET_VELOCITY_LIMIT ACCEL=5000 SQUARE_CORNER_VELOCITY=5.5");
  EXPECT_EQ(k.kind, CommandKind::extended);
  EXPECT_EQ(k.name, "SET_VELOCITY_LIMIT");
  std::string_view v;
  std::uint32_t col = 0;
  ASSERT_TRUE(find_extended_arg(k, "square_corner_velocity", v, col));
  EXPECT_EQ(v, "5.5");
  EXPECT_EQ(col, 54u);
  EXPECT_FALSE(find_extended_arg(k, "VELOCITY", v, col));
}

TEST(Parser, AnExtendedParameterGivenTwiceTakesItsLastValueAsKlipperDoes) {
  // gcode.py builds a dict of the parameters: the later KEY=value replaces the earlier one.
  Command k = parse("SET_INPUT_SHAPER SHAPER_FREQ_X=40 shaper_freq_x=50");
  std::string_view v;
  std::uint32_t col = 0;
  ASSERT_TRUE(find_extended_arg(k, "SHAPER_FREQ_X", v, col));
  EXPECT_EQ(v, "50");
  EXPECT_EQ(col, 49u);  // 1-based: "SET_INPUT_SHAPER SHAPER_FREQ_X=40 shaper_freq_x=" is 48 characters
}

TEST(Parser, ReportsMalformedNumbersWithTheirColumn) {
  Command c = parse("G1 X1.2.3");
  Params p;
  ParseIssue issue;
  EXPECT_FALSE(parse_params(c, p, issue));
  EXPECT_EQ(issue.column, 8u);
  c = parse("G1 Xabc");
  EXPECT_FALSE(parse_params(c, p, issue));
  EXPECT_EQ(issue.column, 5u);
  EXPECT_NE(issue.message.find("expected a number after 'X'"), std::string::npos) << issue.message;
  c = parse("G1 X1 #");
  EXPECT_FALSE(parse_params(c, p, issue));
  EXPECT_EQ(issue.column, 7u);
}

TEST(Parser, RejectsNanInfinityAndOverflow) {
  Params p;
  ParseIssue issue;
  for (const std::string& line : {std::string("G1 Xnan"), std::string("G1 Xinf"), std::string("G1 X-inf"),
                                 "G1 X1" + std::string(400, '0')}) {
    Command c = parse(line);
    EXPECT_FALSE(parse_params(c, p, issue)) << line;
  }
}

TEST(Parser, RejectsLinesThatAreNotCommands) {
  Command c;
  ParseIssue issue;
  EXPECT_FALSE(parse_line("123 G1", c, issue));
  EXPECT_EQ(issue.column, 1u);
  ASSERT_TRUE(parse_line("G1 (unterminated", c, issue));  // arguments are parsed on demand
  Params p;
  EXPECT_FALSE(parse_params(c, p, issue));
  EXPECT_NE(issue.message.find("unterminated"), std::string::npos);
}

TEST(Parser, ParseNumberHandlesAllDecimalForms) {
  double v = 0;
  EXPECT_EQ(parse_number("-.5", v), 3u);
  EXPECT_DOUBLE_EQ(v, -0.5);
  // No exponent in G-code: the number ends at 'e' (Klipper splits at letters, Marlin's
  // value_float() stops at E), so "+2.5e-3" is 2.5 followed by the word E-3.
  EXPECT_EQ(parse_number("+2.5e-3X", v), 4u);
  EXPECT_DOUBLE_EQ(v, 2.5);
  EXPECT_EQ(parse_number("40E1.5", v), 2u);
  EXPECT_DOUBLE_EQ(v, 40.0);
  // More digits than the exact rule takes: the correctly rounded value, still no exponent.
  EXPECT_EQ(parse_number("0.12345678901234567890123e5", v), 25u);
  EXPECT_DOUBLE_EQ(v, 0.12345678901234567890123);
  EXPECT_EQ(parse_number("7.", v), 2u);
  EXPECT_DOUBLE_EQ(v, 7.0);
  EXPECT_EQ(parse_number("nan", v), 0u);
  EXPECT_EQ(parse_number(".", v), 0u);
  EXPECT_EQ(parse_number("-", v), 0u);
}

TEST(Parser, FastNumberPathAgreesWithFromCharsBitForBit) {
  std::mt19937_64 rng(12345);  // seeded: the same cases every run
  for (int n = 0; n < 200000; ++n) {
    const int int_digits = static_cast<int>(rng() % 6);
    const int frac_digits = static_cast<int>(rng() % 8);
    std::string s = (rng() % 2) ? "-" : "";
    for (int k = 0; k < int_digits; ++k) s += static_cast<char>('0' + rng() % 10);
    if (int_digits == 0) s += "0";
    if (frac_digits > 0) {
      s += ".";
      for (int k = 0; k < frac_digits; ++k) s += static_cast<char>('0' + rng() % 10);
    }
    double fast = 0, ref = 0;
    ASSERT_EQ(parse_number(s, fast), s.size()) << s;
    std::from_chars(s.data() + (s[0] == '-'), s.data() + s.size(), ref);
    if (s[0] == '-') ref = -ref;
    ASSERT_EQ(fast, ref) << s;
  }
}

}  // namespace
}  // namespace amctl::gcode

#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::gcode {
namespace {

struct Moves : EventSink {
  std::vector<MoveRequest> moves;
  void on_move(const MoveRequest& m) override { moves.push_back(m); }
};

// Dense (space-free) G-code and letters inside numbers, read as Klipper and Marlin read them
// (issue 14): Klipper upper-cases the line and splits it at every letter (klippy/gcode.py);
// Marlin's parser takes each letter's value up to the next letter and value_float() stops at
// 'E'. Neither knows an exponent.
TEST(Parser, DenseGcodeAndLettersEndNumbersAsFirmwareReadsThem) {
  struct Case {
    const char* line;
    std::array<double, 4> end;
  };
  const Case cases[] = {
      {"G1X30Y40E1.5", {30, 40, 0, 1.5}},
      {"G1 X30Y40E1.5", {30, 40, 0, 1.5}},
      {"G1 X1E5", {1, 0, 0, 5}},
      {"G1 X1e5", {1, 0, 0, 5}},
      {"G1 X2.5e-3 Y1", {2.5, 1, 0, -3}},
      {"g1 x3 y4 e0.5", {3, 4, 0, 0.5}},
      {"G1 Y.5E.25", {0, 0.5, 0, 0.25}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.line);
    InterpreterOptions o;
    Interpreter in(o, "t.gcode");
    Moves m;
    in.feed("M82", 1, m);
    in.feed("G1 F600", 2, m);
    in.feed(c.line, 3, m);
    ASSERT_EQ(m.moves.size(), 1u);
    for (int a = 0; a < 4; ++a) EXPECT_DOUBLE_EQ(m.moves[0].end_mm[a], c.end[a]) << a;
  }
}

}  // namespace
}  // namespace amctl::gcode
