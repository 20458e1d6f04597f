#include "amctl/process/shrink_apply.hpp"

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/process/csv.hpp"

namespace amctl::process {
namespace {
Json vec_json(const std::array<double, 3>& v) { return Json::array({v[0], v[1], v[2]}); }
}  // namespace

SizePrediction predict_printed_size(const ScaleMap& map, const std::array<double, 3>& nmin,
                                    const std::array<double, 3>& nmax,
                                    const std::array<double, 3>& cmin,
                                    const std::array<double, 3>& cmax,
                                    const std::optional<SlicingModel>& layers) {
  SizePrediction p;
  for (int a = 0; a < 3; ++a) {
    p.nominal_mm[a] = nmax[a] - nmin[a];
    p.compensated_mm[a] = cmax[a] - cmin[a];
    const double o0 = map.origin_mm[a];
    p.predicted_mm[a] = map.axes[a].inverse(cmax[a] - o0) - map.axes[a].inverse(cmin[a] - o0);
  }
  if (layers) {
    const double h = cmax[2] - cmin[2];
    SlicedHeight z;
    z.layers = layers->layers_for(h);
    z.sliced_height_mm = layers->height_of_layers(z.layers);
    const double bottom = cmin[2] - map.origin_mm[2];
    z.predicted_printed_height_mm =
        map.axes[2].inverse(bottom + z.sliced_height_mm) - map.axes[2].inverse(bottom);
    z.nominal_height_mm = p.nominal_mm[2];
    z.error_mm = z.predicted_printed_height_mm - p.nominal_mm[2];
    p.sliced_z = z;
  }
  return p;
}

ShrinkApplyReport shrink_apply(const ShrinkApplyRequest& q) {
  if (q.model_path.empty() == q.gcode_path.empty()) {
    throw Error("shrink apply needs exactly one of --model FILE.stl or --gcode FILE.gcode");
  }
  if (q.origin_mm) {
    for (const double v : *q.origin_mm) {
      if (!std::isfinite(v) || std::fabs(v) > 1e9) {
        throw Error(fmt::format("--origin: must be finite coordinates within 1e9 mm, got {}", v));
      }
    }
  }
  // The output first: one that cannot be written, or is the input, fails before any reading.
  check_output(q.output_path, OutputOptions{"-o/--output", {q.model_path, q.gcode_path}, {}});
  ShrinkApplyReport rep;
  rep.input = q.model_path.empty() ? q.gcode_path : q.model_path;
  rep.output = q.output_path;
  rep.map.axes = q.factors;
  std::array<double, 3> nmin{}, nmax{}, cmin{}, cmax{};
  if (!q.model_path.empty()) {
    const Mesh mesh = read_stl(q.model_path);
    require_closed_manifold(mesh, q.model_path);
    const auto lo = mesh.min_corner(), hi = mesh.max_corner();
    rep.map.origin_mm = q.origin_mm.value_or(
        std::array<double, 3>{0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), lo[2]});
    const Mesh scaled = scale_mesh(mesh, rep.map);
    StlApplyReport s;
    s.format = q.stl_format.value_or(mesh.format);
    write_file_atomic(q.output_path, serialize_stl(scaled, s.format),
                      OutputOptions{"-o/--output", {q.model_path}, {}});
    nmin = lo;
    nmax = hi;
    cmin = scaled.min_corner();
    cmax = scaled.max_corner();
    s.triangles = mesh.triangles.size();
    s.volume_mm3 = check_mesh(mesh).volume_mm3;
    s.scaled_volume_mm3 = check_mesh(scaled).volume_mm3;
    rep.stl = s;
  } else {
    // The extent pass and the scaling pass over one rewindable input (standard input and a
    // FIFO are read once; the second pass reads the reader's copy).
    InputFile input(q.gcode_path, gcode::gcode_input_options(!q.origin_mm.has_value()));
    if (q.origin_mm) {
      rep.map.origin_mm = *q.origin_mm;
    } else {
      const auto ex = gcode_extrusion_extent(input);
      rep.map.origin_mm = {0.5 * (ex.min_mm[0] + ex.max_mm[0]),
                           0.5 * (ex.min_mm[1] + ex.max_mm[1]), 0.0};
    }
    GcodeScaleOptions opt;
    opt.scale_extrusion = q.scale_extrusion;
    const auto r = scale_gcode_file(input, q.output_path, rep.map, opt);
    nmin = r.extrusion_min_mm;
    nmax = r.extrusion_max_mm;
    cmin = r.scaled_min_mm;
    cmax = r.scaled_max_mm;
    // Heights in G-code are move Z above the bed (the Z origin): the top layer's Z.
    nmin[2] = cmin[2] = rep.map.origin_mm[2];
    rep.gcode = r;
  }
  rep.prediction = predict_printed_size(rep.map, nmin, nmax, cmin, cmax, q.layers);
  return rep;
}

