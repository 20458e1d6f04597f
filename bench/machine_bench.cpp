#include <benchmark/benchmark.h>

#include "amctl/machine/loader.hpp"

// Machine loading is once per run, not a hot path; these keep its cost visible (a batch that
// estimates thousands of files with `--set` overrides loads the machine each time).
static void BM_ParsePresetToml(benchmark::State& state) {
  const std::string text(amctl::machine::preset_toml("voron24"));
  for (auto _ : state) {
    benchmark::DoNotOptimize(amctl::machine::parse_machine_toml(text, "voron24.toml"));
  }
}
BENCHMARK(BM_ParsePresetToml);

static void BM_ParseKlipperCfgWithMacros(benchmark::State& state) {
  std::string cfg =
      "[mcu]\nserial: /dev/ttyACM0\n[printer]\nkinematics: corexy\nmax_velocity: 500\n"
      "max_accel: 16000\nsquare_corner_velocity: 5\n"
      "[extruder]\nstep_pin: PB3\nrotation_distance: 22.6789511\ngear_ratio: 50:10\n"
      "microsteps: 16\nnozzle_diameter: 0.4\nfilament_diameter: 1.75\n";
  for (int i = 0; i < 50; ++i) {
    cfg += "[gcode_macro M" + std::to_string(i) + "]\ngcode:\n";
    for (int j = 0; j < 20; ++j) cfg += "    G1 X{params.X|default(10)|float} F6000 ; move\n";
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(amctl::machine::parse_klipper_cfg(cfg, "printer.cfg"));
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * cfg.size()));
}
BENCHMARK(BM_ParseKlipperCfgWithMacros);

static void BM_ApplyOverride(benchmark::State& state) {
  amctl::machine::Machine m;
  for (auto _ : state) {
    amctl::machine::apply_override(m, "printer.max_accel=5000");
    benchmark::DoNotOptimize(m);
  }
}
BENCHMARK(BM_ApplyOverride);
