// Binary G-code: files made by an independent writer (tests/reference/bgcode_writer.py, from
// the public specification) in every compression x encoding decode to the text the writer
// states, estimate to the very same numbers as the text, and every kind of damage is an error
// naming the block. With AMCTL_LIBBGCODE_DATA set to the tests/data directory of Prusa's
// libbgcode, PrusaSlicer's own files are checked against Prusa's own conversion to text.
#include <array>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/bgcode.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/formats/sources.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::formats {
namespace {

namespace fs = std::filesystem;
const fs::path kSource = AMCTL_SOURCE_DIR;
constexpr const char* kStem = "boxboss_prusaslicer-2.5_klipper";
const char* const kCompressions[] = {"none", "deflate", "hs11", "hs12"};
const char* const kEncodings[] = {"text", "meatpack", "meatpack-comments"};

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}
void spit(const fs::path& p, std::string_view bytes) {
  std::ofstream(p, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Where a block sits in a file (for the damage tests).
struct BlockAt {
  std::size_t offset = 0, header = 0, params = 0, stored = 0;
  std::uint16_t type = 0, compression = 0;
  [[nodiscard]] std::size_t data() const { return offset + header + params; }
  [[nodiscard]] std::size_t crc() const { return data() + stored; }
};
std::uint32_t le32(const std::string& b, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(b[at + static_cast<std::size_t>(i)]);
  return v;
}
void put32(std::string& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<char>((v >> (8 * i)) & 0xFF);
}
std::vector<BlockAt> blocks(const std::string& b) {
  std::vector<BlockAt> out;
  for (std::size_t at = 10; at < b.size();) {
    BlockAt k;
    k.offset = at;
    k.type = static_cast<std::uint16_t>(static_cast<std::uint8_t>(b[at]) | (static_cast<std::uint8_t>(b[at + 1]) << 8));
    k.compression = static_cast<std::uint16_t>(static_cast<std::uint8_t>(b[at + 2]));
    k.header = k.compression == 0 ? 8 : 12;
    k.stored = k.compression == 0 ? le32(b, at + 4) : le32(b, at + 8);
    k.params = k.type == 5 ? 6 : 2;
    out.push_back(k);
    at = k.crc() + 4;
  }
  return out;
}
/// Writes the right CRC for a block whose bytes were changed on purpose.
void fix_crc(std::string& b, const BlockAt& k) {
  const auto* p = reinterpret_cast<const Bytef*>(b.data() + k.offset);
  put32(b, k.crc(), static_cast<std::uint32_t>(crc32(0L, p, static_cast<uInt>(k.crc() - k.offset))));
}

std::string error_of(const std::string& bytes) {
  try {
    decode_bgcode(bytes, "f.bgcode");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

class Bgcode : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(::testing::TempDir()) / ("amctl_bgcode_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const std::string cmd = "/usr/bin/python3 " + (kSource / "tests/reference/bgcode_writer.py").string() +
                            " --fixtures " + dir_.string() + " --lines 1500 " +
                            (kSource / "examples/gcode" / (std::string(kStem) + ".gcode")).string();
    ok_ = std::system(cmd.c_str()) == 0;
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  void SetUp() override { ASSERT_TRUE(ok_) << "tests/reference/bgcode_writer.py failed"; }
  static fs::path fixture(const std::string& comp, const std::string& enc, const char* ext = ".bgcode") {
    return dir_ / (std::string(kStem) + "_" + comp + "_" + enc + ext);
  }
  static inline fs::path dir_;
  static inline bool ok_ = false;
};

TEST_F(Bgcode, EveryCompressionAndEncodingDecodesToTheWritersText) {
  for (const char* c : kCompressions) {
    for (const char* e : kEncodings) {
      SCOPED_TRACE(std::string(c) + " " + e);
      const std::string text = decode_bgcode(slurp(fixture(c, e)), "f.bgcode");
      EXPECT_EQ(text, slurp(fixture(c, e, ".expected.gcode")));
    }
  }
}

TEST_F(Bgcode, EstimateGivesTheTextsNumbersToTheBit) {
  const machine::Machine m = machine::load_machine((kSource / "configs/klipper-voron-v0.cfg").string());
  const plan::EstimateReport text = plan::estimate_file((dir_ / (std::string(kStem) + ".gcode")).string(), m);
  ASSERT_GT(text.moves, 1000u);
  for (const char* c : kCompressions) {
    for (const char* e : kEncodings) {
      SCOPED_TRACE(std::string(c) + " " + e);
      const plan::EstimateReport r = plan::estimate_file(fixture(c, e).string(), m);
      EXPECT_EQ(r.total_time_s, text.total_time_s);
      EXPECT_EQ(r.motion_time_s, text.motion_time_s);
      EXPECT_EQ(r.moves, text.moves);
      EXPECT_EQ(r.filament_mm, text.filament_mm);
      EXPECT_EQ(r.travel_mm, text.travel_mm);
      // MeatPack without comments drops ";LAYER_CHANGE" and ";TYPE:": the time stays.
      if (std::string(e) != "meatpack") {
        EXPECT_EQ(r.layers.size(), text.layers.size());
        EXPECT_EQ(r.features.size(), text.features.size());
      }
      ASSERT_TRUE(r.slicer_estimate_s.has_value());  // the print metadata's figure
      EXPECT_EQ(*r.slicer_estimate_s, 3723.0);        // the writer's "1h 2m 3s"
    }
  }
}

TEST_F(Bgcode, AnyReadSizeGivesTheSameText) {
  const std::string bytes = slurp(fixture("hs12", "meatpack-comments"));
  const std::string whole = decode_bgcode(bytes, "f.bgcode");
  for (std::size_t step : {1u, 7u, 4096u}) {
    BgcodeReader r(std::make_unique<MemorySource>(bytes), "f.bgcode");
    std::string text;
    std::vector<char> buf(step);
    for (std::size_t k; (k = r.read(buf.data(), buf.size())) > 0;) text.append(buf.data(), k);
    EXPECT_EQ(text, whole) << "read " << step << " bytes at a time";
    EXPECT_EQ(r.stats().thumbnails, 1u);
    EXPECT_EQ(r.stats().metadata_blocks, 4u);
    EXPECT_GE(r.stats().gcode_blocks, 1u);
    EXPECT_TRUE(r.stats().crc32);
  }
}

TEST_F(Bgcode, ADamagedByteIsACrcErrorNamingTheBlock) {
  std::string b = slurp(fixture("hs12", "meatpack-comments"));
  const auto bs = blocks(b);
  const BlockAt& g = bs.at(5);  // the first G-code block (after 4 metadata blocks + thumbnail)
  ASSERT_EQ(g.type, 1);
  b[g.data() + 100] = static_cast<char>(b[g.data() + 100] ^ 0x20);
  const std::string msg = error_of(b);
  EXPECT_NE(msg.find("f.bgcode: block 6 at byte " + std::to_string(g.offset) + " (G-code, heatshrink 12/4)"),
            std::string::npos) << msg;
  EXPECT_NE(msg.find("CRC32"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected"), std::string::npos) << msg;
  // A thumbnail's damage is found as well, though the thumbnail is skipped.
  std::string t = slurp(fixture("hs12", "meatpack-comments"));
  t[bs.at(2).data() + 10] ^= 1;
  EXPECT_NE(error_of(t).find("block 3 at byte"), std::string::npos) << error_of(t);
}

TEST_F(Bgcode, ATruncatedFileSaysSoWhereverItIsCut) {
  const std::string b = slurp(fixture("deflate", "meatpack-comments"));
  const auto bs = blocks(b);
  const BlockAt& g = bs.at(5);
  for (std::size_t cut : {std::size_t{5}, g.offset + 3, g.offset + 10, g.data() + 50, g.crc() + 2}) {
    SCOPED_TRACE(cut);
    const std::string msg = error_of(b.substr(0, cut));
    EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
    EXPECT_NE(msg.find("expected"), std::string::npos) << msg;
  }
}

TEST_F(Bgcode, HeaderAndBlockFieldsOutOfTheSpecificationAreErrors) {
  const std::string good = slurp(fixture("none", "text"));
  std::string b = good;
  b[0] = 'X';
  EXPECT_NE(error_of(b).find("\"GCDE\""), std::string::npos) << error_of(b);
  b = good;
  b[4] = 2;  // version 2
  EXPECT_NE(error_of(b).find("found binary G-code version 2, expected version 1"), std::string::npos);
  b = good;
  b[8] = 3;  // checksum type 3
  EXPECT_NE(error_of(b).find("found checksum type 3"), std::string::npos);
  b = good;
  b[10] = 9;  // first block's type
  EXPECT_NE(error_of(b).find("f.bgcode: block 1 at byte 10: found block type 9, expected 0 to 5"),
            std::string::npos) << error_of(b);
  b = good;
  b[12] = 7;  // first block's compression
  EXPECT_NE(error_of(b).find("found compression 7"), std::string::npos) << error_of(b);
  // A G-code encoding out of range (its CRC made right, so the field itself is what is wrong).
  b = good;
  const BlockAt g = blocks(b).at(5);
  b[g.offset + g.header] = 5;
  fix_crc(b, g);
  EXPECT_NE(error_of(b).find("found G-code encoding 5"), std::string::npos) << error_of(b);
}

TEST_F(Bgcode, ADeclaredSizeThatTheDataDoesNotFillIsAnError) {
  for (const char* c : kCompressions) {
    SCOPED_TRACE(c);
    std::string b = slurp(fixture(c, "meatpack-comments"));
    const BlockAt g = blocks(b).at(5);
    if (g.compression == 0) continue;  // the declared size is the stored size
    put32(b, g.offset + 4, le32(b, g.offset + 4) + 10);  // 10 bytes more than there are
    fix_crc(b, g);
    const std::string msg = error_of(b);
    EXPECT_NE(msg.find("the block header gives"), std::string::npos) << msg;
    put32(b, g.offset + 4, le32(b, g.offset + 4) - 20);  // 10 bytes fewer
    fix_crc(b, g);
    const std::string fewer = error_of(b);
    EXPECT_NE(fewer.find("expected"), std::string::npos) << fewer;
    EXPECT_NE(fewer.find("block 6"), std::string::npos) << fewer;
  }
}

TEST_F(Bgcode, AFileWithoutGcodeBlocksOrWithOneTooLargeIsAnError) {
  const std::string b = slurp(fixture("none", "text"));
  const auto bs = blocks(b);
  EXPECT_NE(error_of(b.substr(0, bs.at(5).offset)).find("no G-code block"), std::string::npos);
  BgcodeLimits small;
  small.max_block_bytes = 1000;
  try {
    decode_bgcode(b, "f.bgcode", small);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("expected at most 1000"), std::string::npos) << e.what();
  }
}

TEST_F(Bgcode, FilesWithoutChecksumsAreRead) {
  const fs::path out = dir_ / "nocrc.bgcode";
  const std::string cmd = "/usr/bin/python3 " + (kSource / "tests/reference/bgcode_writer.py").string() +
                          " " + (dir_ / (std::string(kStem) + ".gcode")).string() + " " + out.string() +
                          " --checksum none --compression deflate --expected " + (dir_ / "nocrc.txt").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  BgcodeReader r(std::make_unique<MemorySource>(slurp(out)), "f.bgcode");
  EXPECT_EQ(decode_bgcode(slurp(out), "f.bgcode"), slurp(dir_ / "nocrc.txt"));
}

TEST_F(Bgcode, AnErrorInTheDecodedGcodeNamesTheLineAndTheBlock) {
  std::string text = slurp(dir_ / (std::string(kStem) + ".gcode"));
  text += "G1 X10 Y\n";  // a word without its number, on the last line
  spit(dir_ / "bad.gcode", text);
  const fs::path out = dir_ / "bad.bgcode";
  const std::string cmd = "/usr/bin/python3 " + (kSource / "tests/reference/bgcode_writer.py").string() +
                          " " + (dir_ / "bad.gcode").string() + " " + out.string() + " --expected " +
                          (dir_ / "bad.txt").string() + " --block-bytes 16384";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  // The bad line's number in the decoded text, counted independently from the writer's text.
  const std::string decoded = slurp(dir_ / "bad.txt");
  std::size_t line = 0, at = 0;
  for (std::size_t i = 0; i < decoded.size(); ++i) {
    if (decoded[i] == '\n') {
      ++line;
      if (decoded.compare(at, 8, "G1 X10 Y") == 0 && i - at == 8) break;
      at = i + 1;
    }
  }
  const machine::Machine m = machine::load_machine("default");
  try {
    plan::estimate_file(out.string(), m);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(e.where().line, line) << msg;
    EXPECT_EQ(e.where().file, out.string()) << msg;
    EXPECT_NE(msg.find("(in G-code block "), std::string::npos) << msg;
  }
}

TEST(BgcodePrusaSlicer, FilesOfLibbgcodeDecodeAsPrusaConvertsThem) {
  const char* data = std::getenv("AMCTL_LIBBGCODE_DATA");
  if (data == nullptr) GTEST_SKIP() << "set AMCTL_LIBBGCODE_DATA to libbgcode's tests/data";
  for (const char* stem : {"mini_cube_b", "mini_cube_ps2.8.1"}) {
    SCOPED_TRACE(stem);
    const std::string mine = decode_bgcode(slurp(fs::path(data) / (std::string(stem) + ".bgcode")), stem);
    const std::string ref = slurp(fs::path(data) / (std::string(stem) + "_ref.gcode"));
    // Prusa's conversion: metadata and thumbnails as comments, a blank line, the G-code
    // blocks' text, a blank line, the configuration. Ours: the G-code text, then the print
    // metadata. Compare the G-code text.
    const std::size_t meta = mine.find("\n; filament used [mm] = ");
    ASSERT_NE(meta, std::string::npos);
    const std::string gcode = mine.substr(0, meta + 1);
    const std::size_t start = ref.find(gcode.substr(0, gcode.find('\n') + 1));
    ASSERT_NE(start, std::string::npos);
    EXPECT_EQ(ref.compare(start, gcode.size(), gcode), 0);
  }
}

}  // namespace
}  // namespace amctl::formats
