// libFuzzer target for Klipper's [bed_mesh] and its saved profiles (bedmesh::read_klipper):
// the input is a printer.cfg; its mesh settings are read, every profile upsampled (ZMesh) and
// looked up, and a short print that loads the first profile is planned through the mesh's
// move transform.
//
// Acceptable outcomes: settings or amctl::Error. Every z the mesh gives must be finite, every
// upsampled grid within the documented bounds, and the print's time finite and >= 0.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "amctl/bedmesh/config.hpp"
#include "amctl/bedmesh/mesh.hpp"
#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "fuzz_support.hpp"

using amctl::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  // [include] would read other files: this target is about the mesh.
  if (text.find("[include") != std::string_view::npos) return 0;
  try {
    const amctl::machine::Machine m = amctl::machine::parse_klipper_cfg(text, "fuzz.cfg");
    const auto settings = amctl::bedmesh::read_klipper(m.klipper_config, amctl::SourceLocation{"fuzz.cfg", 0, 0});
    if (!settings) return 0;
    (void)amctl::bedmesh::to_json(*settings).dump();
    (void)amctl::bedmesh::to_text(*settings);
    for (const auto& p : settings->profiles) {
      amctl::bedmesh::ZMesh mesh(p);
      require(mesh.fine_x_count() <= amctl::bedmesh::kMaxFineCount &&
              mesh.fine_y_count() <= amctl::bedmesh::kMaxFineCount);
      const auto& q = p.params;
      for (double fx : {-1.0, 0.0, 0.37, 0.5, 1.0, 2.0}) {
        for (double fy : {-1.0, 0.0, 0.61, 1.0, 2.0}) {
          const double x = q.min_x_mm + fx * (q.max_x_mm - q.min_x_mm);
          const double y = q.min_y_mm + fy * (q.max_y_mm - q.min_y_mm);
          require(std::isfinite(mesh.z_at(x, y)));
        }
      }
    }
    if (settings->profiles.empty()) return 0;
    const auto& q = settings->profiles.front().params;
    const std::string gcode = "SET_KINEMATIC_POSITION X=" + std::to_string(q.min_x_mm) +
                              " Y=" + std::to_string(q.min_y_mm) + " Z=0\nBED_MESH_PROFILE LOAD=" +
                              settings->profiles.front().name + "\nG1 X" + std::to_string(0.5 * (q.min_x_mm + q.max_x_mm)) +
                              " Y" + std::to_string(q.max_y_mm) + " Z0.2 F6000\nBED_MESH_OFFSET X=1 ZFADE=0.1\n"
                              "G1 X" + std::to_string(q.min_x_mm) + " Z0.4\nBED_MESH_CLEAR\nG1 Y" +
                              std::to_string(q.min_y_mm) + "\n";
    const auto r = amctl::plan::estimate_text(gcode, "fuzz.gcode", m, {});
    require(std::isfinite(r.total_time_s) && r.total_time_s >= 0.0);
  } catch (const amctl::Error&) {
  }
  return 0;
}
