#pragma once
// The empirical build-time estimator of seed 004 (section 3), generalised to G-code:
//
//   T = L_raster / v_raster + L_contour / v_contour + sum_links L_i / v_link(w_i)
//       + L_travel / v_travel + N_layer t_layer + N_retract t_retract + N_wipe t_wipe + t_fixed
//
// with average speeds measured on real parts rather than machine limits. The seed measured
// v_raster = 24.34 mm/s (mean of 12 cases, insensitive to width and angle) and link speeds
// 9.13 / 11.10 / 11.57 mm/s for extrusion widths 0.305 / 0.505 / 0.705 mm on a Stratasys
// FDM 2000, and used the raster speed for contours. Link paces (s/mm = 1/v) are interpolated
// linearly in width between the tabulated widths (clamped outside), which keeps T linear in
// every parameter, so the parameters are fitted from measured durations by least squares.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/process/stats.hpp"

namespace amctl::process {

/// Lengths and counts the estimator needs, for a whole file or one layer.
struct TimeFeatures {
  double raster_mm = 0.0;     ///< infill lines (longer than a link)
  double contour_mm = 0.0;    ///< perimeters, skirt, brim, gap fill, unknown extrusion
  /// Link length apportioned to the tabulated widths (hat-function weights), one per width.
  std::vector<double> link_mm_by_width;
  double link_mm = 0.0;       ///< total link length
  double travel_mm = 0.0;     ///< non-extruding XY(Z) moves
  double layer_changes = 0.0;
  double retracts = 0.0;      ///< retractions (extrude-only moves with negative E)
  double wipes = 0.0;         ///< moves travelling while retracting
  double files = 0.0;         ///< 1 for a whole file (the fixed-time term), 0 for a layer
};

/// How G-code moves are classified.
struct ScanOptions {
  /// Extrusion widths (mm, strictly increasing) at which link speeds are tabulated.
  std::vector<double> link_widths_mm{0.305, 0.505, 0.705};
  /// An infill move is a link when it is at most this many extrusion widths long.
  double link_length_widths = 3.0;
  double filament_diameter_mm = 1.75;
  /// Width used when it cannot be derived (no layer height yet).
  double default_width_mm = 0.45;
};

struct GcodeTimeScan {
  TimeFeatures total;
  std::vector<TimeFeatures> layers;     ///< index = slicer layer (0-based); empty if none
  std::vector<std::string> feature_names;
  std::optional<double> slicer_estimate_s;
  double mean_raster_width_mm = 0.0;
  std::uint64_t raster_moves = 0, link_moves = 0;
};

/// Reads G-code with the gcode module's interpreter. Extrusion width is derived from the
/// filament fed: A = E * pi d^2 / 4 / L and PrusaSlicer's rounded-rectangle bead
/// A = (w - h) h + pi h^2 / 4, h the layer height.
[[nodiscard]] GcodeTimeScan scan_gcode_for_time(std::string_view text, const std::string& name,
                                                const ScanOptions& options);
[[nodiscard]] GcodeTimeScan scan_gcode_file_for_time(const std::string& path,
                                                     const ScanOptions& options);

/// The estimator's parameters.
struct EmpiricalTimeModel {
  double raster_speed_mm_s = 24.34;
  double contour_speed_mm_s = 24.34;
  std::vector<double> link_widths_mm{0.305, 0.505, 0.705};
  std::vector<double> link_speeds_mm_s{9.13, 11.10, 11.57};
  double travel_speed_mm_s = 24.34;
  double layer_change_s = 0.0;
  double retract_s = 0.0;
  double wipe_s = 0.0;
  double fixed_s = 0.0;

  /// Throws amctl::Error unless speeds are > 0, times >= 0 and the link table is consistent.
  void validate() const;
  [[nodiscard]] double estimate_s(const TimeFeatures& f) const;
  /// Seed preset: FDM 2000 speeds from seed 004 Table 3 / conclusions.
  static EmpiricalTimeModel fdm2000_seed();
};

/// Parameter names in the order used by fits: raster_pace, contour_pace, link_pace@<w>...,
/// travel_pace, layer_change_s, retract_s, wipe_s, fixed_s (paces in s/mm).
[[nodiscard]] std::vector<std::string> empirical_parameter_names(const EmpiricalTimeModel& m);
[[nodiscard]] std::vector<double> empirical_parameters(const EmpiricalTimeModel& m);
[[nodiscard]] EmpiricalTimeModel with_parameters(const EmpiricalTimeModel& base,
                                                 const std::vector<double>& p);
/// The regression row of `f` (T = row . parameters).
[[nodiscard]] std::vector<double> empirical_row(const TimeFeatures& f, const EmpiricalTimeModel& m);

struct EmpiricalFitOptions {
  /// Parameters held at the starting model's values (by name, see above).
  std::vector<std::string> fixed;
  /// Use the raster speed for contours too (the seed's choice).
  bool contour_equals_raster = true;
  double confidence = 0.95;
};

struct EmpiricalFit {
  EmpiricalTimeModel model;
  std::vector<std::string> names;        ///< every parameter
  std::vector<double> values, std_errors;  ///< std error 0 for fixed ones
  std::vector<bool> free;
  std::vector<std::string> not_identified;  ///< free but absent from every sample: kept fixed
  std::vector<double> predicted_s, residual_s;  ///< per sample
  double rms_s = 0.0;
  std::size_t dof = 0;
};

/// Fits the model to measured durations: one TimeFeatures per sample and its duration.
/// Throws amctl::Error when samples are fewer than free parameters, or the free parameters
/// cannot be told apart (collinear lengths/counts): the message names them and suggests
/// fixing some.
[[nodiscard]] EmpiricalFit fit_empirical(const std::vector<TimeFeatures>& samples,
                                         const std::vector<double>& durations_s,
                                         const EmpiricalTimeModel& start,
                                         const EmpiricalFitOptions& options);

/// Seed eq. (6): link speed from a timed trajectory, v_link = L_link / (T - L_raster/v_raster).
[[nodiscard]] double link_speed_from_timing(double link_mm, double trajectory_s, double raster_mm,
                                            double raster_speed_mm_s);

}  // namespace amctl::process
