#include "amctl/process/slicing.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::process {
namespace {
// Heights are compared with a tolerance far below any caliper resolution so that a feature
// of exactly n layers keeps its n-th layer despite rounding in n * layer_mm.
constexpr double kTolMm = 1e-9;
}  // namespace

void SlicingModel::validate() const {
  require_positive("layer_mm", layer_mm);
  require_positive("first_layer_mm", first_layer_mm);
  if (!(plane_fraction > 0.0 && plane_fraction <= 1.0)) {
    throw Error(fmt::format("plane_fraction must lie in (0, 1], got {}", plane_fraction));
  }
}

long SlicingModel::layers_for(double h) const {
  validate();
  require_finite("feature height", h);
  if (h + kTolMm < plane_fraction * first_layer_mm) return 0;
  // Layer k >= 2 is kept when first + (k - 2 + p) t <= h.
  const double rest = (h + kTolMm - first_layer_mm - plane_fraction * layer_mm) / layer_mm;
  if (rest < 0.0) return 1;
  return 2 + static_cast<long>(std::floor(rest));
}

double SlicingModel::height_of_layers(long n) const {
  if (n <= 0) return 0.0;
  return first_layer_mm + static_cast<double>(n - 1) * layer_mm;
}

double SlicingModel::sliced_height(double h) const { return height_of_layers(layers_for(h)); }

FractionInterval fit_plane_fraction(const SlicingModel& model, const std::vector<double>& h,
                                    const std::vector<long>& layers) {
  if (h.size() != layers.size() || h.empty()) {
    throw Error("fit_plane_fraction: need one layer count per height and at least one height");
  }
  const double t = model.layer_mm, f = model.first_layer_mm;
  FractionInterval iv{0.0, 1.0};
  for (std::size_t i = 0; i < h.size(); ++i) {
    const long n = layers[i];
    if (n < 1) throw Error(fmt::format("row {}: layer count must be >= 1, got {}", i + 1, n));
    // Layer n kept: plane_n <= h.  plane_1 = p f; plane_k = f + (k - 2 + p) t for k >= 2.
    if (n == 1) iv.hi = std::min(iv.hi, h[i] / f);
    else iv.hi = std::min(iv.hi, (h[i] - f) / t - static_cast<double>(n - 2));
    // Layer n + 1 dropped: plane_{n+1} = f + (n - 1 + p) t > h.
    iv.lo = std::max(iv.lo, (h[i] - f) / t - static_cast<double>(n - 1));
  }
  if (!(iv.lo < iv.hi)) {
    throw Error(fmt::format("no single slice-plane position explains these layer counts "
                            "(needs fraction > {:.4f} and <= {:.4f})",
                            iv.lo, iv.hi));
  }
  return iv;
}

std::vector<SlicingErrorRow> slicing_error_table(const std::vector<double>& nominals,
                                                 const std::vector<double>& measured,
                                                 const AxisMap& z_map, HeightScaling scaling,
                                                 const SlicingModel& model) {
  model.validate();
  if (!measured.empty() && measured.size() != nominals.size()) {
    throw Error(fmt::format("{} nominal heights but {} measurements", nominals.size(),
                            measured.size()));
  }
  std::vector<SlicingErrorRow> rows;
  for (std::size_t i = 0; i < nominals.size(); ++i) {
    SlicingErrorRow r;
    r.nominal_mm = nominals[i];
    switch (scaling) {
      case HeightScaling::none: r.target_mm = r.nominal_mm; break;
      case HeightScaling::dimension: r.target_mm = z_map.factor_for_size(r.nominal_mm) * r.nominal_mm; break;
      case HeightScaling::position: r.target_mm = z_map.map(r.nominal_mm); break;
    }
    r.layers = model.layers_for(r.target_mm);
    r.sliced_mm = model.height_of_layers(r.layers);
    r.slicing_error_mm = r.sliced_mm - r.target_mm;
    if (!measured.empty()) {
      r.measured_mm = measured[i];
      r.total_error_mm = measured[i] - r.nominal_mm;
      r.dimensional_error_mm = *r.total_error_mm - r.slicing_error_mm;
      r.process_error_mm = measured[i] - r.sliced_mm;
    }
    rows.push_back(r);
  }
  return rows;
}

}  // namespace amctl::process
