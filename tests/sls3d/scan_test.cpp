// The ring's hatch path (amctl/sls3d/scan.hpp) against hand calculations.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "amctl/sls3d/scan.hpp"

namespace amctl::sls3d {
namespace {

TEST(Sls3dScan, RingScanLengthIsTheAreaOverTheHatch) {
  // pi (55^2 - 50^2) mm^2 / 0.3 mm = 5497.8 mm; the chords at (j + 1/2) h midpoints are a
  // midpoint rule for the area, exact up to the edges.
  const ScanPath p = hatch_ring(0.05, 0.055, HatchSettings{3e-4, 5.0, 0.0});
  const double area = std::numbers::pi * (0.055 * 0.055 - 0.05 * 0.05);
  EXPECT_NEAR(p.length_m(), area / 3e-4, 1e-3 * area / 3e-4);
  // The paper's 14 s -> 15.1 s: 1.1 s of exposure at 5 m/s.
  EXPECT_NEAR(p.duration_s(), 1.0996, 2e-3);
}

TEST(Sls3dScan, PassesSplitTheVectorsAtTheStepBoundaries) {
  const ScanPath p = hatch_rectangle(0, 0, 1e-3, 1e-3, HatchSettings{2.5e-4, 1.0, 0.0});
  ASSERT_EQ(p.vectors().size(), 4u);
  // Four vectors of 1 mm at 1 m/s: 4 ms; serpentine: the second goes back.
  EXPECT_NEAR(p.duration_s(), 4e-3, 1e-15);
  EXPECT_LT(p.vectors()[1].x1_m, p.vectors()[1].x0_m);
  const auto passes = p.passes(0.5e-3, 1.5e-3, 10.0, 2.0);
  ASSERT_EQ(passes.size(), 2u);
  EXPECT_NEAR(passes[0].x0_m, 0.5e-3, 1e-15);
  EXPECT_NEAR(passes[0].x1_m, 1e-3, 1e-15);
  EXPECT_NEAR(passes[1].x0_m, 1e-3, 1e-15);
  EXPECT_NEAR(passes[1].x1_m, 0.5e-3, 1e-15);
  EXPECT_NEAR(passes[1].t1_s, 10.0015, 1e-12);
  double energy = 0;
  for (const auto& q : passes) energy += q.power_w * (q.t1_s - q.t0_s);
  EXPECT_NEAR(energy, 2.0 * 1e-3, 1e-12);
}

TEST(Sls3dScan, RotatedRingHasTheSameDuration) {
  const ScanPath a = hatch_ring(0.05, 0.055, HatchSettings{3e-4, 5.0, 0.0});
  const ScanPath b = hatch_ring(0.05, 0.055, HatchSettings{3e-4, 5.0, std::numbers::pi / 2});
  EXPECT_NEAR(a.duration_s(), b.duration_s(), 1e-12);
  // Turned by 90 degrees: the first vector runs along y.
  EXPECT_NEAR(b.vectors().front().x0_m, b.vectors().front().x1_m, 1e-12);
}

}  // namespace
}  // namespace amctl::sls3d
