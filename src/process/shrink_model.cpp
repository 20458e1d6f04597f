#include "amctl/process/shrink_model.hpp"
#include "amctl/core/text_input.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/json_file.hpp"

namespace amctl::process {
namespace {

Json range_json(const RangeFit& r, double confidence) {
  Json j;
  j["n"] = r.line.n;
  j["levels"] = r.levels;
  j["lower_mm"] = r.lower_mm;
  j["upper_mm"] = json_number(r.upper_mm);
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
  j["factor_ci"] = {json_number(r.factor_ci_lo), json_number(r.factor_ci_hi)};
  j["r2"] = r.line.r2;
  j["residual_sd_mm"] = r.line.residual_sd;
  j["sse_mm2"] = r.line.sse;
  j["pure_error_sd_mm"] = r.pure_error_sd_mm;
  j["lack_of_fit_p"] = r.lack_of_fit_p ? Json(*r.lack_of_fit_p) : Json(nullptr);
  return j;
}

Json axis_json(const AxisShrinkFit& a) {
  Json j;
  if (a.ranges.size() == 1) {
    j = range_json(a.ranges.front(), a.confidence);
  } else {
    j["ranges"] = Json::array();
    Json breaks = Json::array();
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

// One axis object at JSON pointer `at` into maps[axis].
void read_axis(const JsonFile& f, const std::string& at, std::array<AxisMap, 3>& maps,
               std::array<bool, 3>& seen) {
  const Json& a = f.root().at(Json::json_pointer(at.empty() ? "" : at));
  if (!a.is_object()) f.fail(at, "expected an object with \"axis\" and \"factor\" or \"ranges\"");
  if (!a.contains("axis")) f.fail(at, "fit without \"axis\" (expected \"X\", \"Y\" or \"Z\")");
  const Json& ax = a["axis"];
  const std::string name = ax.is_string() ? ax.get<std::string>() : ax.dump();
  const int k = name == "X" ? 0 : name == "Y" ? 1 : name == "Z" ? 2 : -1;
  if (k < 0) f.fail(at + "/axis", fmt::format("unknown axis '{}': expected X, Y or Z", name));
  if (seen[static_cast<std::size_t>(k)]) f.fail(at + "/axis", fmt::format("axis {} given twice", name));
  seen[static_cast<std::size_t>(k)] = true;
  std::vector<double> factors, breaks;
  if (a.contains("ranges")) {
    const Json& r = a["ranges"];
    if (!r.is_array() || r.empty()) f.fail(at + "/ranges", "\"ranges\" must be a non-empty array");
    for (std::size_t i = 0; i < r.size(); ++i) {
      const std::string ri = fmt::format("{}/ranges/{}", at, i);
      factors.push_back(f.number(ri + "/factor"));
      if (i + 1 < r.size()) breaks.push_back(f.number(ri + "/upper_mm"));
    }
  } else {
    if (!a.contains("factor")) f.fail(at, "expected \"factor\" or \"ranges\"");
    factors.push_back(f.number(at + "/factor"));
  }
  try {
    maps[static_cast<std::size_t>(k)] = AxisMap(factors, breaks);
  } catch (const Error& e) {
    f.fail(at, e.detail());
  }
}

}  // namespace

std::vector<AxisShrinkFit> fit_shrinkage_file(const std::string& csv_path, std::optional<char> axis,
                                              const ShrinkFitOptions& options) {
  const auto table = CsvTable::read(csv_path);
  auto samples = read_shrink_samples(table);
  if (axis) {
    const char a = static_cast<char>(std::toupper(static_cast<unsigned char>(*axis)));
    if (a != 'X' && a != 'Y' && a != 'Z') {
      throw Error(fmt::format("axis must be X, Y or Z, got '{}'", *axis));
    }
    std::erase_if(samples, [a](const ShrinkSample& s) { return s.axis != a; });
    if (samples.empty()) throw Error(fmt::format("{}: no samples for axis {}", csv_path, a));
  }
  return fit_shrinkage(samples, options);
}

Json shrink_model_json(const std::vector<AxisShrinkFit>& fits, const std::string& csv_path,
                       bool averaged) {
  Json j;
  if (fits.size() == 1) {
    j = axis_json(fits.front());
  } else {
    j["axes"] = Json::array();
    for (const auto& f : fits) j["axes"].push_back(axis_json(f));
  }
  j["file"] = csv_path;
  j["fitted"] = averaged ? "means" : "measurements";
  return j;
}

std::array<AxisMap, 3> parse_shrink_model(const std::string& text, const std::string& name) {
  const JsonFile f = JsonFile::parse(text, name);
  std::array<AxisMap, 3> maps{};
  std::array<bool, 3> seen{};
  if (f.root().is_object() && f.root().contains("axes")) {
    const Json& axes = f.root()["axes"];
    if (!axes.is_array() || axes.empty()) f.fail("/axes", "\"axes\" must be a non-empty array");
    for (std::size_t i = 0; i < axes.size(); ++i) read_axis(f, fmt::format("/axes/{}", i), maps, seen);
  } else {
    read_axis(f, "", maps, seen);
  }
  return maps;
}

std::array<AxisMap, 3> read_shrink_model(const std::string& path) {
  return parse_shrink_model(read_whole_text(path, InputOptions{"shrink model (JSON)", false, 64ull << 20}), path);
}

std::array<AxisMap, 3> load_factor_maps(const std::string& spec) {
  if (spec.size() > 5 && spec.substr(spec.size() - 5) == ".json") return read_shrink_model(spec);
  return parse_factor_spec(spec);
}

std::string shrink_fit_text(const AxisShrinkFit& a) {
  std::string s = fmt::format("axis {}: {} range(s){}\n", a.axis, a.ranges.size(),
                              a.breaks_from_data ? " (breakpoints found from the data)" : "");
  for (const auto& r : a.ranges) {
    s += fmt::format(
        "  {:>7.3f} < h <= {:<8} n={:<3} E = {:+.6f} h {:+.5f} mm  (se {:.6f}, {:.5f})  R2={:.4f}\n"
        "                      C = {:.5f} +- {:.5f}  {:.0f}% CI [{:.5f}, {:.5f}]\n",
        r.lower_mm, std::isfinite(r.upper_mm) ? fmt::format("{:.3f}", r.upper_mm) : "inf",
        r.line.n, r.line.slope, r.line.intercept, r.line.slope_se, r.line.intercept_se,
        r.line.r2, r.factor, r.factor_se, 100 * a.confidence, r.factor_ci_lo, r.factor_ci_hi);
  }
  return s;
}

}  // namespace amctl::process
