// G-code scaling: expected coordinates are computed by hand from the map definitions.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/process/gcode_scale.hpp"
#include "amctl/process/gcode_text.hpp"

namespace pr = amctl::process;

namespace {
pr::ScaleMap make_map(const char* spec, std::array<double, 3> origin) {
  pr::ScaleMap m;
  m.axes = pr::parse_factor_spec(spec);
  m.origin_mm = origin;
  return m;
}
}  // namespace

TEST(GcodeScale, AbsoluteMovesAreMappedAboutTheOrigin) {
  const std::string in =
      "G90\nM82\nG92 E0\nG1 Z0.2 F600 ; layer\nG1 X10 Y0 E1.5\nG1 X10 Y10 E3.0\nG0 Z12\n"
      "G1 X0 Y10 E4.5 ;edge\n";
  // X/Y: 1.01 about (5, 5); Z: 0.99 up to 10 mm, then 1.02.
  const auto map = make_map("xy=1.01,z=0.99:10:1.02", {5, 5, 0});
  std::string out;
  const auto rep = pr::scale_gcode(in, "t.gcode", map, {}, out);
  EXPECT_NE(out.find("G1 Z0.198 F600 ; layer\n"), std::string::npos) << out;
  // X10 -> 5 + 1.01 * 5 = 10.05; Y0 -> 5 - 5.05 = -0.05.
  EXPECT_NE(out.find("G1 X10.05 Y-0.05"), std::string::npos) << out;
  // Z12 -> 0.99 * 10 + 1.02 * 2 = 11.94.
  EXPECT_NE(out.find("G0 Z11.94\n"), std::string::npos) << out;
  // First extrusion: length ratio 1.01 (uniform XY), local Z factor 0.99 -> 1.5 * 0.9999.
  EXPECT_NE(out.find("E1.49985"), std::string::npos) << out;
  // Last move at Z = 12 (factor 1.02): 1.5 * 1.01 * 1.02 = 1.5453 added to 2 * 1.49985.
  EXPECT_NE(out.find("G1 X-0.05 Y10.05 E4.545 ;edge\n"), std::string::npos) << out;
  EXPECT_EQ(rep.layers, 2u);
  EXPECT_NEAR(rep.scaled_extruded_mm, 2 * 1.49985 + 1.5453, 1e-9);
}

TEST(GcodeScale, RelativeModesScaleDeltas) {
  const std::string in = "G91\nM83\nG1 X10 E1\nG1 Z5\nG1 Z5\nG1 E-0.8\n";
  const auto map = make_map("x=2,z=1:5:3", {0, 0, 0});
  std::string out;
  (void)pr::scale_gcode(in, "t.gcode", map, {}, out);
  // Z deltas: 0..5 maps to 0..5, 5..10 maps to 5..20, so the second +5 becomes +15.
  EXPECT_NE(out.find("G1 X20 E2\nG1 Z5\nG1 Z15\nG1 E-0.8\n"), std::string::npos) << out;
}

TEST(GcodeScale, ArcCentresAreMapped) {
  const std::string in = "G90\nM83\nG1 X10 Y0\nG2 X0 Y-10 I-10 J0 E1\n";
  const auto map = make_map("xy=1.5", {0, 0, 0});
  std::string out;
  const auto rep = pr::scale_gcode(in, "t.gcode", map, {}, out);
  EXPECT_NE(out.find("G2 X0 Y-15 I-15 J0 E1.5"), std::string::npos) << out;
  EXPECT_NEAR(rep.max_arc_radius_mismatch_mm, 0.0, 1e-12);
  const auto aniso = make_map("x=1.5,y=1", {0, 0, 0});
  const auto rep2 = pr::scale_gcode(in, "t.gcode", aniso, {}, out);
  EXPECT_NEAR(rep2.max_arc_radius_mismatch_mm, 5.0, 1e-12);  // start radius 15, end 10
  EXPECT_THROW((void)pr::scale_gcode("G90\nG1 X1 Y0\nG2 X0 Y1 R1\n", "r.gcode", aniso, {}, out),
               amctl::Error);
}

TEST(GcodeScale, LayersKeepOneZAndTheirOrder) {
  std::string in = "G90\nM83\n";
  for (int k = 1; k <= 80; ++k) {
    const double z = 0.25 * k;
    in += "G1 Z" + std::to_string(z) + "\nG1 X1 Y0 E0.1\nG1 X0 Y1 E0.1\n";
  }
  const auto map = make_map("z=0.9902:10:1.0032", {0, 0, 0});
  std::string out;
  (void)pr::scale_gcode(in, "t.gcode", map, {}, out);
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

TEST(GcodeScale, InchUnitsAreRejected) {
  std::string out;
  try {
    (void)pr::scale_gcode("G21\nG20\nG1 X1\n", "in.gcode", make_map("x=1.01", {0, 0, 0}), {}, out);
    FAIL();
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("in.gcode:2"), std::string::npos) << e.what();
  }
}

TEST(GcodeText, WordsCommentsAndChecksumsAreParsed) {
  const auto g = pr::parse_gcode_line("N12 G1 X1.5 Y-2 E.3 F1800*57 ; move", "f", 1);
  ASSERT_EQ(g.words.size(), 5u);
  EXPECT_EQ(g.command(), "G1");
  EXPECT_DOUBLE_EQ(g.find('E')->value, 0.3);
  EXPECT_FALSE(g.has_comment);  // the checksum ends the line
  const auto h = pr::parse_gcode_line("G1 X1E5 ;TYPE:Perimeter", "f", 2);
  EXPECT_DOUBLE_EQ(h.find('X')->value, 1.0);
  EXPECT_DOUBLE_EQ(h.find('E')->value, 5.0);
  EXPECT_EQ(h.comment, "TYPE:Perimeter");
  EXPECT_THROW((void)pr::parse_gcode_line("G1 X1.2.3", "f", 3), amctl::Error);
}
