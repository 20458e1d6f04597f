#pragma once
// Compensating a sliced part: rewrite the coordinates of G0/G1/G2/G3 moves through a
// ScaleMap. Because the Z map is a continuous increasing function, every move of one layer
// gets the same new Z and the layer order is kept. Extrusion is rescaled with the path:
// E per move is multiplied by (new XY length / old XY length) * dZ'/dZ (the layer height
// grows with the local Z factor), so the bead cross-section stays what the slicer planned.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "amctl/process/scale_map.hpp"

namespace amctl::process {

struct GcodeScaleOptions {
  bool scale_extrusion = true;
  /// Coordinate decimals written for X/Y/Z/I/J and E.
  int xyz_decimals = 4;
  int e_decimals = 5;
};

struct GcodeScaleReport {
  std::uint64_t lines = 0;
  std::uint64_t moves_rewritten = 0;
  std::uint64_t arcs = 0;
  std::uint64_t layers = 0;                ///< distinct Z values of extruding moves
  double max_arc_radius_mismatch_mm = 0;   ///< |r_start - r_end| after an anisotropic XY map
  std::array<double, 3> extrusion_min_mm{}, extrusion_max_mm{};    ///< before
  std::array<double, 3> scaled_min_mm{}, scaled_max_mm{};          ///< after
  double extruded_mm = 0, scaled_extruded_mm = 0;                  ///< total filament
};

/// Extent of extruding moves (used to pick a default origin); throws when nothing extrudes.
struct GcodeExtent {
  std::array<double, 3> min_mm{}, max_mm{};
};
[[nodiscard]] GcodeExtent gcode_extrusion_extent(std::string_view text, const std::string& file);

/// Rewrites `text`. Throws amctl::Error (file:line) for inch units (G20), R-form arcs under
/// an anisotropic or piecewise XY map, or malformed words. `out` receives the new text.
GcodeScaleReport scale_gcode(std::string_view text, const std::string& file, const ScaleMap& map,
                             const GcodeScaleOptions& options, std::string& out);

}  // namespace amctl::process
