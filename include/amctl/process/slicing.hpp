#pragma once
// Slicing error (seed 004, section 2): a layered part can only take heights that are whole
// numbers of layers, so a feature whose top falls between two slice planes loses (or gains)
// up to one layer. This models which layers a slicer keeps.
#include <optional>
#include <vector>

#include "amctl/process/scale_map.hpp"

namespace amctl::process {

/// Layer k (1-based) spans [z_{k-1}, z_k] with z_0 = 0, z_1 = first_layer_mm and
/// z_k = first_layer_mm + (k - 1) layer_mm. The slicer samples the part on one plane per
/// layer, at z_{k-1} + plane_fraction (z_k - z_{k-1}); the layer is printed when that plane
/// still cuts the feature, i.e. when the plane lies at or below the feature top H.
///   plane_fraction = 1   keep only layers whose top fits under H (floor; the seed's
///                        remodelled geometry 4 was built this way);
///   plane_fraction = 0.5 mid-layer sampling (PrusaSlicer, Cura): round to nearest layer.
struct SlicingModel {
  double layer_mm = 0.2;
  double first_layer_mm = 0.2;
  double plane_fraction = 0.5;

  /// Throws amctl::Error unless thicknesses > 0 and 0 < plane_fraction <= 1.
  void validate() const;
  /// Number of layers printed for a feature of height `height_mm` standing on the bed.
  [[nodiscard]] long layers_for(double height_mm) const;
  /// Height of the top of layer n (0 for n = 0).
  [[nodiscard]] double height_of_layers(long n) const;
  /// Height the layered feature gets: height_of_layers(layers_for(H)).
  [[nodiscard]] double sliced_height(double height_mm) const;
};

/// The interval of plane fractions (lo, hi] that reproduces observed layer counts for the
/// given feature heights with the layer and first-layer thickness of `model`. Throws when no
/// single fraction explains all of them.
struct FractionInterval {
  double lo = 0.0;   ///< exclusive
  double hi = 1.0;   ///< inclusive
};
[[nodiscard]] FractionInterval fit_plane_fraction(const SlicingModel& model,
                                                  const std::vector<double>& heights_mm,
                                                  const std::vector<long>& layers);

/// One row of the seed's Table 2.
struct SlicingErrorRow {
  double nominal_mm = 0.0;
  double target_mm = 0.0;       ///< nominal after compensation (what the slicer was given)
  long layers = 0;
  double sliced_mm = 0.0;       ///< height of the layered part before shrinkage
  double slicing_error_mm = 0.0;  ///< sliced - target (seed's definition)
  std::optional<double> measured_mm;
  std::optional<double> total_error_mm;        ///< measured - nominal
  std::optional<double> dimensional_error_mm;  ///< total - slicing (seed's definition)
  std::optional<double> process_error_mm;      ///< measured - sliced: what the process did
};

/// How a compensation applies to a feature height.
enum class HeightScaling {
  none,       ///< target = nominal
  dimension,  ///< target = C_r(H) * H, the factor of the range holding H (the seed's Table 2)
  position    ///< target = g(H), the continuous piecewise map used on models and G-code
};

/// Builds the table for `nominals` (and optional measurements, same length or empty).
[[nodiscard]] std::vector<SlicingErrorRow> slicing_error_table(
    const std::vector<double>& nominals_mm, const std::vector<double>& measured_mm,
    const AxisMap& z_map, HeightScaling scaling, const SlicingModel& model);

}  // namespace amctl::process
