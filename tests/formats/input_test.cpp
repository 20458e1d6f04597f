// Opening an input by its content: plain text, binary G-code, a sliced 3MF, gzip, and 3D
// models refused with "slice it first", whatever the file is called.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <zlib.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/formats/sources.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::formats {
namespace {

namespace fs = std::filesystem;

std::string read_all(gcode::ByteSource& s) {
  std::string out;
  std::string buf(4096, '\0');
  for (std::size_t k; (k = s.read(buf.data(), buf.size())) > 0;) out.append(buf.data(), k);
  return out;
}

class Input : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("amctl_input_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string write(const std::string& name, std::string_view bytes) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p.string();
  }
  static std::string error_of(const std::string& path) {
    try {
      open_gcode_input(path);
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  }
  fs::path dir_;
};

TEST_F(Input, RecognisesContentFromTheFirstBytes) {
  EXPECT_EQ(detect_content("G28\nG1 X10\n"), ContentKind::gcode_text);
  EXPECT_EQ(detect_content(std::string("GCDE\x01\0\0\0\x01\0", 10)), ContentKind::binary_gcode);
  EXPECT_EQ(detect_content(std::string("PK\x03\x04", 4)), ContentKind::zip);
  EXPECT_EQ(detect_content("\x1f\x8b\x08"), ContentKind::gzip);
  EXPECT_EQ(detect_content("solid cube\n facet normal 0 0 1\n"), ContentKind::stl_ascii);
  EXPECT_EQ(detect_content("  SOLID\n"), ContentKind::stl_ascii);
  EXPECT_EQ(detect_content("solidify\n"), ContentKind::gcode_text);  // not the word "solid"
  EXPECT_EQ(detect_content("ISO-10303-21;\nHEADER;\n"), ContentKind::step);
  // Binary STL: 80-byte header, a triangle count, 50 bytes per triangle.
  std::string stl(84, '\0');
  stl[80] = 2;
  EXPECT_EQ(detect_content(stl, 84 + 2 * 50), ContentKind::stl_binary);
  EXPECT_EQ(detect_content(stl, 84 + 2 * 50 + 1), ContentKind::gcode_text);
  EXPECT_EQ(detect_content(stl, 0), ContentKind::gcode_text);  // size unknown (a pipe)
}

TEST_F(Input, PlainTextIsReadAsItIs) {
  const std::string text = "G28\nG1 X10 F600\n";
  GcodeInput in = open_gcode_input(write("a.gcode", text));
  EXPECT_EQ(in.format, GcodeFormat::text);
  EXPECT_EQ(read_all(*in.bytes), text);
  // Shorter than the bytes looked at, and empty.
  GcodeInput e = open_gcode_input(write("e.gcode", ""));
  EXPECT_EQ(read_all(*e.bytes), "");
}

TEST_F(Input, GzipIsInflatedAsAStream) {
  std::string text;
  for (int i = 0; i < 20000; ++i) text += "G1 X" + std::to_string(i % 200) + " Y5 E0.1\n";
  // gzip it with zlib (windowBits 15 + 16 = the gzip wrapper).
  z_stream zs{};
  ASSERT_EQ(deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string gz(deflateBound(&zs, text.size()), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(text.data());
  zs.avail_in = static_cast<uInt>(text.size());
  zs.next_out = reinterpret_cast<Bytef*>(gz.data());
  zs.avail_out = static_cast<uInt>(gz.size());
  ASSERT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  gz.resize(zs.total_out);
  deflateEnd(&zs);
  GcodeInput in = open_gcode_input(write("a.gcode.gz", gz));
  EXPECT_EQ(in.format, GcodeFormat::gzip);
  EXPECT_EQ(read_all(*in.bytes), text);
  // Cut short: said so.
  GcodeInput cut = open_gcode_input(write("cut.gcode.gz", gz.substr(0, gz.size() / 2)));
  try {
    read_all(*cut.bytes);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  // The decoder sits on the project's one reader: a rewindable input is decoded again from its
  // first byte on the second pass (M73, the scaler), a regular file and a FIFO alike.
  const std::string path = write("b.gcode.gz", gz);
  InputFile file(path, gcode::gcode_input_options(true));
  GcodeFormat format = GcodeFormat::text;
  EXPECT_EQ(read_all(*decode_gcode(file, {}, &format)), text);
  EXPECT_EQ(format, GcodeFormat::gzip);
  file.rewind();
  EXPECT_EQ(read_all(*decode_gcode(file)), text);
  const std::string fifo = (dir_ / "in.fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    std::ofstream w(fifo, std::ios::binary);
    w.write(gz.data(), static_cast<std::streamsize>(gz.size()));
    w.close();
    ::_exit(0);
  }
  InputFile piped(fifo, gcode::gcode_input_options(true));
  EXPECT_EQ(read_all(*decode_gcode(piped)), text);
  piped.rewind();  // from the reader's own copy: the pipe is read once
  EXPECT_EQ(read_all(*decode_gcode(piped)), text);
  int status = 0;
  ::waitpid(child, &status, 0);
}

TEST_F(Input, ModelsAreToBeSlicedFirstWhateverTheirName) {
  const std::string ascii = "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n"
                            "  vertex 1 0 0\n  vertex 0 1 0\n endloop\nendfacet\nendsolid t\n";
  for (const char* name : {"m.stl", "m.gcode"}) {
    const std::string msg = error_of(write(name, ascii));
    EXPECT_NE(msg.find(std::string(name) + ": found a 3D model (an ASCII STL), expected G-code: "
                       "this is a model, slice it first"),
              std::string::npos)
        << msg;
  }
  std::string bin(84 + 50, '\0');
  bin.replace(0, 5, "solid");  // binary STLs often start with "solid" too
  bin[80] = 1;
  EXPECT_NE(error_of(write("b.stl", bin)).find("(a binary STL)"), std::string::npos);
  EXPECT_NE(error_of(write("s.step", "ISO-10303-21;\n")).find("(a STEP file)"), std::string::npos);
}

TEST_F(Input, MissingFilesAndDirectoriesAreClearErrors) {
  EXPECT_NE(error_of((dir_ / "nothere.gcode").string()).find("no such file; expected a G-code file"), std::string::npos);
  EXPECT_NE(error_of(dir_.string()).find("is a directory; expected a G-code file"), std::string::npos);
  // A member path under a file that is not a zip.
  const std::string text = write("t.gcode", "G28\n");
  EXPECT_NE(error_of(text + "/Metadata/plate_1.gcode").find("is not a zip archive"), std::string::npos);
}

}  // namespace
}  // namespace amctl::formats

namespace amctl::formats {
namespace {

TEST_F(Input, DirectoriesExpandToTheirGcodeFilesSorted) {
  write("b.gcode", "G1 X1\n");
  write("a.BGCODE", "GCDE");
  write("c.gcode.3mf", "PK\x03\x04");
  write("notes.txt", "x");
  const std::vector<std::string> got = expand_gcode_inputs({dir_.string(), "-", "missing.gcode"});
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(got[0], (dir_ / "a.BGCODE").string());
  EXPECT_EQ(got[1], (dir_ / "b.gcode").string());
  EXPECT_EQ(got[2], (dir_ / "c.gcode.3mf").string());  // not a real zip: the error comes on reading
  EXPECT_EQ(got[3], "-");
  EXPECT_EQ(got[4], "missing.gcode");
  fs::create_directories(dir_ / "empty");
  EXPECT_THROW(expand_gcode_inputs({(dir_ / "empty").string()}), Error);
}

}  // namespace
}  // namespace amctl::formats

namespace amctl::formats {
namespace {

TEST_F(Input, DecodersWrapAStreamTheyDoNotOwn) {
  // The shape a reader with its own byte source uses: recognise the first bytes, then wrap.
  const std::string text = "G28\nG1 X10 F600\n";
  std::string gz(128, '\0');
  uLongf len = 0;
  {
    z_stream zs{};
    ASSERT_EQ(deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
    zs.avail_in = static_cast<uInt>(text.size());
    zs.next_out = reinterpret_cast<Bytef*>(gz.data());
    zs.avail_out = static_cast<uInt>(gz.size());
    ASSERT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
    len = zs.total_out;
    deflateEnd(&zs);
  }
  gz.resize(len);
  ASSERT_TRUE(is_gzip(gz));
  MemorySource raw(gz);
  auto decoded = decode_gzip(raw, "a.gz");
  EXPECT_EQ(read_all(*decoded), text);
}

}  // namespace
}  // namespace amctl::formats
