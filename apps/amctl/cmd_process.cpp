// amctl shrink fit | shrink slicing | shrink apply | calibrate-time | estimate-time (process
// planning, seed 004).
#include <cmath>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/shrinkage.hpp"
#include "amctl/process/slicing.hpp"
#include "commands.hpp"

namespace amctl::cli {
namespace {

using nlohmann::json;
namespace pr = amctl::process;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json range_json(const pr::RangeFit& r, double confidence) {
  json j;
  j["n"] = r.line.n;
  j["levels"] = r.levels;
  j["lower_mm"] = r.lower_mm;
  j["upper_mm"] = num(r.upper_mm);
  j["data_min_mm"] = r.data_min_mm;
  j["data_max_mm"] = r.data_max_mm;
  j["slope"] = r.line.slope;
  j["intercept"] = r.line.intercept;
  j["factor"] = r.factor;
  j["slope_se"] = r.line.slope_se;
  j["intercept_se"] = r.line.intercept_se;
  j["slope_intercept_cov"] = r.line.covariance;
  j["factor_se"] = r.factor_se;
  j["confidence"] = confidence;
  j["slope_ci"] = {r.slope_ci_lo, r.slope_ci_hi};
  j["factor_ci"] = {num(r.factor_ci_lo), num(r.factor_ci_hi)};
  j["r2"] = r.line.r2;
  j["residual_sd_mm"] = r.line.residual_sd;
  j["sse_mm2"] = r.line.sse;
  j["pure_error_sd_mm"] = r.pure_error_sd_mm;
  j["lack_of_fit_p"] = r.lack_of_fit_p ? json(*r.lack_of_fit_p) : json(nullptr);
  return j;
}

json axis_json(const pr::AxisShrinkFit& a) {
  json j;
  if (a.ranges.size() == 1) {
    j = range_json(a.ranges.front(), a.confidence);
  } else {
    j["ranges"] = json::array();
    json breaks = json::array();
    for (std::size_t i = 0; i < a.ranges.size(); ++i) {
      j["ranges"].push_back(range_json(a.ranges[i], a.confidence));
      if (i + 1 < a.ranges.size()) breaks.push_back(a.ranges[i].upper_mm);
    }
    j["breaks_mm"] = breaks;
    j["breaks_from_data"] = a.breaks_from_data;
    j["total_sse_mm2"] = a.total_sse;
    // The spec string that `shrink apply --factors` accepts for this axis.
    std::string spec = fmt::format("{}=", static_cast<char>(std::tolower(a.axis)));
    for (std::size_t i = 0; i < a.ranges.size(); ++i) {
      if (i) spec += fmt::format(":{}:", a.ranges[i - 1].upper_mm);
      spec += fmt::format("{:.6f}", a.ranges[i].factor);
    }
    j["factors_spec"] = spec;
  }
  j["axis"] = std::string(1, a.axis);
  return j;
}

std::vector<double> parse_list(const std::string& s, const char* what) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ',')) {
    try {
      std::size_t used = 0;
      const double v = std::stod(tok, &used);
      if (used != tok.size()) throw std::invalid_argument(tok);
      out.push_back(v);
    } catch (const std::exception&) {
      throw Error(fmt::format("{}: expected comma-separated numbers, got '{}'", what, s));
    }
  }
  return out;
}

void print_axis_text(const pr::AxisShrinkFit& a) {
  std::cout << fmt::format("axis {}: {} range(s){}\n", a.axis, a.ranges.size(),
                           a.breaks_from_data ? " (breakpoints found from the data)" : "");
  for (const auto& r : a.ranges) {
    std::cout << fmt::format(
        "  {:>7.3f} < h <= {:<8} n={:<3} E = {:+.6f} h {:+.5f} mm  (se {:.6f}, {:.5f})  R2={:.4f}\n"
        "                      C = {:.5f} +- {:.5f}  {:.0f}% CI [{:.5f}, {:.5f}]\n",
        r.lower_mm, std::isfinite(r.upper_mm) ? fmt::format("{:.3f}", r.upper_mm) : "inf",
        r.line.n, r.line.slope, r.line.intercept, r.line.slope_se, r.line.intercept_se,
        r.line.r2, r.factor, r.factor_se, 100 * a.confidence, r.factor_ci_lo, r.factor_ci_hi);
  }
}

