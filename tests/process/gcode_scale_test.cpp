// G-code scaling: expected coordinates are computed by hand from the map definitions.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include "amctl/core/error.hpp"
#include "amctl/process/gcode_scale.hpp"

namespace pr = amctl::process;
namespace fs = std::filesystem;

namespace {
pr::ScaleMap make_map(const char* spec, std::array<double, 3> origin) {
  pr::ScaleMap m;
  m.axes = pr::parse_factor_spec(spec);
  m.origin_mm = origin;
  return m;
}

// A directory of its own per test and process, removed when the test is done with it (the
// tests used to leave one /tmp/amctl_gcode_scale_* directory behind per test and run).
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() / (std::string("amctl_gcode_scale_") + info->name() + "_" +
                                         std::to_string(::getpid()));
    fs::create_directories(path_);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string read_all(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Writes `in` to a file, scales it into another and returns the output text.
std::string scale_text(const std::string& in, const pr::ScaleMap& map,
                       pr::GcodeScaleReport* report = nullptr, pr::GcodeScaleOptions opt = {}) {
  const ScratchDir scratch;
  const fs::path& dir = scratch.path();
  std::ofstream(dir / "t.gcode", std::ios::binary) << in;
  const auto rep = pr::scale_gcode_file((dir / "t.gcode").string(), (dir / "o.gcode").string(),
                                        map, opt);
  if (report) *report = rep;
  return read_all(dir / "o.gcode");
}
}  // namespace

TEST(GcodeScale, AbsoluteMovesAreMappedAboutTheOrigin) {
  const std::string in =
      "G90\nM82\nG92 E0\nG1 Z0.2 F600 ; layer\nG1 X10 Y0 E1.5\nG1 X10 Y10 E3.0\nG0 Z12\n"
      "G1 X0 Y10 E4.5 ;edge\n";
  // X/Y: 1.01 about (5, 5); Z: 0.99 up to 10 mm, then 1.02.
  const auto map = make_map("xy=1.01,z=0.99:10:1.02", {5, 5, 0});
  pr::GcodeScaleReport rep;
  const std::string out = scale_text(in, map, &rep);
  // X10 -> 5 + 1.01 * 5 = 10.05; Y0 -> 5 - 5.05 = -0.05. First extrusion: length ratio 1.01
  // (uniform XY), local Z factor 0.99 -> 1.5 * 0.9999 = 1.49985. Second: the same again.
  // Z12 -> 0.99 * 10 + 1.02 * 2 = 11.94. Last move at Z = 12 (factor 1.02):
  // 1.5 * 1.01 * 1.02 = 1.5453 added to 2 * 1.49985 = 4.5450.
  EXPECT_EQ(out,
            "G90\nM82\nG92 E0\nG1 Z0.198 F600 ; layer\nG1 X10.05 Y-0.05 E1.49985\n"
            "G1 X10.05 Y10.05 E2.9997\nG0 Z11.94\nG1 X-0.05 Y10.05 E4.545 ;edge\n");
  EXPECT_EQ(rep.layers, 2u);
  EXPECT_EQ(rep.lines, 8u);
  EXPECT_EQ(rep.moves_rewritten, 5u);
  EXPECT_NEAR(rep.extruded_mm, 4.5, 1e-12);
  EXPECT_NEAR(rep.scaled_extruded_mm, 2 * 1.49985 + 1.5453, 1e-9);
}

TEST(GcodeScale, RelativeModesScaleDeltas) {
  const std::string in = "G91\nM83\nG1 X10 E1\nG1 Z5\nG1 Z5\nG1 E-0.8\n";
  const auto map = make_map("x=2,z=1:5:2", {0, 0, 0});
  // Z deltas: 0..5 maps to 0..5, 5..10 maps to 5..15, so the second +5 becomes +10. The
  // retraction does not extrude and keeps its text.
  EXPECT_EQ(scale_text(in, map), "G91\nM83\nG1 X20 E2\nG1 Z5\nG1 Z10\nG1 E-0.8\n");
}

TEST(GcodeScale, G91MakesERelativeLikeTheInterpreter) {
  // M82 is in force, but under G91 E is relative too (Klipper's and the interpreter's rule):
  // E2 is an amount, doubled with the path.
  const auto map = make_map("xy=2", {0, 0, 0});
  EXPECT_EQ(scale_text("M82\nG91\nG1 X5 E2\nG1 X5 E2\n", map),
            "M82\nG91\nG1 X10 E4\nG1 X10 E4\n");
}

TEST(GcodeScale, ArcCentresAreMapped) {
  const std::string in = "G90\nM83\nG1 X10 Y0\nG2 X0 Y-10 I-10 J0 E1\n";
  const auto map = make_map("xy=1.5", {0, 0, 0});
  pr::GcodeScaleReport rep;
  EXPECT_EQ(scale_text(in, map, &rep), "G90\nM83\nG1 X15 Y0\nG2 X0 Y-15 I-15 J0 E1.5\n");
  EXPECT_EQ(rep.arcs, 1u);
  EXPECT_NEAR(rep.max_arc_radius_mismatch_mm, 0.0, 1e-12);
  const auto aniso = make_map("x=1.5,y=1", {0, 0, 0});
  (void)scale_text(in, aniso, &rep);
  EXPECT_NEAR(rep.max_arc_radius_mismatch_mm, 5.0, 1e-12);  // start radius 15, end 10
  try {
    (void)scale_text("G90\nG1 X1 Y0\nG2 X0 Y1 R1\n", aniso);
    FAIL() << "an R arc under an anisotropic map must be refused";
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("t.gcode:3:10"), std::string::npos) << e.what();
  }
  // Under a uniform map R scales with the factor.
  EXPECT_EQ(scale_text("G90\nG1 X1 Y0\nG2 X0 Y1 R1\n", map), "G90\nG1 X1.5 Y0\nG2 X0 Y1.5 R1.5\n");
}

