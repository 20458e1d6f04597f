#pragma once
// Hybrid CoreXY (Markforged): stepper_x = X - Y (the '-' callback
// hybrid_corexy.py allocates for rail 0), stepper_y = Y, stepper_z* = Z; an optional
// [dual_carriage] on X or Y.
// klippy/kinematics/hybrid_corexy.py, chelper/kin_corexy.c (read at 84104bbb, nothing copied).
#include <memory>
#include <string_view>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct HybridCoreXY {
  static constexpr std::string_view kName = "hybrid_corexy";
  Rails rails;
  std::optional<DualCarriage> dual_carriage;
  bool operator==(const HybridCoreXY&) const = default;
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const HybridCoreXY& p, const Context& ctx);

}  // namespace amctl::kinematics
