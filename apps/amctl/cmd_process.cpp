// amctl shrink fit | shrink slicing | shrink apply | calibrate-time, and the empirical mode of
// `amctl estimate` (process planning, seed 004). Each command parses its flags, calls one
// function of the process module and prints; file formats and studies live there.
#include <array>
#include <cmath>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/shrink_apply.hpp"
#include "amctl/process/shrink_model.hpp"
#include "amctl/process/slicing_study.hpp"
#include "amctl/process/time_study.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

namespace pr = amctl::process;

std::vector<double> parse_list(const std::string& s, const char* what) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ',')) {
    try {
      std::size_t used = 0;
      const double v = std::stod(tok, &used);
      if (used != tok.size() || !std::isfinite(v)) throw std::invalid_argument(tok);
      out.push_back(v);
    } catch (const std::exception&) {
      throw Error(fmt::format("{}: expected comma-separated finite numbers, got '{}'", what, s));
    }
  }
  return out;
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
                "fit the mean error at each nominal value (the process-planning study's procedure) instead of "
                "every repeated measurement");
  cmd->add_option("--ranges", o->ranges,
                  "number of ranges with breakpoints found from the data (1, 2, ... or auto)");
  cmd->add_option("--breaks", o->breaks, "breakpoints in mm, comma separated (e.g. 10)");
  cmd->add_option("--min-points", o->min_points, "minimum points per automatically found range");
  cmd->add_option("--confidence", o->confidence, "confidence level of the intervals");
  cmd->add_option("--axis", o->axis, "fit only this axis (X, Y or Z)");
  cmd->callback([o] {
    std::optional<char> axis;
    if (!o->axis.empty()) {
      const char a = static_cast<char>(std::toupper(static_cast<unsigned char>(o->axis[0])));
      if (o->axis.size() != 1 || (a != 'X' && a != 'Y' && a != 'Z')) {
        throw Error(fmt::format("--axis: must be X, Y or Z, got '{}'", o->axis));
      }
      axis = a;
    }
    if (!(o->confidence > 0.0 && o->confidence < 1.0)) {
      throw Error(fmt::format("--confidence: must lie strictly between 0 and 1, got {}", o->confidence));
    }
    if (o->min_points < 2) throw Error(fmt::format("--min-points: must be at least 2, got {}", o->min_points));
    pr::ShrinkFitOptions opt;
    opt.average_repeats = o->average;
    opt.min_points_per_range = o->min_points;
    opt.confidence = o->confidence;
    if (!o->breaks.empty()) {
      opt.breaks_mm = parse_list(o->breaks, "--breaks");
      for (const double b : opt.breaks_mm) {
        if (!(b > 0.0)) throw Error(fmt::format("--breaks: must be sizes > 0 mm, got {}", b));
      }
    } else if (o->ranges == "auto") {
      opt.ranges = 0;
    } else {
      const auto v = parse_list(o->ranges, "--ranges");
      if (v.size() != 1 || v[0] < 1 || v[0] != std::floor(v[0])) {
        throw Error(fmt::format("--ranges: must be a whole number >= 1 or 'auto', got '{}'",
                                o->ranges));
      }
      opt.ranges = static_cast<int>(v[0]);
    }
    const auto fits = pr::fit_shrinkage_file(o->file, axis, opt);
    if (o->json) {
      std::cout << pr::shrink_model_json(fits, o->file, o->average).dump(2) << "\n";
    } else {
      for (const auto& f : fits) std::cout << pr::shrink_fit_text(f);
    }
  });
}

