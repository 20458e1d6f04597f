// `amctl machine ...`: inspect machine descriptions.
//   amctl machine show [SPEC] [--set section.key=value]... [--json]
//   amctl machine list            presets compiled into amctl
//   amctl machine keys [--json]   every key of the TOML schema with its unit
#include <iostream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/bedmesh/config.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/machine/effective.hpp"
#include "amctl/machine/json.hpp"
#include "amctl/machine/loader.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

namespace mc = amctl::machine;

struct ShowOptions {
  MachineOptions machine;
  bool json = false;
};

void show(const ShowOptions& o) {
  const mc::Machine m = resolve_machine(o.machine);
  // Klipper's [bed_mesh] (docs/bedmesh.md): listed only for a printer.cfg that has it.
  const std::optional<bedmesh::Settings> mesh =
      m.klipper_config.empty() ? std::nullopt
                               : bedmesh::read_klipper(m.klipper_config, SourceLocation{o.machine.spec, 0, 0});
  if (o.json) {
    Json j = mc::to_json(m);
    j["source"] = o.machine.spec.empty() ? "default" : o.machine.spec;
    if (mesh) j["bed_mesh"] = bedmesh::to_json(*mesh);
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << mc::to_toml(m);
  std::cout << fmt::format(
      "\n# Effective limits (derived as Klipper derives them):\n"
      "#   max_z_velocity            {} mm/s\n"
      "#   max_z_accel               {} mm/s^2\n"
      "#   max_extrude_only_velocity {:.6g} mm/s\n"
      "#   max_extrude_only_accel    {:.6g} mm/s^2\n"
      "#   max_extrude_cross_section {:.6g} mm^2\n"
      "#   junction deviation        {:.6g} mm at max_accel (square_corner_velocity)\n",
      mc::effective_max_z_velocity_mm_s(m), mc::effective_max_z_accel_mm_s2(m),
      mc::effective_max_extrude_only_velocity_mm_s(m),
      mc::effective_max_extrude_only_accel_mm_s2(m),
      mc::effective_max_extrude_cross_section_mm2(m),
      mc::klipper_junction_deviation_mm(m.square_corner_velocity_mm_s, m.max_accel_mm_s2));
  if (mesh) std::cout << bedmesh::to_text(*mesh);
}

}  // namespace

void register_machine(CLI::App& app) {
  CLI::App* machine = app.add_subcommand("machine", "Inspect machine descriptions");
  machine->require_subcommand(1);

  auto opts = std::make_shared<ShowOptions>();
  CLI::App* show_cmd = machine->add_subcommand(
      "show", "Print the resolved machine (preset, .toml or Klipper printer.cfg) as TOML");
  show_cmd->add_option("spec", opts->machine.spec,
                       "Preset name, machine .toml or Klipper printer.cfg (default: 'default')");
  show_cmd->add_option("--set", opts->machine.overrides,
                       "Override a key: section.key=value (see docs/machine.md), repeatable");
  show_cmd->add_flag("--json", opts->json, "Print one JSON object");
  show_cmd->callback([opts] { show(*opts); });

  machine->add_subcommand("list", "List the presets compiled into amctl")->callback([] {
    for (const std::string& name : mc::preset_names()) {
      const mc::Machine m = mc::preset(name);
      std::cout << fmt::format("{:<12} {} {} {}\n", name, mc::to_string(m.firmware),
                               kinematics::name_of(m.kinematics), mc::to_string(m.junction));
    }
  });

  auto keys_json = std::make_shared<bool>(false);
  CLI::App* keys = machine->add_subcommand("keys", "List every machine key with its unit");
  keys->add_flag("--json", *keys_json, "Print one JSON object");
  keys->callback([keys_json] {
    const auto all = mc::schema();
    if (*keys_json) {
      std::cout << mc::schema_json().dump(2) << "\n";
      return;
    }
    for (const auto& k : all) {
      const auto r = range_for_unit(k.unit);
      std::cout << fmt::format("{}.{} [{}{}{}]: {}\n", k.section, k.key, k.type,
                               k.unit.empty() ? "" : ", " + k.unit,
                               r ? fmt::format(", {:g} to {:g}", r->min, r->max) : std::string(), k.description);
    }
  });
}

}  // namespace amctl::cli