TEST(GcodeScale, LayersKeepOneZAndTheirOrder) {
  std::string in = "G90\nM83\n";
  for (int k = 1; k <= 80; ++k) {
    const double z = 0.25 * k;
    in += "G1 Z" + std::to_string(z) + "\nG1 X1 Y0 E0.1\nG1 X0 Y1 E0.1\n";
  }
  const auto map = make_map("z=0.9902:10:1.0032", {0, 0, 0});
  const std::string out = scale_text(in, map);
  double prev = -1;
  std::size_t pos = 0;
  int layers = 0;
  while ((pos = out.find("G1 Z", pos)) != std::string::npos) {
    const double z = std::stod(out.substr(pos + 4));
    EXPECT_GT(z, prev);
    prev = z;
    ++layers;
    ++pos;
  }
  EXPECT_EQ(layers, 80);
  EXPECT_NEAR(prev, 0.9902 * 10 + 1.0032 * 10, 1e-4);
}

TEST(GcodeScale, InchUnitsAreScaledInInches) {
  // G20: X1 is 25.4 mm. About X = 12.7 mm with factor 1.1: 12.7 + 1.1 * 12.7 = 26.67 mm,
  // written back in inches: 1.05. The E amount follows the path: 0.1 * 1.1 = 0.11.
  const auto map = make_map("x=1.1", {12.7, 0, 0});
  EXPECT_EQ(scale_text("G21\nG20\nM83\nG1 X1 E0.1\nG21\nG1 X25.4 Y0\n", map),
            "G21\nG20\nM83\nG1 X1.05 E0.11\nG21\nG1 X26.67 Y0\n");
}