void register_shrink_slicing(CLI::App& shrink) {
  auto* cmd = shrink.add_subcommand(
      "slicing", "Slicing, dimensional and total error of layered heights (Table 2 of the UTFPR process-planning study)");
  struct Opts {
    pr::SlicingStudyRequest q;
    std::string factors;
    std::string scaling = "dimension";
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  cmd->add_option("file", o->q.csv_path, "CSV with nominal_mm and optionally measurements")
      ->required();
  cmd->add_option("--measured-column", o->q.measured_column, "column with measured heights (mm)");
  cmd->add_option("--observed-slicing-column", o->q.observed_slicing_column,
                  "column with observed slicing errors (mm): fit the slice-plane position");
  cmd->add_option("--factors", o->factors, "Z compensation, e.g. z=0.9902:10:1.0032");
  cmd->add_option("--scaling", o->scaling, "dimension (the study's per-dimension factors), position (continuous map) or none")
      ->check(CLI::IsMember({"dimension", "position", "none"}));
  cmd->add_option("--layer-mm", o->q.layer_mm, "layer thickness");
  cmd->add_option("--first-layer-mm", o->q.first_layer_mm, "first layer thickness (default: layer)");
  cmd->add_option("--plane-fraction", o->q.plane_fraction,
                  "slice plane position inside a layer, (0,1]: 1 = keep whole layers only, "
                  "0.5 = mid-layer (default 1, or fitted with --observed-slicing-column)");
  cmd->add_flag("--json", o->json, "print one JSON object");
  cmd->callback([o] {
    auto q = o->q;
    if (!o->factors.empty()) q.z_map = pr::parse_factor_spec(o->factors)[2];
    q.scaling = o->scaling == "none"       ? pr::HeightScaling::none
                : o->scaling == "position" ? pr::HeightScaling::position
                                           : pr::HeightScaling::dimension;
    const auto study = pr::slicing_study(q);
    if (o->json) {
      std::cout << pr::slicing_study_json(study).dump(2) << "\n";
    } else {
      std::cout << pr::slicing_study_text(study);
    }
  });
}

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
    pr::ShrinkApplyRequest q;
    q.model_path = o->model;
    q.gcode_path = o->gcode;
    q.output_path = o->out;
    q.factors = pr::load_factor_maps(o->factors);
    if (!o->origin.empty()) {
      const auto v = parse_list(o->origin, "--origin");
      if (v.size() != 3) throw Error(fmt::format("--origin needs x,y,z, got '{}'", o->origin));
      q.origin_mm = std::array<double, 3>{v[0], v[1], v[2]};
    }
    if (!o->format.empty()) {
      q.stl_format = o->format == "ascii" ? pr::StlFormat::ascii : pr::StlFormat::binary;
    }
    // 0 (the default) means no sliced-height prediction; a negative thickness is a typo, not
    // "off".
    // A printed layer: 1 um to 10 mm (0 for --layer-mm: no slicing prediction).
    constexpr PhysicalRange kLayerRange{"layer thickness", "mm", 1e-3, 10.0};
    if (o->layer_mm != 0.0) require_range_flag("--layer-mm", kLayerRange, o->layer_mm);
    if (o->first_layer_mm) require_range_flag("--first-layer-mm", kLayerRange, *o->first_layer_mm);
    if (!(o->plane_fraction > 0.0 && o->plane_fraction <= 1.0)) {
      throw Error(fmt::format("--plane-fraction: must be in (0, 1], got {}", o->plane_fraction));
    }
    if (o->layer_mm > 0.0) {
      q.layers = pr::SlicingModel{o->layer_mm, o->first_layer_mm.value_or(o->layer_mm),
                                  o->plane_fraction};
    }
    q.scale_extrusion = !o->no_scale_e;
    if (o->out == "-" && o->json) {
      throw Error("--json: standard output holds the scaled file (-o -), expected -o FILE");
    }
    const auto rep = pr::shrink_apply(q);
    if (o->out == "-") return;  // standard output holds the scaled file
    std::cout << (o->json ? pr::shrink_apply_json(rep).dump(2) + "\n" : pr::shrink_apply_text(rep));
  });
}

void register_calibrate_time(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "calibrate-time",
      "Fit machine limits (planner) or empirical speeds to measured print durations");
  struct Opts {
    std::string file, mode = "planner", fit, save, params, file_limits = "keep";
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
  CLI::Option* file_limits = add_file_limits_option(*cmd, o->file_limits);
  cmd->add_flag("--keep-file-limits", o->keep_limits,
                "the same as --file-limits keep (the default): honour the files' own limits, "
                "which override the limits being fitted while they last");
  cmd->add_flag("--absolute", o->absolute, "minimise residuals in seconds, not relative ones");
  cmd->add_option("--params", o->params, "empirical mode: starting parameters (JSON)");
  cmd->add_option("--fix", o->fix, "empirical mode: hold a parameter, e.g. wipe_s or wipe_s=0.5");
  cmd->add_flag("--separate-contour", o->separate_contour,
                "empirical mode: fit a contour speed instead of using the raster speed");
  cmd->add_option("--save", o->save, "write the calibrated machine (TOML) or parameters (JSON)");
  cmd->add_flag("--json", o->json, "print one JSON object");
  cmd->callback([o, file_limits] {
    // The output first: a path that cannot be written (or is an input) fails before the fit.
    if (!o->save.empty()) check_output(o->save, OutputOptions{"--save", {o->file, o->params, o->machine.spec}, {}});
    pr::TimeCalibration c;
    if (o->mode == "empirical") {
      c = pr::calibrate_empirical_time({o->file, o->params, o->fix, o->separate_contour});
    } else {
      pr::PlannerCalibrationRequest q;
      q.timings_csv = o->file;
      q.machine = resolve_machine(o->machine);
      std::stringstream ss(o->fit);
      for (std::string tok; std::getline(ss, tok, ',');) q.limits.push_back(tok);
      if (o->keep_limits && file_limits->count() > 0 && o->file_limits != "keep") {
        throw Error(fmt::format("--keep-file-limits: conflicts with --file-limits {}, expected one "
                                "of the two", o->file_limits));
      }
      q.file_limits = file_limits_policy(o->file_limits);
      q.absolute = o->absolute;
      c = pr::calibrate_planner_time(q);
    }
    if (!o->save.empty()) {
      pr::write_file_atomic(o->save, pr::time_calibration_file(c), OutputOptions{"--save", {o->file, o->params}, {}});
    }
    std::cout << (o->json ? pr::time_calibration_json(c).dump(2) + "\n"
                          : pr::time_calibration_text(c));
  });
}

}  // namespace

void run_empirical_estimate(const std::string& file, const std::string& params_json, bool as_json) {
  const auto e = pr::estimate_empirical(file, params_json);
  std::cout << (as_json ? pr::empirical_estimate_json(e).dump(2) + "\n"
                        : pr::empirical_estimate_text(e));
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
