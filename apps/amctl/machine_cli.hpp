#pragma once
// Shared `--machine` / `--set` options for every subcommand that needs a printer.
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "amctl/machine/machine.hpp"

namespace amctl::cli {

struct MachineOptions {
  std::string spec;                    ///< preset name, .toml or printer.cfg; "" = default
  std::vector<std::string> overrides;  ///< "section.key=value", applied in order
};

/// Adds `--machine SPEC` and `--set section.key=value` (repeatable) to `cmd`.
void add_machine_options(CLI::App& cmd, MachineOptions& options);

/// load_machine(spec, overrides): the validated machine, or amctl::Error.
machine::Machine resolve_machine(const MachineOptions& options);

}  // namespace amctl::cli