TEST(GcodeScale, G92OffsetsAndHomingKeepTheMachinePositionRight) {
  // G92 X100 at machine X0: file X110 is machine X10, which maps to 20 (x2 about 0), file
  // X120 in the output. After G28 both files are at machine 0 again.
  const auto map = make_map("x=2", {0, 0, 0});
  EXPECT_EQ(scale_text("G92 X100\nG1 X110\nG28 X\nG1 X10\n", map),
            "G92 X100\nG1 X120\nG28 X\nG1 X20\n");
}

TEST(GcodeScale, UntouchedLinesAreCopiedByteForByte) {
  // CR LF ends, comments, commands with bare letters the interpreter accepts (M84 X Y E,
  // G28 X Y), a Klipper macro, text in M117, no newline at the end.
  const std::string in =
      "; header ; with X10 in a comment\r\nM84 X Y E\r\nG28 X Y\nM117 Hello X world\n"
      "SET_VELOCITY_LIMIT ACCEL=3000\nG1 F1800\n  G1   X10  Y10 (c) F600 ; keep spacing\r\n"
      "M107";
  const auto map = make_map("xy=2", {0, 0, 0});
  pr::GcodeScaleReport rep;
  EXPECT_EQ(scale_text(in, map, &rep),
            "; header ; with X10 in a comment\r\nM84 X Y E\r\nG28 X Y\nM117 Hello X world\n"
            "SET_VELOCITY_LIMIT ACCEL=3000\nG1 F1800\n  G1   X20  Y20 (c) F600 ; keep spacing\r\n"
            "M107");
  EXPECT_EQ(rep.lines, 8u);
  EXPECT_EQ(rep.moves_rewritten, 1u);
}

TEST(GcodeScale, ChecksumsAreRecomputedForRewrittenLines) {
  auto with_checksum = [](std::string body) {
    unsigned char x = 0;
    for (char c : body) x ^= static_cast<unsigned char>(c);
    return body + "*" + std::to_string(int{x});
  };
  const auto map = make_map("x=2", {0, 0, 0});
  EXPECT_EQ(scale_text(with_checksum("N7 G1 X3") + "\n", map), with_checksum("N7 G1 X6") + "\n");
}

TEST(GcodeScale, MalformedLinesNameFileLineAndColumnAndWriteNothing) {
  const ScratchDir scratch;
  const fs::path& dir = scratch.path();
  std::ofstream(dir / "bad.gcode") << "G1 X10\nG1 X10 E\n";
  const auto map = make_map("x=2", {0, 0, 0});
  try {
    (void)pr::scale_gcode_file((dir / "bad.gcode").string(), (dir / "o.gcode").string(), map, {});
    FAIL() << "a bare E in a move must be an error";
  } catch (const amctl::Error& e) {
    EXPECT_EQ(e.where().line, 2u) << e.what();
    EXPECT_EQ(e.where().column, 9u) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.gcode:2:9"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "o.gcode"));
  for (const auto& f : fs::directory_iterator(dir)) {
    EXPECT_EQ(f.path().filename().string().find(".tmp"), std::string::npos) << f.path();
  }
}

TEST(GcodeScale, IdentityMapReproducesARealSlicerFile) {
  // PrusaSlicer/Klipper output (M107 ... M84 X Y E, G4 P..., arcs of none): with factors 1
  // every number keeps its value, so every byte must stay.
  const std::string src =
      std::string(AMCTL_SOURCE_DIR) + "/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode";
  const ScratchDir scratch;
  const fs::path& dir = scratch.path();
  pr::ScaleMap identity;
  const auto rep = pr::scale_gcode_file(src, (dir / "o.gcode").string(), identity, {});
  EXPECT_EQ(read_all(dir / "o.gcode"), read_all(src));
  EXPECT_EQ(rep.moves_rewritten, 0u);
  EXPECT_GT(rep.layers, 10u);
  const auto ex = pr::gcode_extrusion_extent(src);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(ex.min_mm[a], rep.extrusion_min_mm[a]);
    EXPECT_EQ(ex.max_mm[a], rep.extrusion_max_mm[a]);
  }
}
