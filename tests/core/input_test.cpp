// The one input reader (core/input.hpp): line ends, streams read once, rewinding, and the
// inputs that cannot be read.
#include "amctl/core/input.hpp"
#include "amctl/core/text_input.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> lines_of(LineReader& r) {
  std::vector<std::string> out;
  std::string_view line;
  while (r.next(line)) out.emplace_back(line);
  return out;
}

/// A source handing out its text a few bytes at a time (every buffer boundary gets tried).
class Trickle final : public ByteSource {
 public:
  Trickle(std::string text, std::size_t step) : text_(std::move(text)), step_(step) {}
  std::size_t read(char* dst, std::size_t n) override {
    const std::size_t k = std::min({n, step_, text_.size() - pos_});
    text_.copy(dst, k, pos_);
    pos_ += k;
    return k;
  }
  [[nodiscard]] const std::string& name() const override { return name_; }

 private:
  std::string text_;
  std::size_t step_, pos_ = 0;
  std::string name_ = "trickle";
};

TEST(LineReader, LfCrlfAndALoneCrEachEndALine) {
  // Hand-counted: "a" LF, "b" CRLF, "c" CR, "" CRLF, "d" CR CR -> "d", "", then "e" unterminated.
  const std::string text = "a\nb\r\nc\r\r\nd\r\re";
  const std::vector<std::string> want{"a", "b", "c", "", "d", "", "e"};
  LineReader mem(text, "t");
  EXPECT_EQ(lines_of(mem), want);
  EXPECT_TRUE(mem.ended_without_newline());
  EXPECT_EQ(mem.bytes_read(), text.size());
  for (std::size_t step : {1u, 2u, 3u, 7u}) {
    LineReader r(std::make_unique<Trickle>(text, step), 4096);
    EXPECT_EQ(lines_of(r), want) << "step " << step;
    EXPECT_EQ(r.line_number(), want.size());
    EXPECT_EQ(r.bytes_read(), text.size());
  }
}

TEST(LineReader, TellsEachLinesTerminator) {
  LineReader r(std::string_view("a\r\nb\rc\nd"), "t");
  std::string_view line;
  std::vector<std::string> terms;
  while (r.next(line)) terms.emplace_back(r.terminator());
  EXPECT_EQ(terms, (std::vector<std::string>{"\r\n", "\r", "\n", ""}));
}

TEST(LineReader, ACrOnlyFileIsManyLines) {
  std::string text;
  for (int i = 0; i < 10000; ++i) text += "G1 X" + std::to_string(i) + "\r";
  LineReader r(std::make_unique<Trickle>(text, 4093), 4096);
  const auto lines = lines_of(r);
  ASSERT_EQ(lines.size(), 10000u);
  EXPECT_EQ(lines[9999], "G1 X9999");
  EXPECT_FALSE(r.ended_without_newline());
}

TEST(LineReader, ALineLongerThanTheBufferIsAnErrorWithItsLine) {
  const std::string text = "ok\n" + std::string(10000, 'x') + "\n";
  LineReader r(std::make_unique<Trickle>(text, 100000), 4096);
  std::string_view line;
  EXPECT_TRUE(r.next(line));
  try {
    r.next(line);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.where().line, 2u);
  }
}

class InputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("amctl_input_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& n) const { return (dir_ / n).string(); }
  fs::path dir_;
};

std::string read_all(ByteSource& s) {
  std::string out;
  char buf[777];
  for (std::size_t n = 0; (n = s.read(buf, sizeof buf)) != 0;) out.append(buf, n);
  return out;
}

TEST_F(InputTest, ARegularFileIsReadAgainThroughTheSameDescriptor) {
  const std::string p = path("f.txt");
  std::ofstream(p) << "hello\nworld\n";
  InputFile in(p, InputOptions{"text", true, 0});
  EXPECT_EQ(in.size(), 12u);
  EXPECT_EQ(read_all(in), "hello\nworld\n");
  fs::rename(p, path("moved.txt"));  // the open file is still the one read
  in.rewind();
  EXPECT_EQ(read_all(in), "hello\nworld\n");
}

