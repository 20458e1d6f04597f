// One set of checks of the thermal studies' inputs (amctl/thermal/checks.hpp).
#include "amctl/thermal/checks.hpp"

#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/process_ranges.hpp"
#include "amctl/thermal/powder_bed_sim.hpp"

namespace amctl::thermal {
namespace {

void range(const ParamName& name, std::string_view keyword, const PhysicalRange& r, double v) {
  if (!in_range(r, v)) throw Error(fmt::format("{}: must be {}, got {}", name(keyword), describe(r), v));
}

}  // namespace

void check_margin_study(const MarginStudyOptions& o, const ParamName& name) {
  // Beyond these ranges the modal state space overflows.
  range(name, "length_mm", PhysicalRange{"powder depth", "mm", 1e-3, 1e4}, o.length_m * 1e3);
  range(name, "kp_w_m2k", kHeatTransferGainRange, o.kp_w_m2k);
  range(name, "ti_s", kTimeConstantRange, o.ti_s);
  range(name, "density_kg_m3", kDensityRange, o.material.density_kg_m3);
  range(name, "specific_heat_j_kgk", kSpecificHeatRange, o.material.specific_heat_j_kgk);
  range(name, "conductivity_w_mk", kConductivityRange, o.material.conductivity_w_mk);
  if (!(std::isfinite(o.beta_1_s) && o.beta_1_s < 0.0)) {
    throw Error(fmt::format("{}: must be a finite number < 0 [1/s], got {}", name("beta_1_s"), o.beta_1_s));
  }
  if (o.modes < 1) throw Error(fmt::format("{}: must be >= 1 (N), got {}", name("modes"), o.modes));
  if (o.hamiltonian_modes < 1) {
    throw Error(fmt::format("{}: must be >= 1, got {}", name("hamiltonian_modes"), o.hamiltonian_modes));
  }
}

void check_heater_study(const HeaterStudyOptions& o, const ParamName& name) {
  range(name, "target_c", kTemperatureRange, o.target_c);
  range(name, "noise_k", PhysicalRange{"temperature noise", "K", 0.0, 100.0}, o.sensor_noise_k);
  if (o.cycles < 3 || o.cycles > 1000) {
    throw Error(fmt::format("{}: must be in [3, 1000], got {}", name("cycles"), o.cycles));
  }
  const HeaterPlantParams& p = o.plant;
  range(name, "power_w", kPowerRange, p.heater_power_w);
  range(name, "capacity_j_k", kHeatCapacityRange, p.block_capacity_j_k);
  range(name, "loss_w_k", kConductanceRange, p.loss_w_k);
  // 0: no fan, no delay, no heater-core node.
  if (p.fan_extra_loss_w_k != 0.0) range(name, "fan_loss_w_k", kConductanceRange, p.fan_extra_loss_w_k);
  range(name, "sensor_tau_s", kTimeConstantRange, p.sensor_time_constant_s);
  if (p.sensor_delay_s != 0.0) range(name, "sensor_delay_s", kTimeConstantRange, p.sensor_delay_s);
  if (p.core_capacity_j_k != 0.0) range(name, "core_capacity_j_k", kHeatCapacityRange, p.core_capacity_j_k);
  range(name, "core_to_block_w_k", kConductanceRange, p.core_to_block_w_k);
  if (o.target_c < p.ambient_c + 20.0) {
    throw Error(fmt::format("{}: must be at least 20 K above ambient ({:g} C) for the relay test, got {:g}",
                            name("target_c"), p.ambient_c, o.target_c));
  }
  // The relay test needs a heater that can reach the target: at full power the block settles
  // at ambient + power / loss (fan off).
  const double reach_c = p.ambient_c + p.heater_power_w / p.loss_w_k;
  if (!(reach_c > o.target_c + 5.0)) {
    throw Error(fmt::format("{}: must bring the block 5 K above {} {:g} C at full power (ambient {:g} C + "
                            "power / {} {:g} W/K = {:.6g} C), got {:g}",
                            name("power_w"), name("target_c"), o.target_c, p.ambient_c, name("loss_w_k"),
                            p.loss_w_k, reach_c, p.heater_power_w));
  }
}

void check_sls_layers(std::optional<int> layers, const ParamName& name) {
  if (layers && (*layers < 0 || *layers > kMaxSlsLayers)) {
    throw Error(fmt::format("{}: must be in [0, {}], got {}", name("layers"), kMaxSlsLayers, *layers));
  }
}

}  // namespace amctl::thermal
