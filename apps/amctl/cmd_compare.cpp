// `amctl compare FILE --machine M --natural-frequency-hz F --damping-ratio Z [--json]
//  [--methods invert,fbf,lpfbf,rfbf,collocation,zv,mzv,ei] [--max-base-accel-mm-s2 A] [--plant-offsets -20,-10,0,10,20]
//  [--sample-rate-hz R] [--layer L]`: every compensation method and the input shapers on one file, the
// plant equal to the model and off by each offset (comparison::compare_file,
// docs/compensation.md, "Comparison").
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/comparison/compare.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct CompareArgs {
  std::string file;
  MachineOptions machine;
  double f_hz = 0.0;
  double zeta = 0.1;
  std::string methods = "invert,fbf,lpfbf,rfbf,collocation,zv,mzv,ei";
  std::optional<double> max_base_accel_mm_s2;
  std::string offsets = "-20,-10,0,10,20";
  double rate_hz = 1000.0;
  std::optional<int> layer;
  bool json = false;
};

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    out.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

double parse_offset_pct(const std::string& text) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size())
    throw Error(fmt::format("--plant-offsets: '{}' is not a number (percent)", text));
  return v;
}

std::string cell(double v, const char* spec) {
  if (!std::isfinite(v)) return std::isinf(v) ? "inf" : "-";
  return fmt::format(fmt::runtime(spec), v);
}

void run_compare(const CompareArgs& a) {
  comparison::ComparisonOptions o;
  o.methods = split_list(a.methods);
  if (a.max_base_accel_mm_s2) o.max_base_accel_mm_s2 = *a.max_base_accel_mm_s2;
  o.plant_offsets_pct.clear();
  for (const auto& t : split_list(a.offsets)) o.plant_offsets_pct.push_back(parse_offset_pct(t));
  o.natural_frequency_hz = a.f_hz;
  o.damping_ratio = a.zeta;
  require_range_flag("--sample-rate-hz", kSampleRateRange, a.rate_hz);
  require_mode_frequency_flag("--natural-frequency-hz", a.f_hz, a.rate_hz);
  require_damping_ratio_flag("--damping-ratio", a.zeta);
  if (a.max_base_accel_mm_s2) require_range_flag("--max-base-accel-mm-s2", kAccelRange, *a.max_base_accel_mm_s2);
  for (const double p : o.plant_offsets_pct) {
    // The plant's frequency F (1 + p/100) must be a mode the simulation can sample too.
    const double f = a.f_hz * (1.0 + p / 100.0);
    if (p > -100.0 && f >= 0.5 * a.rate_hz) {  // -100 % or less: comparison::validate names it
      throw Error(fmt::format("--plant-offsets: must be above -100 % and keep the plant below half the "
                              "sample rate ({} Hz), got {} % ({} Hz)",
                              0.5 * a.rate_hz, p, f));
    }
  }
  o.sample_rate_hz = a.rate_hz;
  o.layer = a.layer;
  comparison::validate(o);
  const machine::Machine m = resolve_machine(a.machine);
  const comparison::ComparisonResult r = comparison::compare_file(a.file, m, o);
  if (a.json) {
    std::cout << comparison::to_json(r).dump(2) << "\n";
    return;
  }
  std::cout << fmt::format(
      "{}{}: model {:.6g} Hz, damping {:.6g}; plant frequency off by the offset; errors in mm\n"
      "contour = max distance of the simulated nozzle to the planned path (every row); tracking "
      "= max/RMS |nozzle - path(t)| (compensation only); vib = max residual vibration; "
      "smooth = shaper's command vs plan; lead = compensation lead-in\n",
      r.file, r.layer ? fmt::format(" layer {}", *r.layer) : "", r.natural_frequency_hz, r.damping_ratio);
  std::cout << fmt::format("{:<14} {:>7} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9} {:>7} {:>11} {:>9} {:>9}\n",
                           "method", "plant%", "contour", "rms_cont", "track", "rms_track", "vib",
                           "smooth", "lead_s", "peak_acc", "compute_s", "x_real");
  for (const auto& row : r.rows) {
    std::cout << fmt::format("{:<14} {:>7} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9} {:>7} {:>11} {:>9} {:>9}{}\n",
                             row.method, fmt::format("{:+g}", row.plant_offset_pct),
                             cell(row.max_contour_error_mm, "{:.5f}"), cell(row.rms_contour_error_mm, "{:.5f}"),
                             cell(row.max_tracking_error_mm, "{:.5f}"), cell(row.rms_tracking_error_mm, "{:.5f}"),
                             cell(row.max_residual_vibration_mm, "{:.5f}"), cell(row.smoothing_mm, "{:.4f}"),
                             cell(row.lead_in_s, "{:.3f}"), cell(row.peak_command_accel_mm_s2, "{:.0f}"),
                             cell(row.compute_time_s, "{:.4f}"), cell(row.real_time_factor, "{:.0f}"),
                             row.status == "ok" ? "" : "  " + row.status);
  }
}

}  // namespace

void register_compare(CLI::App& app) {
  auto a = std::make_shared<CompareArgs>();
  CLI::App* sub = app.add_subcommand(
      "compare", "Every compensation method and input shaper on one file, plant on and off the model");
  sub->add_option("file", a->file, "G-code file")->required();
  add_machine_options(*sub, a->machine);
  sub->add_option("--natural-frequency-hz", a->f_hz, "model natural frequency of X and Y [Hz]")->required();
  sub->add_option("--damping-ratio", a->zeta, "model damping ratio of X and Y (default 0.1)");
  sub->add_option("--methods", a->methods,
                  "comma-separated: invert, fbf, lpfbf, rfbf, collocation (compensation), zv, mzv, ei "
                  "(shapers at the model frequency and damping); default all");
  sub->add_option("--max-base-accel-mm-s2", a->max_base_accel_mm_s2,
                  "bound on the compensation commands' acceleration [mm/s^2]: collocation enforces it, "
                  "the other rows say whether they respect it (default: none)");
  sub->add_option("--plant-offsets", a->offsets,
                  "comma-separated plant frequency offsets [%] (> -100; default -20,-10,0,10,20)");
  sub->add_option("--sample-rate-hz", a->rate_hz, "command step and simulation rate [Hz] (default 1000)");
  sub->add_option("--layer", a->layer,
                  "only the moves of this layer, every row on that span from rest (default: the whole file)");
  sub->add_flag("--json", a->json, "Print JSON");
  sub->callback([a] { run_compare(*a); });
}

}  // namespace amctl::cli
