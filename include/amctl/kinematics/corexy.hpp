#pragma once
// CoreXY: stepper_x = A = X + Y, stepper_y = B = X - Y (kin_corexy.c; corexy.py gives
// rail 0 the '+' callback, rail 1 the '-' one), stepper_z* = Z.
// klippy/kinematics/corexy.py, chelper/kin_corexy.c (read at 84104bbb, nothing copied).
#include <memory>
#include <string_view>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct CoreXY {
  static constexpr std::string_view kName = "corexy";
  Rails rails;
  bool operator==(const CoreXY&) const = default;
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const CoreXY& p, const Context& ctx);

}  // namespace amctl::kinematics
