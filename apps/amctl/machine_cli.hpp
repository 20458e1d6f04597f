#pragma once
// Shared `--machine` / `--set` options for every subcommand that needs a printer.
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "amctl/machine/machine.hpp"
#include "amctl/plan/file_limits.hpp"

namespace amctl::cli {

struct MachineOptions {
  std::string spec;                    ///< preset name, .toml or printer.cfg; "" = default
  std::vector<std::string> overrides;  ///< "section.key=value", applied in order
};

/// Adds `--machine SPEC` and `--set section.key=value` (repeatable) to `cmd`.
void add_machine_options(CLI::App& cmd, MachineOptions& options);

/// load_machine(spec, overrides): the validated machine, or amctl::Error.
machine::Machine resolve_machine(const MachineOptions& options);

/// Adds `--file-limits keep|ignore|cap` (what to do with the file's own M201/M203/M204/M205/
/// M566/SET_VELOCITY_LIMIT; default keep, as the firmware does) to `cmd`; returns the option.
CLI::Option* add_file_limits_option(CLI::App& cmd, std::string& value);
/// The policy named by the option's value ("keep", "ignore", "cap").
plan::FileLimits file_limits_policy(const std::string& value);

}  // namespace amctl::cli
