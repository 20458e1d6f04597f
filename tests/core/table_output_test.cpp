// The .npy table writer (core/table_output.hpp), checked byte by byte against the layout
// numpy's format document (NEP 1) states, decoded here by hand; python/tests/test_outputs.py
// reads the same kind of file with numpy itself.
#include "amctl/core/table_output.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl {
namespace {

namespace fs = std::filesystem;

std::string read_all(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

class NpyTableTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("amctl_npy_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

TEST(TableFormat, ChosenByTheExtension) {
  EXPECT_EQ(table_format_for("steps.npy"), TableFormat::npy);
  EXPECT_EQ(table_format_for("/tmp/a.b/STEPS.NPY"), TableFormat::npy);
  EXPECT_EQ(table_format_for("steps.csv"), TableFormat::csv);
  EXPECT_EQ(table_format_for("-"), TableFormat::csv);
  EXPECT_EQ(table_format_for("npy"), TableFormat::csv);
  EXPECT_EQ(table_format_for("steps.npy.gz"), TableFormat::csv);
}

TEST(NpyHeader, LayoutOfTheFormatDocument) {
  const std::vector<NpyColumn> cols{{"stepper", NpyType::text, 3}, {"time_s", NpyType::f8, 0},
                                    {"direction", NpyType::i1, 0}};
  const std::string h = npy_header(cols, 42);
  ASSERT_GE(h.size(), 10u);
  EXPECT_EQ(h.substr(0, 6), "\x93NUMPY");
  EXPECT_EQ(h[6], '\x01');
  EXPECT_EQ(h[7], '\x00');
  const std::size_t len = static_cast<unsigned char>(h[8]) + 256u * static_cast<unsigned char>(h[9]);
  EXPECT_EQ(len + 10, h.size());
  EXPECT_EQ(h.size() % 64, 0u);
  EXPECT_EQ(h.back(), '\n');
  const std::string dict = h.substr(10);
  EXPECT_EQ(dict.rfind("{'descr': [('stepper', '|S3'), ('time_s', '<f8'), ('direction', '|i1')], "
                       "'fortran_order': False, 'shape': (42,), }",
                       0),
            0u);
  // Everything after the dict is padding.
  const std::size_t end = dict.find('}') + 1;
  for (std::size_t i = end; i + 1 < dict.size(); ++i) EXPECT_EQ(dict[i], ' ');
}

TEST(NpyHeader, FixedRoomHoldsEveryRowCount) {
  const std::vector<NpyColumn> cols{{"t_s", NpyType::f8, 0}};
  const std::size_t room = npy_header(cols, UINT64_MAX).size();
  EXPECT_EQ(npy_header(cols, 0, room).size(), room);
  EXPECT_EQ(npy_header(cols, 123456789, room).size(), room);
}

TEST_F(NpyTableTest, RecordsArePackedLittleEndianAfterTheHeader) {
  const std::string p = path("t.npy");
  {
    NpyTable t(p, {{"name", NpyType::text, 4}, {"x", NpyType::f8, 0}, {"n", NpyType::i4, 0},
                   {"d", NpyType::i1, 0}, {"k", NpyType::u8, 0}});
    EXPECT_EQ(t.record_bytes(), 4u + 8u + 4u + 1u + 8u);
    NpyRecord r(t);
    r.set_text(0, "ab").set(1, 1.5).set_int(2, -7).set_int(3, -1).set_int(4, 1ll << 40);
    t.append(r.bytes());
    r.set_text(0, "abcd").set(1, -0.25).set_int(2, 70000).set_int(3, 1).set_int(4, 3);
    t.append(r.bytes());
    t.commit();
  }
  const std::string b = read_all(p);
  const std::size_t len = static_cast<unsigned char>(b[8]) + 256u * static_cast<unsigned char>(b[9]);
  const std::size_t data = 10 + len;
  EXPECT_EQ(data % 64, 0u);
  EXPECT_NE(b.find("'shape': (2,)"), std::string::npos);
  ASSERT_EQ(b.size(), data + 2 * 25);
  // Row 0, decoded by hand.
  EXPECT_EQ(b.substr(data, 4), std::string("ab\0\0", 4));
  const unsigned char one_and_half[8] = {0, 0, 0, 0, 0, 0, 0xf8, 0x3f};  // 1.5 as IEEE 754
  EXPECT_EQ(std::memcmp(b.data() + data + 4, one_and_half, 8), 0);
  const unsigned char minus_seven[4] = {0xf9, 0xff, 0xff, 0xff};
  EXPECT_EQ(std::memcmp(b.data() + data + 12, minus_seven, 4), 0);
  EXPECT_EQ(static_cast<unsigned char>(b[data + 16]), 0xffu);
  const unsigned char two_pow_40[8] = {0, 0, 0, 0, 0, 1, 0, 0};
  EXPECT_EQ(std::memcmp(b.data() + data + 17, two_pow_40, 8), 0);
  // Row 1's text fills its width; 70000 = 0x11170.
  EXPECT_EQ(b.substr(data + 25, 4), "abcd");
  const unsigned char seventy_k[4] = {0x70, 0x11, 0x01, 0x00};
  EXPECT_EQ(std::memcmp(b.data() + data + 25 + 12, seventy_k, 4), 0);
}

TEST_F(NpyTableTest, AnEmptyTableIsAValidFileWithShapeZero) {
  const std::string p = path("e.npy");
  NpyTable t(p, {{"t_s", NpyType::f8, 0}});
  t.commit();
  const std::string b = read_all(p);
  EXPECT_EQ(b.size() % 64, 0u);
  EXPECT_NE(b.find("'shape': (0,)"), std::string::npos);
}

TEST_F(NpyTableTest, WithoutCommitNothingIsLeft) {
  const std::string p = path("gone.npy");
  {
    NpyTable t(p, {{"t_s", NpyType::f8, 0}});
    NpyRecord r(t);
    t.append(r.set(0, 1.0).bytes());
  }
  EXPECT_FALSE(fs::exists(p));
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(NpyTableTest, APipeOrADeviceIsRefusedBeforeWriting) {
  const std::string fifo = path("f.npy");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // A FIFO would block at open without a reader: a reader end opened non-blocking first.
  const int rd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(rd, 0);
  try {
    NpyTable t(fifo, {{"t_s", NpyType::f8, 0}}, OutputOptions{"--csv", {}, {}});
    FAIL() << "a FIFO was accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("f.npy"), std::string::npos) << what;
    EXPECT_NE(what.find("--csv"), std::string::npos) << what;
    EXPECT_NE(what.find("expected a regular file"), std::string::npos) << what;
  }
  ::close(rd);
}

TEST_F(NpyTableTest, ValuesThatDoNotFitTheirColumnAreCaught) {
  NpyTable t(path("v.npy"), {{"s", NpyType::text, 2}, {"d", NpyType::i1, 0}});
  NpyRecord r(t);
  EXPECT_THROW(r.set_text(0, "abc"), InternalError);
  EXPECT_THROW(r.set_int(1, 128), InternalError);
  EXPECT_THROW(r.set(1, 1.0), InternalError);
  EXPECT_THROW(t.append("x"), InternalError);
}

}  // namespace
}  // namespace amctl
