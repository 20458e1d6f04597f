// STL reading/writing and mesh checks on a unit cube built by hand (12 triangles, outward
// normals): volume 1, 8 vertices, 18 edges, every edge shared by exactly two triangles.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/stl.hpp"

namespace pr = amctl::process;

namespace {

pr::Mesh cube(double s) {
  const pr::Vec3 p[8] = {{0, 0, 0}, {s, 0, 0}, {s, s, 0}, {0, s, 0},
                         {0, 0, s}, {s, 0, s}, {s, s, s}, {0, s, s}};
  const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                        {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
  pr::Mesh m;
  m.name = "cube";
  for (const auto& t : f) m.triangles.push_back({{}, {p[t[0]], p[t[1]], p[t[2]]}});
  return m;
}

}  // namespace

TEST(Stl, CubeIsAClosedManifoldWithItsVolume) {
  const auto c = pr::check_mesh(cube(2.0));
  EXPECT_TRUE(c.ok()) << c.first_problem;
  EXPECT_EQ(c.vertices, 8u);
  EXPECT_EQ(c.edges, 18u);
  EXPECT_NEAR(c.volume_mm3, 8.0, 1e-12);
}

TEST(Stl, BinaryAndAsciiRoundTripKeepsTheGeometry) {
  const auto m = cube(3.0);
  for (auto fmt : {pr::StlFormat::binary, pr::StlFormat::ascii}) {
    const std::string bytes = pr::serialize_stl(m, fmt);
    if (fmt == pr::StlFormat::binary) EXPECT_EQ(bytes.size(), 84u + 50u * 12u);
    const auto back = pr::parse_stl(bytes, "mem.stl");
    EXPECT_EQ(back.format, fmt);
    ASSERT_EQ(back.triangles.size(), 12u);
    EXPECT_NEAR(pr::check_mesh(back).volume_mm3, 27.0, 1e-9);
    // Recomputed normal of the first (bottom) triangle points down.
    EXPECT_NEAR(back.triangles[0].normal[2], -1.0, 1e-6);
  }
}

TEST(Stl, AsciiOutputOfABinaryHeaderWithLineBreaksReadsBack) {
  // Found by fuzz_stl: a binary header is 80 free bytes. Written after "solid" as it was,
  // its line break put "outer loop" on a line of its own and the ASCII file was refused.
  pr::Mesh m = cube(1.0);
  m.name = std::string("part\nouter loop\r\x01 v2", 20);
  const std::string ascii = pr::serialize_stl(m, pr::StlFormat::ascii);
  EXPECT_EQ(ascii.substr(0, ascii.find('\n')), "solid part outer loop   v2");
  const pr::Mesh back = pr::parse_stl(ascii, "back.stl");
  ASSERT_EQ(back.triangles.size(), m.triangles.size());
  for (std::size_t i = 0; i < m.triangles.size(); ++i) {
    EXPECT_EQ(back.triangles[i].v, m.triangles[i].v) << i;  // small integers: exact in %.9g
  }
  EXPECT_EQ(back.name, "part outer loop   v2");
}

TEST(Stl, HugeCoordinatesWriteAFiniteNormalAndReadBack) {
  // Found by fuzz_stl: an ASCII STL may hold 1e301 and 7.8e38; the facet normal's cross product
  // overflowed to NaN, amctl wrote "facet normal nan ..." and refused its own file.
  const std::string text =
      "solid big\n facet normal 0 0 -1\n  outer loop\n   vertex 0 0 0\n   vertex 10 0 1e301\n"
      "   vertex 7.8e38 0 10\n  endloop\n endfacet\nendsolid big\n";
  const pr::Mesh m = pr::parse_stl(text, "big.stl");
  const std::string ascii = pr::serialize_stl(m, pr::StlFormat::ascii);
  EXPECT_EQ(ascii.find("nan"), std::string::npos) << ascii;
  EXPECT_EQ(ascii.find("inf"), std::string::npos) << ascii;
  const pr::Mesh back = pr::parse_stl(ascii, "back.stl");
  ASSERT_EQ(back.triangles.size(), 1u);
  EXPECT_EQ(back.triangles[0].v, m.triangles[0].v);
  // The normal: (10, 0, 1e301) x (7.8e38, 0, 10) = (0, 1e301 * 7.8e38 - 100, 0), along +y.
  EXPECT_NE(ascii.find("facet normal 0 1 0"), std::string::npos) << ascii;
}

TEST(Stl, ScalingAboutAnOriginMultipliesExtentsAndVolume) {
  pr::ScaleMap map;
  map.axes = pr::parse_factor_spec("x=1.01,y=1.02,z=0.99");
  map.origin_mm = {1.0, 1.0, 0.0};
  const auto s = pr::scale_mesh(cube(2.0), map);
  EXPECT_NEAR(s.min_corner()[0], 1.0 - 1.01, 1e-12);
  EXPECT_NEAR(s.max_corner()[1], 1.0 + 1.02, 1e-12);
  EXPECT_NEAR(s.max_corner()[2], 2 * 0.99, 1e-12);
  EXPECT_NEAR(pr::check_mesh(s).volume_mm3, 8.0 * 1.01 * 1.02 * 0.99, 1e-9);
}

TEST(Stl, OpenNonManifoldAndFlippedMeshesAreReported) {
  auto open = cube(1.0);
  open.triangles.pop_back();
  auto c = pr::check_mesh(open);
  EXPECT_EQ(c.boundary_edges, 3u);
  EXPECT_THROW(pr::require_closed_manifold(open, "open.stl"), amctl::Error);

  auto flipped = cube(1.0);
  std::swap(flipped.triangles[0].v[1], flipped.triangles[0].v[2]);
  c = pr::check_mesh(flipped);
  EXPECT_EQ(c.misoriented_edges, 3u);

  auto extra = cube(1.0);
  extra.triangles.push_back(extra.triangles[0]);  // a third triangle on three edges
  c = pr::check_mesh(extra);
  EXPECT_EQ(c.nonmanifold_edges, 3u);

  auto flat = cube(1.0);
  flat.triangles[0].v[2] = flat.triangles[0].v[0];
  EXPECT_GE(pr::check_mesh(flat).degenerate_triangles, 1u);
}

TEST(Stl, TruncatedOrForeignFilesGiveClearErrors) {
  const std::string ascii = pr::serialize_stl(cube(1.0), pr::StlFormat::ascii);
  try {
    (void)pr::parse_stl(ascii.substr(0, 100), "cut.stl");
    FAIL();
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.stl:"), std::string::npos) << e.what();
  }
  const std::string bin = pr::serialize_stl(cube(1.0), pr::StlFormat::binary);
  EXPECT_THROW((void)pr::parse_stl(bin.substr(0, bin.size() - 7), "cut.stl"), amctl::Error);
  EXPECT_THROW((void)pr::parse_stl("hello", "x.stl"), amctl::Error);
}

TEST(AtomicWrite, ReplacesTheTargetAndLeavesNoTemporary) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "amctl_process_atomic_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string target = (dir / "out.txt").string();
  pr::write_file_atomic(target, "first");
  pr::write_file_atomic(target, "second");
  EXPECT_EQ(pr::read_file_bytes(target), "second");
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) (void)e, ++n;
  EXPECT_EQ(n, 1u);
  // A directory that does not exist: error, nothing created.
  EXPECT_THROW(pr::write_file_atomic((dir / "no" / "x.txt").string(), "x"), amctl::Error);
  fs::remove_all(dir);
}
