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

}  // namespace amctl::cli
