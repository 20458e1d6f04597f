#pragma once
// Hybrid CoreXZ: stepper_x = X - Z (the '-' callback hybrid_corexz.py allocates
// for rail 0), stepper_y = Y, stepper_z* = Z; an optional [dual_carriage] on X or Y.
// klippy/kinematics/hybrid_corexz.py, chelper/kin_corexz.c (read at 84104bbb, nothing copied).
#include <memory>
#include <string_view>

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {

struct HybridCoreXZ {
  static constexpr std::string_view kName = "hybrid_corexz";
  Rails rails;
  std::optional<DualCarriage> dual_carriage;
  bool operator==(const HybridCoreXZ&) const = default;
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const HybridCoreXZ& p, const Context& ctx);

}  // namespace amctl::kinematics
