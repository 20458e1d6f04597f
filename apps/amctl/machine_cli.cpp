// Shared --machine/--set options.
#include "machine_cli.hpp"

#include "amctl/machine/loader.hpp"

namespace amctl::cli {

void add_machine_options(CLI::App& cmd, MachineOptions& options) {
  cmd.add_option("--machine,-m", options.spec,
                 "Printer: preset name (amctl machine list), machine .toml or Klipper "
                 "printer.cfg (default: the 'default' preset)");
  cmd.add_option("--set", options.overrides,
                 "Override a machine key, section.key=value (docs/machine.md); repeatable");
}

machine::Machine resolve_machine(const MachineOptions& options) {
  return machine::load_machine(options.spec, options.overrides);
}

CLI::Option* add_file_limits_option(CLI::App& cmd, std::string& value) {
  value = "keep";
  return cmd
      .add_option("--file-limits", value,
                  "The file's own limits (M204, SET_VELOCITY_LIMIT, M201, M203, M205, M566): keep "
                  "(default, as the firmware does: they override the machine's), ignore (plan on "
                  "the machine's limits alone) or cap (apply them, never above the machine's)")
      ->check(CLI::IsMember({"keep", "ignore", "cap"}))
      ->default_str("keep");
}

plan::FileLimits file_limits_policy(const std::string& value) {
  return plan::parse_file_limits(value).value_or(plan::FileLimits::keep);
}

}  // namespace amctl::cli
