#pragma once
// CoreXZ: stepper_x = X + Z, stepper_y = Y, stepper_z* = X - Z (kin_corexz.c).
// klippy/kinematics/corexz.py, chelper/kin_corexz.c (read at 84104bbb, nothing copied).
#include <memory>
#include <string_view>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct CoreXZ {
  static constexpr std::string_view kName = "corexz";
  Rails rails;
  bool operator==(const CoreXZ&) const = default;
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const CoreXZ& p, const Context& ctx);

}  // namespace amctl::kinematics
