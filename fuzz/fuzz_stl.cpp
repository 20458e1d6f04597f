// libFuzzer target for the STL reader (process/stl.hpp, ASCII and binary) and the mesh
// checks of `amctl shrink apply --model`. Acceptable outcomes: a mesh with finite
// coordinates that writes back in both formats and reads back with the same triangles, or
// amctl::Error.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/process/stl.hpp"
#include "fuzz_support.hpp"

namespace pr = amctl::process;
using amctl::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  pr::Mesh mesh;
  try {
    mesh = pr::parse_stl(bytes, "fuzz.stl");
  } catch (const amctl::Error&) {
    return 0;
  }
  for (const auto& t : mesh.triangles) {
    for (const auto& v : t.v) {
      for (double c : v) require(std::isfinite(c));
    }
  }
  const pr::MeshCheck check = pr::check_mesh(mesh);
  require(check.ok() == check.first_problem.empty());
  try {
    pr::require_closed_manifold(mesh, "fuzz.stl");
    require(check.ok());
  } catch (const amctl::Error&) {
    require(!check.ok());
  }
  for (auto format : {pr::StlFormat::binary, pr::StlFormat::ascii}) {
    const std::string out = pr::serialize_stl(mesh, format);
    pr::Mesh back;
    try {
      back = pr::parse_stl(out, "again.stl");
    } catch (const amctl::Error&) {
      // Binary STL stores floats: a finite double beyond FLT_MAX becomes inf and is refused.
      if (format == pr::StlFormat::binary) continue;
      __builtin_trap();  // amctl wrote an ASCII STL it refuses to read
    }
    require(back.triangles.size() == mesh.triangles.size());
    require(back.format == format);
  }
  return 0;
}
