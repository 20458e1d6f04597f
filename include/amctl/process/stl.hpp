#pragma once
// STL triangle meshes: binary and ASCII reading and writing, and the checks a slicer needs
// (closed, edge-manifold, consistently oriented, no degenerate triangles).
#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/process/scale_map.hpp"

namespace amctl::process {

using Vec3 = std::array<double, 3>;

struct Triangle {
  Vec3 normal{};
  std::array<Vec3, 3> v{};
};

enum class StlFormat { binary, ascii };

struct Mesh {
  std::string name;            ///< ASCII solid name or binary header text
  std::vector<Triangle> triangles;
  StlFormat format = StlFormat::binary;  ///< format it was read from

  [[nodiscard]] Vec3 min_corner() const;
  [[nodiscard]] Vec3 max_corner() const;
};

/// Parses STL bytes; `file` names the source in errors. Binary when the size is exactly
/// 84 + 50 n for the triangle count n in the header, ASCII when it starts with "solid" and is
/// not such a binary, otherwise an error. Coordinates must be finite.
[[nodiscard]] Mesh parse_stl(std::string_view bytes, const std::string& file);
[[nodiscard]] Mesh read_stl(const std::string& path);

/// Serialises (normals are recomputed from the vertices).
[[nodiscard]] std::string serialize_stl(const Mesh& mesh, StlFormat format);

/// Topology of a mesh after welding identical vertices.
struct MeshCheck {
  std::size_t vertices = 0;
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;      ///< used by one triangle: the surface has a hole
  std::size_t nonmanifold_edges = 0;   ///< used by more than two triangles
  std::size_t misoriented_edges = 0;   ///< two triangles traverse it the same way
  std::size_t degenerate_triangles = 0;
  std::string first_problem;           ///< human-readable description of one offending item
  double volume_mm3 = 0.0;             ///< signed volume (positive for outward normals)
  [[nodiscard]] bool ok() const {
    return boundary_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0 &&
           degenerate_triangles == 0;
  }
};
[[nodiscard]] MeshCheck check_mesh(const Mesh& mesh);
/// Throws amctl::Error describing the defects unless check_mesh(mesh).ok().
void require_closed_manifold(const Mesh& mesh, const std::string& file);

/// Returns the mesh with every vertex mapped by `map` (normals recomputed).
[[nodiscard]] Mesh scale_mesh(const Mesh& mesh, const ScaleMap& map);

}  // namespace amctl::process
