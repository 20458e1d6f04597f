#pragma once
// `amctl shrink apply`: scale an STL model or a sliced G-code file by shrinkage factors and
// predict the printed size: the compensated part shrinks back through the inverse map, and in
// Z the layered height (whole layers of the compensated part) goes through it.
#include <array>
#include <cstddef>
#include <optional>
#include <string>

#include "amctl/core/json.hpp"
#include "amctl/process/gcode_scale.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/slicing.hpp"
#include "amctl/process/stl.hpp"

namespace amctl::process {

/// Z of a compensated part cut into layers, and what it shrinks to.
struct SlicedHeight {
  long layers = 0;
  double sliced_height_mm = 0.0;             ///< whole layers of the compensated height
  double predicted_printed_height_mm = 0.0;  ///< the sliced height through the inverse map
  double nominal_height_mm = 0.0;
  double error_mm = 0.0;                     ///< predicted printed - nominal
};

struct SizePrediction {
  std::array<double, 3> nominal_mm{};      ///< extent of the part as given
  std::array<double, 3> compensated_mm{};  ///< extent after the map
  std::array<double, 3> predicted_mm{};    ///< the compensated extent through the inverse map
  std::optional<SlicedHeight> sliced_z;    ///< when a layer model is given
};

/// The prediction for a part spanning [nominal_min, nominal_max] that the map turned into
/// [compensated_min, compensated_max] (coordinates in mm, the map's origin included).
[[nodiscard]] SizePrediction predict_printed_size(const ScaleMap& map,
                                                  const std::array<double, 3>& nominal_min,
                                                  const std::array<double, 3>& nominal_max,
                                                  const std::array<double, 3>& compensated_min,
                                                  const std::array<double, 3>& compensated_max,
                                                  const std::optional<SlicingModel>& layers);

struct ShrinkApplyRequest {
  std::string model_path;   ///< STL, or
  std::string gcode_path;   ///< G-code: exactly one of the two
  std::array<AxisMap, 3> factors{};
  /// Default: XY centre of the part; Z = part bottom for STL, the bed (0) for G-code.
  std::optional<std::array<double, 3>> origin_mm;
  std::string output_path;
  std::optional<StlFormat> stl_format;       ///< default: as read
  std::optional<SlicingModel> layers;        ///< predict the layered Z height
  bool scale_extrusion = true;               ///< G-code: rescale E with the path
};

struct StlApplyReport {
  std::size_t triangles = 0;
  double volume_mm3 = 0.0, scaled_volume_mm3 = 0.0;
  StlFormat format = StlFormat::binary;
};

struct ShrinkApplyReport {
  std::string input, output;
  ScaleMap map;
  SizePrediction prediction;
  std::optional<StlApplyReport> stl;
  std::optional<GcodeScaleReport> gcode;
};

/// Writes the scaled part atomically (nothing is written on error) and reports.
[[nodiscard]] ShrinkApplyReport shrink_apply(const ShrinkApplyRequest& request);
[[nodiscard]] Json shrink_apply_json(const ShrinkApplyReport& report);
[[nodiscard]] std::string shrink_apply_text(const ShrinkApplyReport& report);

}  // namespace amctl::process
