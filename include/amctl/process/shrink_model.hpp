#pragma once
// The shrink model: what `amctl shrink fit --json` prints and `amctl shrink apply --factors
// FILE.json` reads back. One axis is one object; several axes are {"axes": [ ... ]} with the
// fitted file and method beside them:
//
//   {"axis": "Z", "factor": 1.0032, "slope": ..., ...}                       one range
//   {"axis": "Z", "ranges": [{"factor": F1, "upper_mm": B1, ...}, {"factor": F2, ...}],
//    "breaks_mm": [B1], "factors_spec": "z=F1:B1:F2", ...}                    several ranges
//
// Reading needs only "axis" and the factors (and upper_mm of every range but the last); every
// other key is the fit's statistics, written for people and kept for other tools. Every error
// names file:line.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/shrinkage.hpp"

namespace amctl::process {

/// Reads the samples of a measurement CSV (read_shrink_samples), keeps only `axis` when given
/// ('X', 'Y' or 'Z'; an error when none is left) and fits them.
[[nodiscard]] std::vector<AxisShrinkFit> fit_shrinkage_file(const std::string& csv_path,
                                                            std::optional<char> axis,
                                                            const ShrinkFitOptions& options);

/// The model file's JSON of `fits` fitted from `csv_path` (averaged: means or measurements).
[[nodiscard]] Json shrink_model_json(const std::vector<AxisShrinkFit>& fits,
                                     const std::string& csv_path, bool averaged);

/// The per-axis maps of a model file (axes it does not name keep factor 1).
[[nodiscard]] std::array<AxisMap, 3> read_shrink_model(const std::string& path);
[[nodiscard]] std::array<AxisMap, 3> parse_shrink_model(const std::string& text,
                                                        const std::string& name);

/// `--factors`: a model file when the argument ends in ".json", else an inline spec
/// (parse_factor_spec).
[[nodiscard]] std::array<AxisMap, 3> load_factor_maps(const std::string& spec_or_path);

/// Human-readable lines for one fitted axis (`amctl shrink fit` without --json).
[[nodiscard]] std::string shrink_fit_text(const AxisShrinkFit& fit);

}  // namespace amctl::process
