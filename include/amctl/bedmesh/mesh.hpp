#pragma once
// A probed bed mesh as Klipper stores and applies it (docs/bedmesh.md): the probed grid of
// z offsets, upsampled by Lagrange polynomials or cardinal (Catmull-Rom type) splines to a
// finer grid of mesh_x_pps / mesh_y_pps points between probed ones, and the z at a point
// read off that grid by bilinear interpolation.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "amctl/core/error.hpp"

namespace amctl::bedmesh {

/// How the probed grid is upsampled (Klipper's `algo` of a saved profile).
enum class Algorithm : std::uint8_t { lagrange, bicubic, direct };

[[nodiscard]] const char* name(Algorithm a);

/// Largest upsampled mesh amctl builds: points along one axis, and in all (8 bytes each). A
/// profile beyond them is refused where it is read, before anything is allocated.
inline constexpr int kMaxFineCount = 4096;
inline constexpr std::int64_t kMaxFinePoints = std::int64_t{1} << 22;

/// A profile's grid as saved by SAVE_CONFIG (`[bed_mesh NAME]`).
struct MeshParams {
  double min_x_mm = 0.0, max_x_mm = 0.0, min_y_mm = 0.0, max_y_mm = 0.0;
  int x_count = 0, y_count = 0;     ///< probed points along X and Y
  int mesh_x_pps = 0, mesh_y_pps = 0;  ///< points inserted between two probed ones
  Algorithm algo = Algorithm::lagrange;
  double tension = 0.2;             ///< bicubic: tangent scale of the cardinal spline
};

/// One saved profile: its name, grid and probed z [mm], row-major with y outermost
/// (points_mm[j * x_count + i] is the probe at (x_i, y_j)).
struct Profile {
  std::string name;
  MeshParams params;
  std::vector<double> points_mm;
  SourceLocation where;  ///< the [bed_mesh NAME] header
};

/// The upsampled mesh of one profile and its z at any point.
class ZMesh {
 public:
  /// Builds the fine grid. Throws amctl::Error at `profile.where` when the profile cannot be
  /// upsampled (too few points for its algorithm, a grid beyond kMaxFineCount /
  /// kMaxFinePoints, points that do not fill the grid, extents that are not finite and
  /// increasing).
  explicit ZMesh(const Profile& profile);

  /// z offset [mm] at (x, y): bilinear on the fine grid, clamped to the mesh's edges (a point
  /// outside the mesh takes the value of the nearest edge), after the BED_MESH_OFFSET shift.
  [[nodiscard]] double z_at(double x_mm, double y_mm) const noexcept {
    const Axis::Index ix = x_.locate(x_mm + offset_x_mm_);
    const Axis::Index iy = y_.locate(y_mm + offset_y_mm_);
    const double* r0 = &grid_[static_cast<std::size_t>(iy.i) * x_.count + ix.i];
    const double* r1 = r0 + x_.count;
    const double z0 = lerp(ix.t, r0[0], r0[1]);
    const double z1 = lerp(ix.t, r1[0], r1[1]);
    return lerp(iy.t, z0, z1);
  }
  /// Lowest and highest value of the fine grid [mm].
  [[nodiscard]] std::pair<double, double> z_range() const;
  /// Mean of the fine grid rounded to 0.01 mm (Klipper's default fade_target).
  [[nodiscard]] double z_average_rounded() const;
  /// BED_MESH_OFFSET X= Y=: the mesh is looked up at (x + X, y + Y).
  void set_offsets(double x_mm, double y_mm) { offset_x_mm_ = x_mm; offset_y_mm_ = y_mm; }

  [[nodiscard]] int fine_x_count() const { return x_.count; }
  [[nodiscard]] int fine_y_count() const { return y_.count; }
  /// The fine grid, row-major with y outermost.
  [[nodiscard]] const std::vector<double>& fine_grid() const { return grid_; }
  [[nodiscard]] const std::string& profile_name() const { return name_; }

 private:
  static double lerp(double t, double a, double b) noexcept { return (1.0 - t) * a + t * b; }
  struct Axis {
    double min = 0.0, dist = 1.0;
    int count = 2;
    struct Index { int i; double t; };
    [[nodiscard]] Index locate(double c) const noexcept;
  };
  void sample_lagrange(const Profile& p);
  void sample_bicubic(const Profile& p);

  std::string name_;
  Axis x_, y_;
  int x_mult_ = 1, y_mult_ = 1;
  std::vector<double> grid_;
  double offset_x_mm_ = 0.0, offset_y_mm_ = 0.0;
};

}  // namespace amctl::bedmesh
