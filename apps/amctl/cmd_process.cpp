// amctl shrink fit | shrink slicing | shrink apply | calibrate-time, and the empirical mode of
// `amctl estimate` (process planning, seed 004).
#include <array>
#include <cmath>
#include <algorithm>
#include <iostream>
#include <map>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "amctl/core/error.hpp"
#include "amctl/process/calibrate.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/empirical_time.hpp"
#include "amctl/process/time_calibration.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/process/gcode_scale.hpp"
#include "amctl/process/stl.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/shrinkage.hpp"
#include "amctl/process/slicing.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

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


// Builds the X/Y/Z maps from an inline spec or from the JSON that `shrink fit --json` prints.
std::array<pr::AxisMap, 3> load_factors(const std::string& spec) {
  if (spec.size() > 5 && spec.substr(spec.size() - 5) == ".json") {
    json j;
    try {
      j = json::parse(pr::read_file_bytes(spec));
    } catch (const json::exception& e) {
      throw Error(fmt::format("--factors {}: not valid JSON: {}", spec, e.what()));
    }
    std::array<pr::AxisMap, 3> maps{};
    auto one = [&](const json& a) {
      if (!a.contains("axis")) throw Error(fmt::format("--factors {}: fit without 'axis'", spec));
      const std::string ax = a["axis"].get<std::string>();
      const int k = ax == "X" ? 0 : ax == "Y" ? 1 : ax == "Z" ? 2 : -1;
      if (k < 0) throw Error(fmt::format("--factors {}: unknown axis '{}'", spec, ax));
      std::vector<double> f, b;
      if (a.contains("ranges")) {
        for (std::size_t i = 0; i < a["ranges"].size(); ++i) {
          f.push_back(a["ranges"][i]["factor"].get<double>());
          if (i + 1 < a["ranges"].size()) b.push_back(a["ranges"][i]["upper_mm"].get<double>());
        }
      } else {
        f.push_back(a.at("factor").get<double>());
      }
      maps[k] = pr::AxisMap(f, b);
    };
    if (j.contains("axes")) {
      for (const auto& a : j["axes"]) one(a);
    } else {
      one(j);
    }
    return maps;
  }
  return pr::parse_factor_spec(spec);
}

json vec_json(const std::array<double, 3>& v) { return json::array({v[0], v[1], v[2]}); }

