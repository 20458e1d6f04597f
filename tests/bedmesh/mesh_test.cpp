// The mesh's interpolation against closed forms and a second formulation (docs/bedmesh.md
// sections 1-2): a Lagrange grid reproduces any polynomial of degree below its point count
// exactly at every fine node (so a planar mesh is an exact plane, and the probes are met
// exactly); the cardinal spline is checked against its matrix form, evaluated independently;
// the lookup is bilinear, exact for z = a + b x + c y + d x y between fine nodes.
#include <cmath>
#include <functional>

#include <gtest/gtest.h>

#include "amctl/bedmesh/config.hpp"
#include "amctl/bedmesh/mesh.hpp"

namespace amctl::bedmesh {
namespace {

Profile grid(int nx, int ny, int pps, Algorithm algo, const std::function<double(double, double)>& f,
             double tension = 0.2) {
  Profile p;
  p.name = "t";
  p.params = {10.0, 210.0, -20.0, 130.0, nx, ny, pps, pps, algo, tension};
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double x = 10.0 + 200.0 * i / (nx - 1), y = -20.0 + 150.0 * j / (ny - 1);
      p.points_mm.push_back(f(x, y));
    }
  }
  return p;
}

double fine_x(const ZMesh& m, int i) { return 10.0 + 200.0 * i / (m.fine_x_count() - 1); }
double fine_y(const ZMesh& m, int j) { return -20.0 + 150.0 * j / (m.fine_y_count() - 1); }

TEST(BedMeshInterpolation, LagrangeReproducesPolynomialsBelowItsDegreeAtEveryFineNode) {
  // 5 points per axis: degree <= 4 in each variable is reproduced exactly.
  auto f = [](double x, double y) { return 1e-9 * x * x * x * y - 2e-6 * y * y + 3e-4 * x - 0.05; };
  const ZMesh m(grid(5, 5, 3, Algorithm::lagrange, f));
  ASSERT_EQ(m.fine_x_count(), 17);
  ASSERT_EQ(m.fine_y_count(), 17);
  for (int j = 0; j < m.fine_y_count(); ++j) {
    for (int i = 0; i < m.fine_x_count(); ++i) {
      const double x = fine_x(m, i), y = fine_y(m, j);
      EXPECT_NEAR(m.z_at(x, y), f(x, y), 1e-12) << x << ", " << y;
    }
  }
}

TEST(BedMeshInterpolation, PlanarMeshIsAnExactPlaneEverywhere) {
  auto plane = [](double x, double y) { return 0.1 + 4e-4 * x - 7e-4 * y; };
  for (Algorithm a : {Algorithm::lagrange, Algorithm::direct}) {
    const ZMesh m(grid(4, 6, a == Algorithm::direct ? 0 : 2, a, plane));
    for (double x = 10.0; x <= 210.0; x += 3.7) {
      for (double y = -20.0; y <= 130.0; y += 4.1) EXPECT_NEAR(m.z_at(x, y), plane(x, y), 1e-12);
    }
  }
}

TEST(BedMeshInterpolation, EveryAlgorithmMeetsTheProbesExactly) {
  auto f = [](double x, double y) { return std::sin(x / 37.0) * std::cos(y / 23.0) * 0.2; };
  for (Algorithm a : {Algorithm::lagrange, Algorithm::bicubic}) {
    const Profile p = grid(6, 5, 3, a, f);
    const ZMesh m(p);
    for (int j = 0; j < 5; ++j) {
      for (int i = 0; i < 6; ++i) {
        EXPECT_EQ(m.z_at(10.0 + 200.0 * i / 5, -20.0 + 150.0 * j / 4), p.points_mm[j * 6 + i]);
      }
    }
  }
}

/// The cardinal spline in matrix form: [t^3 t^2 t 1] M [p0 p1 p2 p3]^T with M from the
/// Hermite basis and tangents s (p2 - p0), s (p3 - p1).
double cardinal_matrix(double p0, double p1, double p2, double p3, double t, double s) {
  const double M[4][4] = {{-s, 2 - s, s - 2, s}, {2 * s, s - 3, 3 - 2 * s, -s}, {-s, 0, s, 0}, {0, 1, 0, 0}};
  const double T[4] = {t * t * t, t * t, t, 1.0};
  const double P[4] = {p0, p1, p2, p3};
  double v = 0.0;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) v += T[r] * M[r][c] * P[c];
  }
  return v;
}

TEST(BedMeshInterpolation, BicubicRowsFollowTheCardinalSplineWithRepeatedEnds) {
  // One row of probes (y_count 3, the rows all equal): the fine values along x are the spline
  // between neighbours, the first and last segments with the end probe repeated.
  const double z[5] = {0.05, -0.02, 0.04, 0.11, -0.03};
  Profile p;
  p.name = "row";
  p.params = {0.0, 100.0, 0.0, 50.0, 5, 3, 2, 0, Algorithm::bicubic, 0.35};
  for (int j = 0; j < 3; ++j) p.points_mm.insert(p.points_mm.end(), z, z + 5);
  const ZMesh m(p);
  ASSERT_EQ(m.fine_x_count(), 13);
  for (int seg = 0; seg < 4; ++seg) {
    const double p0 = z[std::max(seg - 1, 0)], p1 = z[seg], p2 = z[seg + 1], p3 = z[std::min(seg + 2, 4)];
    for (int k = 1; k <= 2; ++k) {
      const double want = cardinal_matrix(p0, p1, p2, p3, k / 3.0, 0.35);
      const double x = 100.0 * (3 * seg + k) / 12.0;
      EXPECT_NEAR(m.z_at(x, 0.0), want, 1e-15);
      EXPECT_NEAR(m.z_at(x, 50.0), want, 1e-15);
    }
  }
}

TEST(BedMeshInterpolation, LookupIsBilinearBetweenFineNodesAndClampedOutside) {
  auto f = [](double x, double y) { return 0.02 + 1e-4 * x - 2e-4 * y + 3e-6 * x * y; };
  const ZMesh m(grid(3, 3, 0, Algorithm::direct, f));
  EXPECT_NEAR(m.z_at(47.3, 12.9), f(47.3, 12.9), 1e-15);
  EXPECT_NEAR(m.z_at(-100.0, 12.9), f(10.0, 12.9), 1e-15);   // left of the mesh: its edge
  EXPECT_NEAR(m.z_at(500.0, 500.0), f(210.0, 130.0), 1e-15);  // beyond a corner: the corner
  const auto [lo, hi] = m.z_range();
  EXPECT_NEAR(lo, std::min({f(10, -20), f(210, -20), f(10, 130), f(210, 130)}), 1e-15);
  EXPECT_NEAR(hi, std::max({f(10, -20), f(210, -20), f(10, 130), f(210, 130)}), 1e-15);
}

}  // namespace
}  // namespace amctl::bedmesh
