#include "amctl/core/quantity.hpp"

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl {

namespace {

// The motor and driver keys of a stepper (machine/schema.cpp, docs/machine.md): ranges that
// hold every hobby and industrial stepper from a NEMA 8 to a NEMA 42 with a wide margin, so that
// 1e308 or 1e-300 (a typo, a unit mix-up) is refused at its key instead of simulated.
/// Motor currents: 1 mA to 100 A.
constexpr PhysicalRange kCurrentRange{"current", "A", 1e-3, 100.0};
/// Driver supply: 0.1 V to 1000 V.
constexpr PhysicalRange kVoltageRange{"voltage", "V", 0.1, 1000.0};
/// Holding and detent torque: 1 uN m to 1000 N m.
constexpr PhysicalRange kTorqueRange{"torque", "N m", 1e-6, 1000.0};
/// Phase resistance: 1 mOhm to 10 kOhm.
constexpr PhysicalRange kResistanceRange{"resistance", "ohm", 1e-3, 1e4};
/// Phase inductance: 1 uH to 10 H.
constexpr PhysicalRange kInductanceRange{"inductance", "H", 1e-6, 10.0};
/// Rotor inertia: 1e-10 kg m^2 (a NEMA 8 is about 2e-7) to 1 kg m^2.
constexpr PhysicalRange kInertiaRange{"inertia", "kg m^2", 1e-10, 1.0};

}  // namespace

std::optional<PhysicalRange> range_for_unit(std::string_view unit) {
  for (const PhysicalRange& r : {kSpeedRange, kAccelRange, kJerkRange, kLengthRange, kFrequencyRange,
                                 kCurrentRange, kVoltageRange, kTorqueRange, kResistanceRange,
                                 kInductanceRange, kInertiaRange}) {
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
