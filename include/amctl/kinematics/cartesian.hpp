#pragma once
// Cartesian: stepper_x = X, stepper_y = Y, stepper_z* = Z (kin_cartesian.c). An optional
// [dual_carriage] adds a second carriage on X or Y (IDEX, idex_modes.py).
// klippy/kinematics/cartesian.py, chelper/kin_cartesian.c (read at 84104bbb, nothing copied).
#include <memory>
#include <string_view>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct Cartesian {
  static constexpr std::string_view kName = "cartesian";
  Rails rails;
  std::optional<DualCarriage> dual_carriage;
  bool operator==(const Cartesian&) const = default;
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const Cartesian& p, const Context& ctx);

}  // namespace amctl::kinematics
