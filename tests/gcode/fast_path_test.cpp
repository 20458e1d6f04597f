// The interpreter's fast path for plain G0/G1 lines must mean exactly what the general parser
// means: the same doubles, the same modal state, the same events, the same errors. Each check
// runs a program twice, once as written (fast path) and once with an inline "(g)" comment after
// every command word, which the fast path refuses, so every line goes through parse_line() and
// parse_params(). Coordinates are also checked against std::from_chars, independently of both.
#include <charconv>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::gcode {
namespace {

struct Record : EventSink {
  std::vector<MoveRequest> moves;
  std::vector<std::pair<std::int32_t, std::uint64_t>> layers;
  void on_move(const MoveRequest& m) override { moves.push_back(m); }
  void on_layer_change(std::int32_t layer, std::uint64_t line) override { layers.emplace_back(layer, line); }
};

struct Outcome {
  Record events;
  std::vector<std::string> feature_names;
  std::string error;  // what() of the first error, empty if none
};

Outcome run(const std::string& text) {
  Outcome o;
  Interpreter in({}, "t.gcode");
  LineReader reader(text, "t.gcode");
  try {
    in.run(reader, o.events);
  } catch (const Error& e) {
    o.error = e.what();
  }
  o.feature_names = in.annotations().feature_names;
  return o;
}

/// The same program with "(g)" after every G0/G1 word: only the general parser accepts it.
std::string through_general_parser(const std::string& text) {
  std::string out;
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(begin, end - begin);
    if (line.size() >= 2 && (line[0] == 'G' || line[0] == 'g') && (line[1] == '0' || line[1] == '1') &&
        (line.size() == 2 || line[2] == ' ')) {
      line.insert(2, " (g)");
    }
    out += line;
    out += '\n';
    begin = end + 1;
  }
  return out;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_same(const Outcome& fast, const Outcome& general) {
  EXPECT_EQ(fast.error, general.error);
  ASSERT_EQ(fast.events.moves.size(), general.events.moves.size());
  for (std::size_t i = 0; i < fast.events.moves.size(); ++i) {
    const MoveRequest& a = fast.events.moves[i];
    const MoveRequest& b = general.events.moves[i];
    for (std::size_t k = 0; k < 4; ++k) {
      ASSERT_TRUE(same_bits(a.start_mm[k], b.start_mm[k])) << "move " << i << " axis " << k;
      ASSERT_TRUE(same_bits(a.end_mm[k], b.end_mm[k])) << "move " << i << " axis " << k;
    }
    ASSERT_TRUE(same_bits(a.speed_mm_s, b.speed_mm_s)) << "move " << i;
    ASSERT_EQ(a.line, b.line);
    ASSERT_EQ(a.layer, b.layer);
    ASSERT_EQ(a.feature, b.feature);
  }
  EXPECT_EQ(fast.events.layers, general.events.layers);
  EXPECT_EQ(fast.feature_names, general.feature_names);
}

double from_chars_value(const std::string& s) {
  double v = 0.0;
  const char* b = s.data();
  if (*b == '+') ++b;
  auto [ptr, ec] = std::from_chars(b, s.data() + s.size(), v);
  EXPECT_EQ(ec, std::errc());
  EXPECT_EQ(ptr, s.data() + s.size());
  return v;
}

/// Decimal text with 0-4 integer digits and 0-8 fraction digits, sometimes signed.
std::string random_number(std::mt19937_64& rng) {
  std::uniform_int_distribution<int> int_digits(0, 4), frac_digits(0, 8), digit(0, 9), coin(0, 9);
  int ni = int_digits(rng), nf = frac_digits(rng);
  if (ni == 0 && nf == 0) ni = 1;
  std::string s;
  const int sign = coin(rng);
  if (sign == 0) s += '-';
  if (sign == 1) s += '+';
  for (int i = 0; i < ni; ++i) s += static_cast<char>('0' + digit(rng));
  if (nf > 0 || coin(rng) == 0) s += '.';
  for (int i = 0; i < nf; ++i) s += static_cast<char>('0' + digit(rng));
  return s;
}

TEST(InterpreterFastPath, RandomProgramsMeanTheSameThroughBothParsers) {
  std::mt19937_64 rng(20261122);
  std::uniform_int_distribution<int> pick(0, 99);
  const char* modal[] = {"G90", "G91", "M82", "M83", "G92 E0", "G92 X1 Y-2", "G20", "G21",
                         "M220 S80", "M221 S95", ";LAYER_CHANGE", ";TYPE:Perimeter",
                         ";TYPE:Infill", "G1 F1200"};
  for (int program = 0; program < 40; ++program) {
    std::string g = "G21\nG90\nM83\nG1 F3000\n";
    for (int line = 0; line < 400; ++line) {
      const int r = pick(rng);
      if (r < 8) {
        g += modal[static_cast<std::size_t>(pick(rng)) % std::size(modal)];
        g += '\n';
        if (g.ends_with("G20\n")) g += "G1 X0.1\nG21\n";  // keep inch moves small
        continue;
      }
      std::string l = (r % 3 == 0) ? "G0" : (r % 7 == 0 ? "g1" : "G1");
      std::string letters = "XYZEF";
      std::shuffle(letters.begin(), letters.end(), rng);
      const int count = 1 + pick(rng) % 5;
      for (int k = 0; k < count; ++k) {
        char letter = letters[static_cast<std::size_t>(k)];
        if (pick(rng) < 10) letter = static_cast<char>(letter - 'A' + 'a');
        std::string number = random_number(rng);
        // A feedrate the machine can have (kFeedRange: F0.06 and up; F0.02 is an error).
        if ((letter == 'F' || letter == 'f') && (number[0] == '-' || from_chars_value(number) < 0.1)) {
          number = "1500";
        }
        l += pick(rng) < 15 ? "  " : " ";
        l += letter;
        l += number;
      }
      if (pick(rng) < 10) l += " ; a comment";
      if (pick(rng) < 3) l += " ;TYPE:Skirt";
      g += l + '\n';
    }
    SCOPED_TRACE(program);
    const Outcome fast = run(g);
    ASSERT_TRUE(fast.error.empty()) << fast.error;
    // expect_same() compares move by move: two empty lists would agree on nothing.
    ASSERT_GT(fast.events.moves.size(), 100u);
    expect_same(fast, run(through_general_parser(g)));
  }
}

TEST(InterpreterFastPath, CoordinatesAreTheCorrectlyRoundedDecimal) {
  // One move from the origin in absolute mode with no offsets: the machine position is
  // 0 + (v - 0) = v, so it must be exactly std::from_chars's double of the text.
  std::mt19937_64 rng(7);
  for (int i = 0; i < 3000; ++i) {
    const std::string x = random_number(rng), e = random_number(rng);
    const double xv = from_chars_value(x), ev = from_chars_value(e);
    const Outcome o = run(fmt::format("G90\nM82\nG1 X{} Y1 E{} F600\n", x, e));
    ASSERT_TRUE(o.error.empty()) << o.error;
    ASSERT_EQ(o.events.moves.size(), 1u);
    // (-0 lands on +0: 0 + (-0 - 0) is +0, the same machine position.)
    EXPECT_TRUE(xv == 0.0 ? o.events.moves[0].end_mm[0] == 0.0 : same_bits(o.events.moves[0].end_mm[0], xv)) << x;
    EXPECT_TRUE(ev == 0.0 ? o.events.moves[0].end_mm[3] == 0.0 : same_bits(o.events.moves[0].end_mm[3], ev)) << e;
  }
}

TEST(InterpreterFastPath, UnusualLinesFallBackToTheGeneralParser) {
  // Each of these is refused by the fast path (or is an edge it accepts) and must still mean
  // the same thing.
  const char* lines[] = {
      "G1 X1e1 Y2",          // no exponent in G-code: X1, then the word E1
      "G1X5Y6",              // no space after the word
      "G01 X7",              // leading zero in the command number
      "N10 G1 X8*",          // line number (and a checksum, below)
      "G1 X1 X2",            // a repeated letter: the last wins
      "G1 X0.12345678901234567890",  // more digits than the exact rule allows
      "G1 X9\tY3",           // tab (taken by both paths)
      "G1 X1.5(c)Y2",        // inline comment
      "G1 X-.5 Y.25",        // no integer digits
      "G1 X3. Y4.",          // no fraction digits
      "G1 X1.25 Y2.5 E0.125 ; a comment long enough to take the line past 63 bytes",
      "G1 X1.25 Y2.5 E0.125 F1800 Z0.3 ;TYPE:Perimeter with a name past the 63rd byte",
  };
  for (const char* l : lines) {
    std::string line = l;
    if (line == "N10 G1 X8*") {
      unsigned char x = 0;
      for (char c : std::string_view("N10 G1 X8")) x ^= static_cast<unsigned char>(c);
      line = fmt::format("N10 G1 X8*{}", int{x});
    }
    const std::string g = "G1 F600\n" + line + "\nG1 X0 Y0\n";
    SCOPED_TRACE(line);
    const Outcome fast = run(g);
    EXPECT_TRUE(fast.error.empty()) << fast.error;
    expect_same(fast, run(through_general_parser(g)));
    EXPECT_FALSE(fast.events.moves.empty());
  }
  // A NUL byte inside a line is not the end of the line: the general parser rejects it.
  {
    const std::string g = std::string("G1 F600\nG1 X1") + '\0' + " Y2\n";
    const Outcome fast = run(g);
    EXPECT_NE(fast.error.find("t.gcode:2:"), std::string::npos) << fast.error;
  }
  // The last of two X words wins, as in the general parser's Params.
  EXPECT_EQ(run("G1 F60\nG1 X1 X2\n").events.moves.at(0).end_mm[0], 2.0);
}

TEST(InterpreterFastPath, ErrorsAreReportedByTheGeneralParserWithTheirColumn) {
  struct Case {
    const char* text;
    std::uint64_t line;
    std::uint32_t column;
    const char* says;
  };
  const Case cases[] = {
      {"G1 X1 F0\n", 1, 7, "feedrate F must be a feedrate in [0.06"},
      {"G1 X1 F-60\n", 1, 7, "feedrate F must be a feedrate in [0.06"},
      {"G1 X10 F600\nG1 Y10 E", 2, 9, "expected a number after 'E'"},
      {"G1 X1.2.3\n", 1, 8, "malformed number"},
      {"G1 X1 Q5\n", 1, 0, ""},  // Q is not a move word: the general parser takes the line
      {"G91\nG1 X900000000 F100\nG1 X900000000\n", 3, 4, "out of range"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text);
    // (Not compared with through_general_parser(): its "(g)" shifts the columns.)
    const Outcome fast = run(c.text);
    if (c.line == 1 && c.column == 0) {
      EXPECT_TRUE(fast.error.empty()) << fast.error;
      continue;
    }
    EXPECT_NE(fast.error.find(fmt::format("t.gcode:{}:{}:", c.line, c.column)), std::string::npos)
        << fast.error;
    EXPECT_NE(fast.error.find(c.says), std::string::npos) << fast.error;
  }
}

}  // namespace
}  // namespace amctl::gcode