TEST_F(InputTest, AFileChangedBetweenPassesIsAnError) {
  const std::string p = path("f.txt");
  std::ofstream(p) << "hello\n";
  InputFile in(p, InputOptions{"text", true, 0});
  (void)read_all(in);
  std::ofstream(p, std::ios::app) << "more\n";
  EXPECT_THROW(in.rewind(), Error);
}

// A FIFO is read once; the second pass reads the copy the reader kept, and a pass that
// stopped early continues from the source.
TEST_F(InputTest, AFifoIsReadOnceAndRewoundFromTheCopy) {
  const std::string p = path("pipe");
  ASSERT_EQ(::mkfifo(p.c_str(), 0600), 0);
  std::string text;
  for (int i = 0; i < 20000; ++i) text += "line " + std::to_string(i) + "\n";
  std::thread writer([&] { std::ofstream(p, std::ios::binary) << text; });
  InputFile in(p, InputOptions{"text", true, 0});
  EXPECT_FALSE(in.size());
  char head[1000];
  ASSERT_EQ(in.read(head, sizeof head), sizeof head);  // a partial first pass
  in.rewind();
  EXPECT_EQ(read_all(in), text);
  in.rewind();
  EXPECT_EQ(read_all(in), text);
  writer.join();
}

TEST_F(InputTest, PeekedBytesAreReadFirstAndDecodersSeeThem) {
  const std::string p = path("f.bin");
  std::ofstream(p) << "GCDE....";
  InputFile in(p);
  EXPECT_EQ(in.peek(4), "GCDE");
  Decoder d{"test", [](std::string_view first, std::string_view) { return first.substr(0, 4) == "GCDE"; },
            [](ByteSource&) -> std::unique_ptr<ByteSource> { throw Error("decoded"); }};
  EXPECT_THROW((void)decode(in, {d}), Error);
  EXPECT_EQ(read_all(in), "GCDE....");
}

TEST_F(InputTest, WhatCannotBeReadIsAnErrorNamingIt) {
  try {
    InputFile in(dir_.string(), InputOptions{"G-code file", false, 0});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.where().file, dir_.string());
    EXPECT_NE(std::string(e.what()).find("directory"), std::string::npos);
  }
  try {
    InputFile in(path("missing.gcode"), InputOptions{"G-code file", false, 0});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.where().file, path("missing.gcode"));
  }
  std::ofstream(path("big.txt")) << std::string(5000, 'x');
  EXPECT_THROW(InputFile(path("big.txt"), InputOptions{"text", false, 4096}), Error);
  EXPECT_THROW((void)read_whole_input(path("big.txt"), InputOptions{"text", false, 4096}), Error);
  EXPECT_EQ(read_whole_input(path("big.txt")).size(), 5000u);
}

TEST_F(InputTest, TextDropsAUtf8ByteOrderMarkAndRefusesUtf16) {
  std::ofstream(path("bom.cfg"), std::ios::binary) << "\xEF\xBB\xBF[printer]\n";
  EXPECT_EQ(read_whole_text(path("bom.cfg")), "[printer]\n");
  EXPECT_EQ(read_whole_input(path("bom.cfg")).size(), 13u);  // bytes as they are (binary formats)
  for (const char* bom : {"\xFF\xFE", "\xFE\xFF"}) {
    std::ofstream(path("u16.cfg"), std::ios::binary) << bom << std::string("[\0p\0", 4);
    try {
      (void)read_whole_text(path("u16.cfg"));
      ADD_FAILURE();
    } catch (const Error& e) {
      EXPECT_EQ(e.where().file, path("u16.cfg"));
      EXPECT_EQ(e.where().line, 1u);
      EXPECT_EQ(e.where().column, 1u);
      EXPECT_NE(std::string(e.what()).find("found UTF-16 text"), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace amctl
