#include "amctl/machine/motor_presets.hpp"

#include <algorithm>
#include <array>
#include <cctype>

namespace amctl::machine {
namespace {

// docs/machine.md ("Motor presets") gives the source of every number: resistance, inductance,
// holding torque, rated current and step angle from the manufacturers' datasheets; rotor
// inertia and detent torque from the datasheet where it prints them, else the stated
// frame-length assumption.
constexpr std::array<MotorPreset, 4> kPresets = {{
    {"17hs4401", "17HS4401-class NEMA17 1.8 deg, 40 mm (most i3-style printers)", 200, 0.40, 1.7,
     1.5, 2.8e-3, 54e-7, 0.022},
    {"ldo-42sth48-2504ac", "LDO 42STH48-2504AC NEMA17 1.8 deg, 48 mm (Voron 2.4 A/B, 1.8 deg kits)",
     200, 0.55, 2.5, 1.2, 1.5e-3, 82e-7, 0.030},
    {"ldo-42sth48-2004mah", "LDO 42STH48-2004MAH NEMA17 0.9 deg, 48 mm (Voron 2.4 Rev D / Trident A/B)",
     400, 0.44, 2.0, 1.4, 2.0e-3, 82e-7, 0.024},
    {"ldo-42sth40-1004a", "LDO 42STH40-1004A NEMA17 1.8 deg, 40 mm (Prusa i3 MK3/MK3S X, Y)", 200,
     0.49, 1.0, 6.5, 13e-3, 54e-7, 0.027},
}};

bool same(std::string_view a, std::string_view b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

}  // namespace

std::span<const MotorPreset> motor_presets() { return kPresets; }

const MotorPreset* find_motor_preset(std::string_view name) {
  for (const MotorPreset& p : kPresets) {
    if (same(p.name, name)) return &p;
  }
  return nullptr;
}

const MotorPreset& default_motor_preset() { return kPresets[0]; }

std::string motor_preset_names() {
  std::string s;
  for (const MotorPreset& p : kPresets) {
    if (!s.empty()) s += ", ";
    s += p.name;
  }
  return s;
}

}  // namespace amctl::machine
