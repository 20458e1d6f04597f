#pragma once
// `amctl shrink slicing`: the seed's Table 2 for the heights of a CSV (slicing, dimensional
// and total error), with the slice-plane position optionally fitted to observed slicing
// errors.
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/slicing.hpp"

namespace amctl::process {

struct SlicingStudyRequest {
  std::string csv_path;               ///< column nominal_mm (> 0), others by name
  std::string measured_column;        ///< measured heights (mm, >= 0); "" = none
  std::string observed_slicing_column;  ///< observed slicing errors: fit the plane fraction
  AxisMap z_map;                      ///< the Z compensation the part was built with
  HeightScaling scaling = HeightScaling::dimension;
  double layer_mm = 0.254;
  std::optional<double> first_layer_mm;  ///< default: layer_mm
  std::optional<double> plane_fraction;  ///< default: 1, or the middle of the fitted interval
};

struct SlicingStudy {
  SlicingModel model;
  std::optional<FractionInterval> fitted_fraction;
  std::vector<SlicingErrorRow> rows;
};

[[nodiscard]] SlicingStudy slicing_study(const SlicingStudyRequest& request);
[[nodiscard]] Json slicing_study_json(const SlicingStudy& study);
[[nodiscard]] std::string slicing_study_text(const SlicingStudy& study);

}  // namespace amctl::process
