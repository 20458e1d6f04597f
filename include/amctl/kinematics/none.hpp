#pragma once
// Klipper's `none` kinematics (klippy/kinematics/none.py): no motors and no check; the
// toolhead's limits only. A developer kinematics, also what amctl's `default` preset uses
// when it plans without knowing the printer's motors.
#include <memory>
#include <string_view>

#include "amctl/kinematics/kinematics.hpp"

namespace amctl::kinematics {

struct None {
  static constexpr std::string_view kName = "none";
  bool operator==(const None&) const = default;
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const None& p, const Context& ctx);

}  // namespace amctl::kinematics