void register_shrink_fit(CLI::App& shrink) {
  auto* cmd = shrink.add_subcommand(
      "fit", "Fit measured error E = A h + B and the shrinkage factor C = 1/(1+A) per axis");
  struct Opts {
    std::string file;
    bool json = false;
    bool average = false;
    std::string ranges = "1";
    std::string breaks;
    int min_points = 3;
    double confidence = 0.95;
    std::string axis;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("file", o->file, "CSV with header nominal_mm,measured_mm[,axis,...]")->required();
  cmd->add_flag("--json", o->json, "print one JSON object");
  cmd->add_flag("--average", o->average,
                "fit the mean error at each nominal value (the seed's procedure) instead of "
                "every repeated measurement");
  cmd->add_option("--ranges", o->ranges,
                  "number of ranges with breakpoints found from the data (1, 2, ... or auto)");
  cmd->add_option("--breaks", o->breaks, "breakpoints in mm, comma separated (e.g. 10)");
  cmd->add_option("--min-points", o->min_points, "minimum points per automatically found range");
  cmd->add_option("--confidence", o->confidence, "confidence level of the intervals");
  cmd->add_option("--axis", o->axis, "fit only this axis (X, Y or Z)");
  cmd->callback([o] {
    const auto table = pr::CsvTable::read(o->file);
    auto samples = pr::read_shrink_samples(table);
    if (!o->axis.empty()) {
      const char a = static_cast<char>(std::toupper(static_cast<unsigned char>(o->axis[0])));
      if (o->axis.size() != 1 || (a != 'X' && a != 'Y' && a != 'Z')) {
        throw Error(fmt::format("--axis must be X, Y or Z, got '{}'", o->axis));
      }
      std::erase_if(samples, [a](const pr::ShrinkSample& s) { return s.axis != a; });
      if (samples.empty()) throw Error(fmt::format("{}: no samples for axis {}", o->file, a));
    }
    pr::ShrinkFitOptions opt;
    opt.average_repeats = o->average;
    opt.min_points_per_range = o->min_points;
    opt.confidence = o->confidence;
    if (!o->breaks.empty()) {
      opt.breaks_mm = parse_list(o->breaks, "--breaks");
    } else if (o->ranges == "auto") {
      opt.ranges = 0;
    } else {
      const auto v = parse_list(o->ranges, "--ranges");
      if (v.size() != 1 || v[0] < 1 || v[0] != std::floor(v[0])) {
        throw Error(fmt::format("--ranges must be a whole number >= 1 or 'auto', got '{}'",
                                o->ranges));
      }
      opt.ranges = static_cast<int>(v[0]);
    }
    const auto fits = pr::fit_shrinkage(samples, opt);
    if (o->json) {
      json j;
      if (fits.size() == 1) {
        j = axis_json(fits.front());
      } else {
        j["axes"] = json::array();
        for (const auto& f : fits) j["axes"].push_back(axis_json(f));
      }
      j["file"] = o->file;
      j["fitted"] = o->average ? "means" : "measurements";
      std::cout << j.dump(2) << "\n";
    } else {
      for (const auto& f : fits) print_axis_text(f);
    }
  });
}

void register_shrink_slicing(CLI::App& shrink) {
  auto* cmd = shrink.add_subcommand(
      "slicing", "Slicing, dimensional and total error of layered heights (seed Table 2)");
  struct Opts {
    std::string file;
    std::string measured_col;
    std::string observed_col;
    std::string factors;
    std::string scaling = "dimension";
    double layer_mm = 0.254;
    std::optional<double> first_layer_mm;
    std::optional<double> plane_fraction;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("file", o->file, "CSV with nominal_mm and optionally measurements")->required();
  cmd->add_option("--measured-column", o->measured_col, "column with measured heights (mm)");
  cmd->add_option("--observed-slicing-column", o->observed_col,
                  "column with observed slicing errors (mm): fit the slice-plane position");
  cmd->add_option("--factors", o->factors, "Z compensation, e.g. z=0.9902:10:1.0032");
  cmd->add_option("--scaling", o->scaling, "dimension (seed), position (continuous map) or none")
      ->check(CLI::IsMember({"dimension", "position", "none"}));
  cmd->add_option("--layer-mm", o->layer_mm, "layer thickness");
  cmd->add_option("--first-layer-mm", o->first_layer_mm, "first layer thickness (default: layer)");
  cmd->add_option("--plane-fraction", o->plane_fraction,
                  "slice plane position inside a layer, (0,1]: 1 = keep whole layers only, "
                  "0.5 = mid-layer (default 1, or fitted with --observed-slicing-column)");
  cmd->add_flag("--json", o->json, "print one JSON object");
  cmd->callback([o] {
    const auto t = pr::CsvTable::read(o->file);
    const std::size_t ncol = t.require("nominal_mm");
    std::vector<double> nom, meas;
    std::optional<std::size_t> mcol;
    if (!o->measured_col.empty()) mcol = t.require(o->measured_col);
    for (std::size_t r = 0; r < t.rows(); ++r) {
      nom.push_back(t.number(r, ncol));
      if (nom.back() <= 0) throw Error(t.where(r, ncol), "nominal height must be > 0");
      if (mcol) {
        meas.push_back(t.number(r, *mcol));
        if (meas.back() < 0) throw Error(t.where(r, *mcol), "measured height must be >= 0");
      }
    }
    pr::AxisMap zmap;
    if (!o->factors.empty()) zmap = pr::parse_factor_spec(o->factors)[2];
    const auto scaling = o->scaling == "none"        ? pr::HeightScaling::none
                         : o->scaling == "position"  ? pr::HeightScaling::position
                                                     : pr::HeightScaling::dimension;
    pr::SlicingModel model;
    model.layer_mm = o->layer_mm;
    model.first_layer_mm = o->first_layer_mm.value_or(o->layer_mm);
    model.plane_fraction = 1.0;
    json jfit = nullptr;
    if (!o->observed_col.empty()) {
      const std::size_t oc = t.require(o->observed_col);
      const auto base = pr::slicing_error_table(nom, {}, zmap, scaling, model);
      std::vector<double> h;
      std::vector<long> n;
      for (std::size_t r = 0; r < t.rows(); ++r) {
        const double sliced = base[r].target_mm + t.number(r, oc);
        h.push_back(base[r].target_mm);
        n.push_back(std::lround((sliced - model.first_layer_mm) / model.layer_mm) + 1);
      }
      const auto iv = pr::fit_plane_fraction(model, h, n);
      jfit = {{"plane_fraction_lo", iv.lo}, {"plane_fraction_hi", iv.hi}};
      model.plane_fraction = 0.5 * (iv.lo + iv.hi);
    }
    if (o->plane_fraction) model.plane_fraction = *o->plane_fraction;
    const auto rows = pr::slicing_error_table(nom, meas, zmap, scaling, model);
    if (o->json) {
      json j;
      j["layer_mm"] = model.layer_mm;
      j["first_layer_mm"] = model.first_layer_mm;
      j["plane_fraction"] = model.plane_fraction;
      j["plane_fraction_fit"] = jfit;
      j["rows"] = json::array();
      for (const auto& r : rows) {
        json jr{{"nominal_mm", r.nominal_mm},   {"target_mm", r.target_mm},
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
      std::cout << j.dump(2) << "\n";
      return;
    }
    if (!jfit.is_null()) {
      std::cout << fmt::format("slice plane fraction consistent with the data: ({:.4f}, {:.4f}], "
                               "using {:.4f}\n",
                               jfit["plane_fraction_lo"].get<double>(),
                               jfit["plane_fraction_hi"].get<double>(), model.plane_fraction);
    }
    std::cout << fmt::format("{:>9} {:>9} {:>6} {:>9} {:>9} {:>9} {:>9} {:>9}\n", "nominal",
                             "target", "layers", "sliced", "slicing", "measured", "dimens.",
                             "total");
    for (const auto& r : rows) {
      std::cout << fmt::format("{:9.3f} {:9.4f} {:6} {:9.3f} {:9.3f}", r.nominal_mm, r.target_mm,
                               r.layers, r.sliced_mm, r.slicing_error_mm);
      if (r.measured_mm) {
        std::cout << fmt::format(" {:9.3f} {:9.3f} {:9.3f}", *r.measured_mm,
                                 *r.dimensional_error_mm, *r.total_error_mm);
      }
      std::cout << "\n";
    }
  });
}

}  // namespace

void register_process(CLI::App& app) {
  auto* shrink = app.add_subcommand("shrink", "Shrinkage compensation from measured test parts");
  shrink->require_subcommand(1);
  register_shrink_fit(*shrink);
  register_shrink_slicing(*shrink);
}

}  // namespace amctl::cli
