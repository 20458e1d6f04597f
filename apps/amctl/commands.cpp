#include "commands.hpp"

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"

namespace amctl::cli {
void register_all(CLI::App& app) {
  register_estimate(app);
  register_plan(app);
  register_report(app);
  register_dynamics(app);
  register_compensate(app);
  register_compare(app);
  register_thermal(app);
  register_process(app);
  register_machine(app);
  register_shaper(app);
  register_resonance(app);
  register_steps(app);
  register_stepper(app);
}

void require_positive_flag(std::string_view flag, double value) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw Error(fmt::format("{}: must be a finite number > 0, got {}", flag, value));
  }
}

void require_range_flag(std::string_view flag, const PhysicalRange& range, double value) {
  if (!in_range(range, value)) throw Error(fmt::format("{}: must be {}, got {}", flag, describe(range), value));
}

void require_non_negative_flag(std::string_view flag, double value) {
  if (!(std::isfinite(value) && value >= 0.0)) {
    throw Error(fmt::format("{}: must be a finite number >= 0, got {}", flag, value));
  }
}
}  // namespace amctl::cli
