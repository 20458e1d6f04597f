#pragma once
// Physical ranges of process quantities (heat and extrusion), as core/quantity.hpp has them
// for motion: what each may be in amctl, in its unit. Used by the readers, the commands and
// the Python functions alike (amctl/thermal/checks.hpp, the G-code's SET_PRESSURE_ADVANCE).
#include "amctl/core/quantity.hpp"

namespace amctl {

/// Heater models (amctl thermal hotend/bed, amctl.hotend/bed): a heater power, a heat
/// capacity, a thermal conductance, a time constant or delay, a temperature (above absolute
/// zero, below any heater's reach).
inline constexpr PhysicalRange kPowerRange{"power", "W", 1e-3, 1e6};
inline constexpr PhysicalRange kHeatCapacityRange{"heat capacity", "J/K", 1e-6, 1e9};
inline constexpr PhysicalRange kConductanceRange{"thermal conductance", "W/K", 1e-9, 1e6};
inline constexpr PhysicalRange kTimeConstantRange{"time constant", "s", 1e-6, 1e6};
inline constexpr PhysicalRange kTemperatureRange{"temperature", "C", -273.15, 3000.0};
/// The SLS powder bed's PI study: gains, an integral time, a depth, the material's properties.
inline constexpr PhysicalRange kHeatTransferGainRange{"gain", "W/(m^2 K)", 1e-9, 1e9};
inline constexpr PhysicalRange kDensityRange{"density", "kg/m^3", 1e-3, 1e5};
inline constexpr PhysicalRange kSpecificHeatRange{"specific heat", "J/(kg K)", 1e-3, 1e6};
inline constexpr PhysicalRange kConductivityRange{"conductivity", "W/(m K)", 1e-6, 1e4};

/// Pressure advance (Klipper's pressure_advance, SET_PRESSURE_ADVANCE ADVANCE=): 0 (off) to
/// 2 s, twice the top of Klipper's tuning tower for a long Bowden tube; beyond, the extruder's
/// step count grows without bound (1e6 s never finished).
inline constexpr PhysicalRange kPressureAdvanceRange{"pressure advance", "s", 0.0, 2.0};

}  // namespace amctl
