// Sliced 3MF archives written by Python's zipfile (tests/reference/make_3mf.py, the layout
// OrcaSlicer and Bambu Studio use): each plate reads back byte for byte, estimates to the
// numbers of its G-code, and the zip-bomb limits stop before anything is inflated.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/formats/sliced_3mf.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::formats {
namespace {

namespace fs = std::filesystem;
const fs::path kSource = AMCTL_SOURCE_DIR;
const fs::path kGcode = kSource / "examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode";
const fs::path kOther = kSource / "tests/reference/klipper/syn_square.gcode";

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string read_all(gcode::ByteSource& s, std::size_t step = 65536) {
  std::string out;
  std::string buf(step, '\0');
  for (std::size_t k; (k = s.read(buf.data(), buf.size())) > 0;) out.append(buf.data(), k);
  return out;
}

class Sliced3mf : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(::testing::TempDir()) / ("amctl_3mf_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const std::string py = "/usr/bin/python3 " + (kSource / "tests/reference/make_3mf.py").string() + " ";
    ok_ = std::system((py + (dir_ / "one.gcode.3mf").string() + " " + kGcode.string()).c_str()) == 0 &&
          std::system((py + (dir_ / "two.gcode.3mf").string() + " " + kGcode.string() + " " +
                       kOther.string()).c_str()) == 0 &&
          std::system((py + (dir_ / "model.3mf").string() + " --model").c_str()) == 0 &&
          std::system((py + (dir_ / "bomb.gcode.3mf").string() + " --bomb 20").c_str()) == 0;
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  void SetUp() override { ASSERT_TRUE(ok_) << "tests/reference/make_3mf.py failed"; }
  static inline fs::path dir_;
  static inline bool ok_ = false;
};

TEST_F(Sliced3mf, ListsThePlatesInOrderAndReadsThemBackByteForByte) {
  const ZipArchive z((dir_ / "two.gcode.3mf").string(), "two.gcode.3mf");
  const auto plates = z.gcode_members();
  ASSERT_EQ(plates.size(), 2u);
  EXPECT_EQ(plates[0].name, "Metadata/plate_1.gcode");
  EXPECT_EQ(plates[1].name, "Metadata/plate_2.gcode");
  EXPECT_EQ(plates[0].plate, 1);
  EXPECT_EQ(plates[0].size, fs::file_size(kGcode));
  EXPECT_TRUE(z.has_model());
  auto s1 = z.open_member("Metadata/plate_1.gcode");
  EXPECT_EQ(read_all(*s1, 1000), slurp(kGcode));
  auto s2 = z.open_member("Metadata/plate_2.gcode");
  EXPECT_EQ(read_all(*s2), slurp(kOther));
  EXPECT_EQ(s2->origin(0), "Metadata/plate_2.gcode");
}

TEST_F(Sliced3mf, EstimateOfAPlateIsTheEstimateOfItsGcode) {
  const machine::Machine m = machine::load_machine((kSource / "configs/klipper-voron-v0.cfg").string());
  const plan::EstimateReport text = plan::estimate_file(kGcode.string(), m);
  const plan::EstimateReport one = plan::estimate_file((dir_ / "one.gcode.3mf").string(), m);
  const plan::EstimateReport plate1 =
      plan::estimate_file((dir_ / "two.gcode.3mf/Metadata/plate_1.gcode").string(), m);
  for (const auto* r : {&one, &plate1}) {
    EXPECT_EQ(r->total_time_s, text.total_time_s);
    EXPECT_EQ(r->moves, text.moves);
    EXPECT_EQ(r->filament_mm, text.filament_mm);
    EXPECT_EQ(r->layers.size(), text.layers.size());
    EXPECT_EQ(r->slicer_estimate_s, text.slicer_estimate_s);
    EXPECT_EQ(r->lines, text.lines);
  }
  EXPECT_EQ(one.file, (dir_ / "one.gcode.3mf").string());
  EXPECT_EQ(plate1.file, (dir_ / "two.gcode.3mf/Metadata/plate_1.gcode").string());
}

TEST_F(Sliced3mf, SeveralPlatesAreListedAsPartsAndNeedOneNamed) {
  const auto parts = gcode_parts((dir_ / "two.gcode.3mf").string());
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[1], (dir_ / "two.gcode.3mf/Metadata/plate_2.gcode").string());
  EXPECT_EQ(gcode_parts((dir_ / "one.gcode.3mf").string()).size(), 1u);
  EXPECT_EQ(gcode_parts(kGcode.string()), std::vector<std::string>{kGcode.string()});
  try {
    open_gcode_input((dir_ / "two.gcode.3mf").string());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("found 2 plates with G-code"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("two.gcode.3mf/Metadata/plate_2.gcode"), std::string::npos);
  }
  EXPECT_THROW(open_gcode_input((dir_ / "two.gcode.3mf/Metadata/plate_9.gcode").string()), Error);
}

TEST_F(Sliced3mf, AModelWithoutGcodeIsToBeSlicedFirst) {
  try {
    open_gcode_input((dir_ / "model.3mf").string());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("this is a model, slice it first"), std::string::npos) << e.what();
  }
}

TEST_F(Sliced3mf, ZipBombsStopBeforeInflating) {
  // 20 MiB of zeros stored in ~20 KiB: the ratio limit says no before a byte is inflated.
  try {
    open_gcode_input((dir_ / "bomb.gcode.3mf").string());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("a zip bomb?"), std::string::npos) << e.what();
  }
  // The size limit alone.
  ArchiveLimits small;
  small.max_member_bytes = 1000;
  const ZipArchive z((dir_ / "one.gcode.3mf").string(), "one.gcode.3mf", small);
  EXPECT_THROW(z.open_member("Metadata/plate_1.gcode"), Error);
}

}  // namespace
}  // namespace amctl::formats
