#pragma once
// The checks of the thermal studies' inputs, one set for every caller: `amctl thermal
// sls-margins|sls|hotend|bed` and amctl.sls_margins / sls_build / hotend / bed. Each value
// must lie in its physical range (core/quantity.hpp); the error names the parameter as the
// caller spells it (a flag on the command line, a keyword in Python).
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "amctl/thermal/studies.hpp"

namespace amctl::thermal {

/// The caller's name of a parameter, given its Python keyword ("power_w" -> "--power-w").
using ParamName = std::function<std::string(std::string_view keyword)>;

/// sls-margins: kp_w_m2k, ti_s, modes, length_mm (checked on length_m), density_kg_m3,
/// specific_heat_j_kgk, conductivity_w_mk, beta_1_s, hamiltonian_modes. Throws amctl::Error
/// "NAME: must be ..., got V".
void check_margin_study(const MarginStudyOptions& o, const ParamName& name);
/// hotend / bed: target_c, noise_k, cycles, power_w, capacity_j_k, loss_w_k, fan_loss_w_k,
/// sensor_tau_s, sensor_delay_s, core_capacity_j_k, core_to_block_w_k, and a heater that can
/// reach the target (power_w named).
void check_heater_study(const HeaterStudyOptions& o, const ParamName& name);
/// sls: the number of layer additions given to override the configuration's (none: kept).
void check_sls_layers(std::optional<int> layers, const ParamName& name);

}  // namespace amctl::thermal