Json shrink_apply_json(const ShrinkApplyReport& rep) {
  Json j;
  if (rep.stl) {
    j["triangles"] = rep.stl->triangles;
    j["volume_mm3"] = rep.stl->volume_mm3;
    j["scaled_volume_mm3"] = rep.stl->scaled_volume_mm3;
    j["format"] = rep.stl->format == StlFormat::ascii ? "ascii" : "binary";
  }
  if (rep.gcode) {
    const auto& r = *rep.gcode;
    j["lines"] = r.lines;
    j["moves_rewritten"] = r.moves_rewritten;
    j["arcs"] = r.arcs;
    j["layers"] = r.layers;
    j["max_arc_radius_mismatch_mm"] = r.max_arc_radius_mismatch_mm;
    j["filament_mm"] = r.extruded_mm;
    j["scaled_filament_mm"] = r.scaled_extruded_mm;
  }
  j["input"] = rep.input;
  j["output"] = rep.output;
  j["origin_mm"] = vec_json(rep.map.origin_mm);
  j["factors"] = Json::array();
  for (int a = 0; a < 3; ++a) {
    j["factors"].push_back({{"axis", std::string(1, "XYZ"[a])},
                            {"factors", rep.map.axes[a].factors()},
                            {"breaks_mm", rep.map.axes[a].breaks_mm()}});
  }
  const auto& p = rep.prediction;
  j["nominal_size_mm"] = vec_json(p.nominal_mm);
  j["compensated_size_mm"] = vec_json(p.compensated_mm);
  j["predicted_printed_size_mm"] = vec_json(p.predicted_mm);
  j["sliced_z"] = nullptr;
  if (p.sliced_z) {
    const auto& z = *p.sliced_z;
    j["sliced_z"] = {{"layers", z.layers},
                     {"sliced_height_mm", z.sliced_height_mm},
                     {"predicted_printed_height_mm", z.predicted_printed_height_mm},
                     {"nominal_height_mm", z.nominal_height_mm},
                     {"error_mm", z.error_mm}};
  }
  return j;
}

std::string shrink_apply_text(const ShrinkApplyReport& rep) {
  const auto& p = rep.prediction;
  std::string s = fmt::format("wrote {}\n", rep.output);
  for (int a = 0; a < 3; ++a) {
    s += fmt::format("  {}: nominal {:.4f} mm -> compensated {:.4f} mm -> predicted "
                     "printed {:.4f} mm\n",
                     "XYZ"[a], p.nominal_mm[a], p.compensated_mm[a], p.predicted_mm[a]);
  }
  if (p.sliced_z) {
    s += fmt::format("  Z layered: {} layers = {:.4f} mm built -> {:.4f} mm printed "
                     "(error {:+.4f} mm)\n",
                     p.sliced_z->layers, p.sliced_z->sliced_height_mm,
                     p.sliced_z->predicted_printed_height_mm, p.sliced_z->error_mm);
  }
  return s;
}

}  // namespace amctl::process
