#include "amctl/process/scale_map.hpp"

#include <cctype>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::process {

AxisMap::AxisMap(std::vector<double> factors, std::vector<double> breaks_mm)
    : factors_(std::move(factors)), breaks_(std::move(breaks_mm)) {
  if (factors_.size() != breaks_.size() + 1) {
    throw Error(fmt::format("a scale map with {} breakpoint(s) needs {} factor(s), got {}",
                            breaks_.size(), breaks_.size() + 1, factors_.size()));
  }
  for (std::size_t i = 0; i < factors_.size(); ++i) {
    // A shrinkage compensation: no material shrinks or grows by half (1e300 would scale a
    // part beyond any machine; a coordinate would overflow).
    if (!std::isfinite(factors_[i]) || factors_[i] < kMinScaleFactor || factors_[i] > kMaxScaleFactor) {
      throw Error(fmt::format("scale factor {} must be a number in [{}, {}] (a shrinkage "
                              "compensation), got {}",
                              i + 1, kMinScaleFactor, kMaxScaleFactor, factors_[i]));
    }
  }
  for (std::size_t i = 0; i < breaks_.size(); ++i) {
    if (!std::isfinite(breaks_[i]) || breaks_[i] <= 0.0 || breaks_[i] > 1e9) {
      throw Error(fmt::format("breakpoint {} must be a finite number in (0, 1e9] mm, got {}", i + 1,
                              breaks_[i]));
    }
    if (i > 0 && !(breaks_[i] > breaks_[i - 1])) {
      throw Error(fmt::format("breakpoints must be strictly increasing: {} mm follows {} mm",
                              breaks_[i], breaks_[i - 1]));
    }
  }
  double g = 0.0, prev = 0.0;
  for (std::size_t i = 0; i < breaks_.size(); ++i) {
    g += factors_[i] * (breaks_[i] - prev);
    knots_.push_back(g);
    prev = breaks_[i];
  }
}

double AxisMap::map(double u) const {
  std::size_t i = 0;
  while (i < breaks_.size() && u > breaks_[i]) ++i;
  if (i == 0) return factors_[0] * u;
  return knots_[i - 1] + factors_[i] * (u - breaks_[i - 1]);
}

double AxisMap::inverse(double v) const {
  std::size_t i = 0;
  while (i < knots_.size() && v > knots_[i]) ++i;
  if (i == 0) return v / factors_[0];
  return breaks_[i - 1] + (v - knots_[i - 1]) / factors_[i];
}

double AxisMap::slope_at(double u) const {
  std::size_t i = 0;
  while (i < breaks_.size() && u > breaks_[i]) ++i;
  return factors_[i];
}

bool AxisMap::is_identity() const {
  for (double f : factors_) {
    if (f != 1.0) return false;
  }
  return true;
}

namespace {

double parse_number(std::string_view s, std::string_view what) {
  double v = 0.0;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v)) {
    throw Error(fmt::format("--factors: {} must be a number, got '{}'", what, s));
  }
  return v;
}

}  // namespace

std::array<AxisMap, 3> parse_factor_spec(std::string_view spec) {
  std::array<AxisMap, 3> out{};
  std::array<bool, 3> seen{};
  if (spec.empty()) throw Error("--factors: empty specification (expected e.g. z=0.9902:10:1.0032)");
  std::size_t pos = 0;
  while (pos <= spec.size()) {
    std::size_t comma = spec.find(',', pos);
    if (comma == std::string_view::npos) comma = spec.size();
    const std::string_view item = spec.substr(pos, comma - pos);
    pos = comma + 1;
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos) {
      throw Error(fmt::format("--factors: item '{}' must look like axis=factor[:break:factor...]",
                              item));
    }
    std::string name(item.substr(0, eq));
    for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    std::vector<int> axes;
    if (name == "x") axes = {0};
    else if (name == "y") axes = {1};
    else if (name == "z") axes = {2};
    else if (name == "xy") axes = {0, 1};
    else if (name == "all" || name == "xyz") axes = {0, 1, 2};
    else throw Error(fmt::format("--factors: unknown axis '{}' (expected x, y, z, xy or all)", name));
    std::vector<double> factors, breaks;
    std::string_view rest = item.substr(eq + 1);
    int idx = 0;
    std::size_t p2 = 0;
    while (p2 <= rest.size()) {
      std::size_t colon = rest.find(':', p2);
      if (colon == std::string_view::npos) colon = rest.size();
      const std::string_view tok = rest.substr(p2, colon - p2);
      if (idx % 2 == 0) factors.push_back(parse_number(tok, fmt::format("{} factor", name)));
      else breaks.push_back(parse_number(tok, fmt::format("{} breakpoint", name)));
      ++idx;
      p2 = colon + 1;
      if (colon == rest.size()) break;
    }
    for (int a : axes) {
      if (seen[a]) throw Error(fmt::format("--factors: axis {} given twice", "XYZ"[a]));
      seen[a] = true;
      try {
        out[a] = AxisMap(factors, breaks);
      } catch (const Error& e) {
        throw Error(fmt::format("--factors: {} {}", name, e.what()));
      }
    }
    if (comma == spec.size()) break;
  }
  return out;
}

}  // namespace amctl::process
