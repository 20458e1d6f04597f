#include "amctl/core/quantity.hpp"

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl {

std::optional<PhysicalRange> range_for_unit(std::string_view unit) {
  for (const PhysicalRange& r : {kSpeedRange, kAccelRange, kJerkRange, kLengthRange, kFrequencyRange}) {
    if (r.unit == unit) return r;
  }
  return std::nullopt;
}

bool in_range(const PhysicalRange& r, double v) { return std::isfinite(v) && v >= r.min && v <= r.max; }

std::string describe(const PhysicalRange& r) {
  const char* article = r.quantity.empty() || std::string_view("aeiou").find(r.quantity[0]) == std::string_view::npos
                            ? "a"
                            : "an";
  return fmt::format("{} {} in [{:g}, {:g}] {}", article, r.quantity, r.min, r.max, r.unit);
}

void require_in_range(std::string_view what, const PhysicalRange& r, double v) {
  if (!in_range(r, v)) throw Error(fmt::format("{} must be {}, got {}", what, describe(r), v));
}

}  // namespace amctl