void register_shrink_apply(CLI::App& shrink) {
  auto* cmd = shrink.add_subcommand(
      "apply", "Scale an STL model or a G-code file by shrinkage factors (atomic output)");
  struct Opts {
    std::string model, gcode, factors, origin, out, format;
    double layer_mm = 0.0;
    std::optional<double> first_layer_mm;
    double plane_fraction = 0.5;
    bool no_scale_e = false;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  auto* m = cmd->add_option("--model", o->model, "STL model (binary or ASCII)");
  auto* g = cmd->add_option("--gcode", o->gcode, "sliced G-code");
  m->excludes(g);
  cmd->add_option("--factors", o->factors,
                  "x=F,y=F,z=F1:BREAK:F2... (breaks in mm above the origin) or the JSON of "
                  "`shrink fit --json`")->required();
  cmd->add_option("--origin", o->origin,
                  "x,y,z to scale about (default: XY centre of the part, Z = part bottom for "
                  "STL and the bed, Z = 0, for G-code)");
  cmd->add_option("-o,--output", o->out, "output file")->required();
  cmd->add_option("--format", o->format, "STL output: binary or ascii (default: as read)")
      ->check(CLI::IsMember({"binary", "ascii"}));
  cmd->add_option("--layer-mm", o->layer_mm, "layer thickness for the predicted sliced height (STL)");
  cmd->add_option("--first-layer-mm", o->first_layer_mm, "first layer thickness (default: layer)");
  cmd->add_option("--plane-fraction", o->plane_fraction, "slice plane position in a layer (0,1]");
  cmd->add_flag("--no-scale-e", o->no_scale_e, "keep E amounts (G-code)");
  cmd->add_flag("--json", o->json, "print one JSON report");
  cmd->callback([o] {
    if (o->model.empty() == o->gcode.empty()) {
      throw Error("shrink apply needs exactly one of --model FILE.stl or --gcode FILE.gcode");
    }
    pr::ScaleMap map;
    map.axes = load_factors(o->factors);
    std::optional<std::array<double, 3>> origin;
    if (!o->origin.empty()) {
      const auto v = parse_list(o->origin, "--origin");
      if (v.size() != 3) throw Error(fmt::format("--origin needs x,y,z, got '{}'", o->origin));
      origin = std::array<double, 3>{v[0], v[1], v[2]};
    }
    json rep;
    std::array<double, 3> nmin{}, nmax{}, cmin{}, cmax{};
    if (!o->model.empty()) {
      const pr::Mesh mesh = pr::read_stl(o->model);
      pr::require_closed_manifold(mesh, o->model);
      const auto lo = mesh.min_corner(), hi = mesh.max_corner();
      map.origin_mm = origin.value_or(std::array<double, 3>{0.5 * (lo[0] + hi[0]),
                                                            0.5 * (lo[1] + hi[1]), lo[2]});
      const pr::Mesh scaled = pr::scale_mesh(mesh, map);
      const auto fmt_out = o->format.empty() ? mesh.format
                           : o->format == "ascii" ? pr::StlFormat::ascii
                                                  : pr::StlFormat::binary;
      pr::write_file_atomic(o->out, pr::serialize_stl(scaled, fmt_out));
      nmin = lo;
      nmax = hi;
      cmin = scaled.min_corner();
      cmax = scaled.max_corner();
      const auto check = pr::check_mesh(mesh);
      rep["triangles"] = mesh.triangles.size();
      rep["volume_mm3"] = check.volume_mm3;
      rep["scaled_volume_mm3"] = pr::check_mesh(scaled).volume_mm3;
      rep["format"] = fmt_out == pr::StlFormat::ascii ? "ascii" : "binary";
    } else {
      if (!origin) {
        const auto ex = pr::gcode_extrusion_extent(o->gcode);
        origin = std::array<double, 3>{0.5 * (ex.min_mm[0] + ex.max_mm[0]),
                                       0.5 * (ex.min_mm[1] + ex.max_mm[1]), 0.0};
      }
      map.origin_mm = *origin;
      pr::GcodeScaleOptions opt;
      opt.scale_extrusion = !o->no_scale_e;
      const auto r = pr::scale_gcode_file(o->gcode, o->out, map, opt);
      nmin = r.extrusion_min_mm;
      nmax = r.extrusion_max_mm;
      cmin = r.scaled_min_mm;
      cmax = r.scaled_max_mm;
      // Heights in G-code are move Z above the bed (the Z origin): the top layer's Z.
      nmin[2] = cmin[2] = map.origin_mm[2];
      rep["lines"] = r.lines;
      rep["moves_rewritten"] = r.moves_rewritten;
      rep["arcs"] = r.arcs;
      rep["layers"] = r.layers;
      rep["max_arc_radius_mismatch_mm"] = r.max_arc_radius_mismatch_mm;
      rep["filament_mm"] = r.extruded_mm;
      rep["scaled_filament_mm"] = r.scaled_extruded_mm;
    }
    // Predicted printed size: the part shrinks back through the inverse map; in Z the layered
    // height (whole layers of the compensated part) goes through it.
    std::array<double, 3> nominal{}, compensated{}, predicted{};
    for (int a = 0; a < 3; ++a) {
      nominal[a] = nmax[a] - nmin[a];
      compensated[a] = cmax[a] - cmin[a];
      const double o0 = map.origin_mm[a];
      predicted[a] = map.axes[a].inverse(cmax[a] - o0) - map.axes[a].inverse(cmin[a] - o0);
    }
    json jz = nullptr;
    if (o->layer_mm > 0.0) {
      pr::SlicingModel sm{o->layer_mm, o->first_layer_mm.value_or(o->layer_mm), o->plane_fraction};
      const double h = cmax[2] - cmin[2];
      const long n = sm.layers_for(h);
      const double sliced = sm.height_of_layers(n);
      const double bottom = cmin[2] - map.origin_mm[2];
      const double printed = map.axes[2].inverse(bottom + sliced) - map.axes[2].inverse(bottom);
      jz = {{"layers", n}, {"sliced_height_mm", sliced}, {"predicted_printed_height_mm", printed},
            {"nominal_height_mm", nominal[2]}, {"error_mm", printed - nominal[2]}};
    }
    rep["input"] = o->model.empty() ? o->gcode : o->model;
    rep["output"] = o->out;
    rep["origin_mm"] = vec_json(map.origin_mm);
    rep["factors"] = json::array();
    for (int a = 0; a < 3; ++a) {
      rep["factors"].push_back({{"axis", std::string(1, "XYZ"[a])},
                                {"factors", map.axes[a].factors()},
                                {"breaks_mm", map.axes[a].breaks_mm()}});
    }
    rep["nominal_size_mm"] = vec_json(nominal);
    rep["compensated_size_mm"] = vec_json(compensated);
    rep["predicted_printed_size_mm"] = vec_json(predicted);
    rep["sliced_z"] = jz;
    if (o->json) {
      std::cout << rep.dump(2) << "\n";
      return;
    }
    std::cout << fmt::format("wrote {}\n", o->out);
    for (int a = 0; a < 3; ++a) {
      std::cout << fmt::format("  {}: nominal {:.4f} mm -> compensated {:.4f} mm -> predicted "
                               "printed {:.4f} mm\n",
                               "XYZ"[a], nominal[a], compensated[a], predicted[a]);
    }
    if (!jz.is_null()) {
      std::cout << fmt::format("  Z layered: {} layers = {:.4f} mm built -> {:.4f} mm printed "
                               "(error {:+.4f} mm)\n",
                               jz["layers"].get<long>(), jz["sliced_height_mm"].get<double>(),
                               jz["predicted_printed_height_mm"].get<double>(),
                               jz["error_mm"].get<double>());
    }
  });
}

// ---- build time -------------------------------------------------------------------------

json model_json(const pr::EmpiricalTimeModel& m, const pr::ScanOptions& so) {
  return {{"raster_speed_mm_s", m.raster_speed_mm_s},
          {"contour_speed_mm_s", m.contour_speed_mm_s},
          {"link_widths_mm", m.link_widths_mm},
          {"link_speeds_mm_s", m.link_speeds_mm_s},
          {"travel_speed_mm_s", m.travel_speed_mm_s},
          {"layer_change_s", m.layer_change_s},
          {"retract_s", m.retract_s},
          {"wipe_s", m.wipe_s},
          {"fixed_s", m.fixed_s},
          {"link_length_widths", so.link_length_widths},
          {"filament_diameter_mm", so.filament_diameter_mm}};
}

void load_model_json(const std::string& path, pr::EmpiricalTimeModel& m, pr::ScanOptions& so) {
  json j;
  try {
    j = json::parse(pr::read_file_bytes(path));
    if (j.contains("model")) j = j["model"];
    m.raster_speed_mm_s = j.value("raster_speed_mm_s", m.raster_speed_mm_s);
    m.contour_speed_mm_s = j.value("contour_speed_mm_s", m.contour_speed_mm_s);
    m.link_widths_mm = j.value("link_widths_mm", m.link_widths_mm);
    m.link_speeds_mm_s = j.value("link_speeds_mm_s", m.link_speeds_mm_s);
    m.travel_speed_mm_s = j.value("travel_speed_mm_s", m.travel_speed_mm_s);
    m.layer_change_s = j.value("layer_change_s", m.layer_change_s);
    m.retract_s = j.value("retract_s", m.retract_s);
    m.wipe_s = j.value("wipe_s", m.wipe_s);
    m.fixed_s = j.value("fixed_s", m.fixed_s);
    so.link_length_widths = j.value("link_length_widths", so.link_length_widths);
    so.filament_diameter_mm = j.value("filament_diameter_mm", so.filament_diameter_mm);
  } catch (const json::exception& e) {
    throw Error(fmt::format("--params {}: {}", path, e.what()));
  }
  so.link_widths_mm = m.link_widths_mm;
  m.validate();
}

json features_json(const pr::TimeFeatures& f, const pr::EmpiricalTimeModel& m) {
  const auto names = pr::empirical_parameter_names(m);
  const auto row = pr::empirical_row(f, m);
  const auto p = pr::empirical_parameters(m);
  json terms = json::object();
  for (std::size_t i = 0; i < names.size(); ++i) terms[names[i]] = row[i] * p[i];
  return {{"raster_mm", f.raster_mm},     {"contour_mm", f.contour_mm},
          {"link_mm", f.link_mm},         {"link_mm_by_width", f.link_mm_by_width},
          {"travel_mm", f.travel_mm},     {"layer_changes", f.layer_changes},
          {"retracts", f.retracts},       {"wipes", f.wipes},
          {"time_terms_s", terms}};
}

void register_calibrate_time(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "calibrate-time",
      "Fit machine limits (planner) or empirical speeds to measured print durations");
  struct Opts {
    std::string file, mode = "planner", fit, save, params;
    std::vector<std::string> fix;
    MachineOptions machine;
    bool keep_limits = false, absolute = false, json = false, separate_contour = false;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("file", o->file,
                  "CSV: gcode,duration_s[,layer] (paths relative to the CSV)")->required();
  cmd->add_option("--mode", o->mode, "planner (fit machine limits) or empirical (fit speeds)")
      ->check(CLI::IsMember({"planner", "empirical"}));
  add_machine_options(*cmd, o->machine);
  cmd->add_option("--fit", o->fit,
                  "limits to fit, comma separated: accel, scv, jd, jerk, max_velocity "
                  "(default: accel, the junction limit of the machine, max_velocity)");
  cmd->add_flag("--keep-file-limits", o->keep_limits,
                "honour M201/M203/M204/M205/SET_VELOCITY_LIMIT in the files (they would "
                "override the limits being fitted)");
  cmd->add_flag("--absolute", o->absolute, "minimise residuals in seconds, not relative ones");
  cmd->add_option("--params", o->params, "empirical mode: starting parameters (JSON)");
  cmd->add_option("--fix", o->fix, "empirical mode: hold a parameter, e.g. wipe_s or wipe_s=0.5");
  cmd->add_flag("--separate-contour", o->separate_contour,
                "empirical mode: fit a contour speed instead of using the raster speed");
  cmd->add_option("--save", o->save, "write the calibrated machine (TOML) or parameters (JSON)");
  cmd->add_flag("--json", o->json, "print one JSON object");
  cmd->callback([o] {
    const auto table = pr::CsvTable::read(o->file);
    const auto timings = pr::read_print_timings(table);
    std::vector<double> measured;
    for (const auto& t : timings) measured.push_back(t.duration_s);
    json j;
    j["file"] = o->file;
    j["mode"] = o->mode;
    if (o->mode == "empirical") {
      auto model = pr::EmpiricalTimeModel::fdm2000_seed();
      pr::ScanOptions so;
      if (!o->params.empty()) load_model_json(o->params, model, so);
      so.link_widths_mm = model.link_widths_mm;
      pr::EmpiricalFitOptions fo;
      fo.contour_equals_raster = !o->separate_contour;
      const auto names = pr::empirical_parameter_names(model);
      auto values = pr::empirical_parameters(model);
      for (const auto& f : o->fix) {
        const auto eq = f.find('=');
        const std::string name = f.substr(0, eq);
        const auto it = std::find(names.begin(), names.end(), name);
        if (it == names.end()) throw Error(fmt::format("--fix: unknown parameter '{}'", name));
        if (eq != std::string::npos) {
          values[static_cast<std::size_t>(it - names.begin())] = parse_list(f.substr(eq + 1), "--fix")[0];
        }
        fo.fixed.push_back(name);
      }
      model = pr::with_parameters(model, values);
      std::map<std::string, pr::GcodeTimeScan> scans;
      std::vector<pr::TimeFeatures> xs;
      for (const auto& t : timings) {
        auto it = scans.find(t.gcode_path);
        if (it == scans.end()) {
          it = scans.emplace(t.gcode_path, pr::scan_gcode_file_for_time(t.gcode_path, so)).first;
        }
        if (!t.layer) {
          xs.push_back(it->second.total);
        } else {
          if (*t.layer >= static_cast<long>(it->second.layers.size())) {
            throw Error(fmt::format("{}:{}: {} has no layer {}", o->file, t.csv_line,
                                    t.gcode_path, *t.layer));
          }
          xs.push_back(it->second.layers[static_cast<std::size_t>(*t.layer)]);
        }
      }
      const auto fit = pr::fit_empirical(xs, measured, model, fo);
      j["parameters"] = json::array();
      for (std::size_t i = 0; i < fit.names.size(); ++i) {
        j["parameters"].push_back({{"name", fit.names[i]}, {"value", fit.values[i]},
                                   {"std_error", num(fit.std_errors[i])},
                                   {"free", static_cast<bool>(fit.free[i])}});
      }
      j["not_identified"] = fit.not_identified;
      j["model"] = model_json(fit.model, so);
      j["samples"] = json::array();
      for (std::size_t i = 0; i < timings.size(); ++i) {
        j["samples"].push_back({{"gcode", timings[i].gcode_path},
                                {"layer", timings[i].layer ? json(*timings[i].layer) : json(nullptr)},
                                {"measured_s", measured[i]}, {"predicted_s", fit.predicted_s[i]},
                                {"residual_s", fit.residual_s[i]}});
      }
      j["rms_s"] = fit.rms_s;
      j["dof"] = fit.dof;
      if (!o->save.empty()) pr::write_file_atomic(o->save, model_json(fit.model, so).dump(2) + "\n");
      if (o->json) {
        std::cout << j.dump(2) << "\n";
        return;
      }
      for (std::size_t i = 0; i < fit.names.size(); ++i) {
        std::cout << fmt::format("  {:<18} {:12.6g} {}\n", fit.names[i], fit.values[i],
                                 fit.free[i] ? fmt::format("+- {:.3g}", fit.std_errors[i])
                                             : std::string("(fixed)"));
      }
      std::cout << fmt::format("  speeds: raster {:.2f} mm/s, travel {:.2f} mm/s; rms residual "
                               "{:.2f} s\n",
                               fit.model.raster_speed_mm_s, fit.model.travel_speed_mm_s, fit.rms_s);
      return;
    }
    const auto base = resolve_machine(o->machine);
    const auto names = o->fit.empty() ? pr::default_limits_for(base) : [&] {
      std::vector<std::string> v;
      std::stringstream ss(o->fit);
      std::string tok;
      while (std::getline(ss, tok, ',')) v.push_back(tok);
      return v;
    }();
    const auto params = pr::limit_parameters(base, names);
    const auto est = pr::planner_duration_estimator(base, names, timings, o->keep_limits);
    pr::CalibrationOptions co;
    co.relative = !o->absolute;
    const auto r = pr::calibrate_durations(est, measured, params, co);
    j["machine"] = base.name;
    j["parameters"] = json::array();
    for (std::size_t i = 0; i < r.names.size(); ++i) {
      j["parameters"].push_back({{"name", r.names[i]}, {"start", params[i].initial},
                                 {"value", r.values[i]}, {"std_error", num(r.std_errors[i])},
                                 {"ci", {num(r.ci_lo[i]), num(r.ci_hi[i])}},
                                 {"identifiable", static_cast<bool>(r.identifiable[i])}});
    }
    j["correlation"] = r.correlation;
    j["samples"] = json::array();
    for (std::size_t i = 0; i < timings.size(); ++i) {
      j["samples"].push_back({{"gcode", timings[i].gcode_path},
                              {"layer", timings[i].layer ? json(*timings[i].layer) : json(nullptr)},
                              {"measured_s", r.measured_s[i]}, {"predicted_s", r.predicted_s[i]},
                              {"residual_s", r.residual_s[i]},
                              {"relative_residual", r.relative_residual[i]}});
    }
    j["rms_s"] = r.rms_s;
    j["rms_relative"] = r.rms_relative;
    j["iterations"] = r.iterations;
    j["evaluations"] = r.evaluations;
    j["converged"] = r.converged;
    j["dof"] = r.dof;
    if (!o->save.empty()) {
      auto m = base;
      for (std::size_t i = 0; i < names.size(); ++i) pr::set_limit(m, names[i], r.values[i]);
      pr::write_file_atomic(o->save, machine::to_toml(m));
    }
    if (o->json) {
      std::cout << j.dump(2) << "\n";
      return;
    }
    std::cout << fmt::format("calibrated {} from {} timing(s), {} iteration(s){}\n", base.name,
                             timings.size(), r.iterations, r.converged ? "" : " (not converged)");
    for (std::size_t i = 0; i < r.names.size(); ++i) {
      std::cout << fmt::format("  {:<13} {:10.4g}  +- {:<9.3g} 95% CI [{:.4g}, {:.4g}]{}\n",
                               r.names[i], r.values[i], r.std_errors[i], r.ci_lo[i], r.ci_hi[i],
                               r.identifiable[i] ? "" : "  (no effect on these prints: not fitted)");
    }
    for (std::size_t i = 0; i < timings.size(); ++i) {
      std::cout << fmt::format("  {:<40} measured {:9.1f} s  planned {:9.1f} s  residual {:+8.2f} s "
                               "({:+.2f} %)\n",
                               timings[i].gcode_path + (timings[i].layer ? fmt::format("#{}", *timings[i].layer) : ""),
                               r.measured_s[i], r.predicted_s[i], r.residual_s[i],
                               100 * r.relative_residual[i]);
    }
  });
}

}  // namespace

