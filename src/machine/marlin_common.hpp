#pragma once
// Internal: what the Marlin readers (marlin_m503.cpp, marlin_configuration.cpp) share.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/machine/machine.hpp"

namespace amctl::machine::detail {

struct MarlinLine {
  std::string_view text;  ///< without its '\n'
  std::uint64_t number = 0;  ///< 1-based
};
std::vector<MarlinLine> split_lines(std::string_view text);

/// A decimal number as Marlin prints it or a C literal writes it ("80.00", "-2", "0.013f",
/// "20000UL", "1e-3"). Throws Error(where, "LABEL: found '...', expected a number").
double parse_marlin_number(std::string_view text, const SourceLocation& where, std::string_view label);

/// A Marlin cartesian machine named after the file, every other key at its default.
Machine marlin_base_machine(const std::string& source_name);
/// Sets stepper `name` to `steps_per_mm` with `microsteps` of a 200-step motor.
void set_steps_per_mm(Machine& m, const std::string& name, double steps_per_mm, int microsteps);
/// The toolhead keys from the Marlin ones (velocity: the XY feedrate limit; accel: print
/// accel), then validate().
void finish_marlin_machine(Machine& m, const std::string& source_name);

}  // namespace amctl::machine::detail
