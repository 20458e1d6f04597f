#include "amctl/process/slicing_study.hpp"

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"

namespace amctl::process {

SlicingStudy slicing_study(const SlicingStudyRequest& q) {
  const auto t = CsvTable::read(q.csv_path);
  const std::size_t ncol = t.require("nominal_mm");
  std::vector<double> nom, meas;
  std::optional<std::size_t> mcol;
  if (!q.measured_column.empty()) mcol = t.require(q.measured_column);
  for (std::size_t r = 0; r < t.rows(); ++r) {
    nom.push_back(t.number(r, ncol));
    if (nom.back() <= 0) throw Error(t.where(r, ncol), "nominal height must be > 0");
    if (mcol) {
      meas.push_back(t.number(r, *mcol));
      if (meas.back() < 0) throw Error(t.where(r, *mcol), "measured height must be >= 0");
    }
  }
  SlicingStudy s;
  s.model.layer_mm = q.layer_mm;
  s.model.first_layer_mm = q.first_layer_mm.value_or(q.layer_mm);
  s.model.plane_fraction = 1.0;
  if (!q.observed_slicing_column.empty()) {
    const std::size_t oc = t.require(q.observed_slicing_column);
    const auto base = slicing_error_table(nom, {}, q.z_map, q.scaling, s.model);
    std::vector<double> h;
    std::vector<long> n;
    for (std::size_t r = 0; r < t.rows(); ++r) {
      const double sliced = base[r].target_mm + t.number(r, oc);
      h.push_back(base[r].target_mm);
      n.push_back(std::lround((sliced - s.model.first_layer_mm) / s.model.layer_mm) + 1);
    }
    s.fitted_fraction = fit_plane_fraction(s.model, h, n);
    s.model.plane_fraction = 0.5 * (s.fitted_fraction->lo + s.fitted_fraction->hi);
  }
  if (q.plane_fraction) s.model.plane_fraction = *q.plane_fraction;
  s.rows = slicing_error_table(nom, meas, q.z_map, q.scaling, s.model);
  return s;
}

Json slicing_study_json(const SlicingStudy& s) {
  Json j;
  j["layer_mm"] = s.model.layer_mm;
  j["first_layer_mm"] = s.model.first_layer_mm;
  j["plane_fraction"] = s.model.plane_fraction;
  j["plane_fraction_fit"] = nullptr;
  if (s.fitted_fraction) {
    j["plane_fraction_fit"] = {{"plane_fraction_lo", s.fitted_fraction->lo},
                               {"plane_fraction_hi", s.fitted_fraction->hi}};
  }
  j["rows"] = Json::array();
  for (const auto& r : s.rows) {
    Json jr{{"nominal_mm", r.nominal_mm},   {"target_mm", r.target_mm},
            {"layers", r.layers},           {"sliced_mm", r.sliced_mm},
            {"slicing_error_mm", r.slicing_error_mm}};
    if (r.measured_mm) {
      jr["measured_mm"] = *r.measured_mm;
      jr["total_error_mm"] = *r.total_error_mm;
      jr["dimensional_error_mm"] = *r.dimensional_error_mm;
      jr["process_error_mm"] = *r.process_error_mm;
    }
    j["rows"].push_back(jr);
  }
  return j;
}

std::string slicing_study_text(const SlicingStudy& s) {
  std::string out;
  if (s.fitted_fraction) {
    out += fmt::format("slice plane fraction consistent with the data: ({:.4f}, {:.4f}], "
                       "using {:.4f}\n",
                       s.fitted_fraction->lo, s.fitted_fraction->hi, s.model.plane_fraction);
  }
  out += fmt::format("{:>9} {:>9} {:>6} {:>9} {:>9} {:>9} {:>9} {:>9}\n", "nominal", "target",
                     "layers", "sliced", "slicing", "measured", "dimens.", "total");
  for (const auto& r : s.rows) {
    out += fmt::format("{:9.3f} {:9.4f} {:6} {:9.3f} {:9.3f}", r.nominal_mm, r.target_mm,
                       r.layers, r.sliced_mm, r.slicing_error_mm);
    if (r.measured_mm) {
      out += fmt::format(" {:9.3f} {:9.3f} {:9.3f}", *r.measured_mm, *r.dimensional_error_mm,
                         *r.total_error_mm);
    }
    out += "\n";
  }
  return out;
}

}  // namespace amctl::process