void run_empirical_estimate(const std::string& file, const std::string& params_json, bool as_json) {
  auto model = pr::EmpiricalTimeModel::fdm2000_seed();
  pr::ScanOptions so;
  if (!params_json.empty()) load_model_json(params_json, model, so);
  so.link_widths_mm = model.link_widths_mm;
  const auto scan = pr::scan_gcode_file_for_time(file, so);
  const double t = model.estimate_s(scan.total);
  if (as_json) {
    json j{{"file", file}, {"mode", "empirical"}, {"total_time_s", t},
           {"model", model_json(model, so)}, {"features", features_json(scan.total, model)},
           {"layers", scan.layers.size()},
           {"mean_raster_width_mm", scan.mean_raster_width_mm},
           {"slicer_estimate_s", scan.slicer_estimate_s ? json(*scan.slicer_estimate_s) : json(nullptr)}};
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << fmt::format("{}: empirical {:.1f} s ({:.2f} min); raster {:.0f} mm, links {:.0f} mm, "
                           "contour {:.0f} mm, travel {:.0f} mm, {} layers\n",
                           file, t, t / 60, scan.total.raster_mm, scan.total.link_mm,
                           scan.total.contour_mm, scan.total.travel_mm, scan.layers.size());
}

void register_process(CLI::App& app) {
  auto* shrink = app.add_subcommand("shrink", "Shrinkage compensation from measured test parts");
  shrink->require_subcommand(1);
  register_shrink_fit(*shrink);
  register_shrink_slicing(*shrink);
  register_shrink_apply(*shrink);
  register_calibrate_time(app);
}

}  // namespace amctl::cli
